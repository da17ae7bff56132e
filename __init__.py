"""QGIS entry point of the Monoplot plugin (the folder is installed as the package ``monoplot``)."""


def classFactory(iface):  # noqa: N802 (name required by QGIS)
    """Return the plugin instance QGIS loads; ``iface`` is the running QgisInterface."""
    try:
        # Icons compiled from resources.qrc by `make resources` / `make package`; registers ":/plugins/monoplot/...".
        from . import resources_rc  # noqa: F401
    except ImportError:
        pass  # a plain source checkout: plugin.plugin_icon() falls back to the SVG file on disk
    from .monoplot_plugin.plugin import MonoplotPlugin

    return MonoplotPlugin(iface)
