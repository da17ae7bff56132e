"""Map layers for the fitted camera: its position (point) and its view footprint (polygon), in a "Monoplot" group.

Memory layers are replaced in place on every fit (same names, found by a custom property), so the layer tree does
not fill up with copies. The outputs issue writes permanent files; these layers are for looking.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator, Optional

from qgis.core import (QgsCoordinateReferenceSystem, QgsFeature, QgsField, QgsFillSymbol, QgsGeometry,
                       QgsMarkerSymbol, QgsPointXY, QgsProject, QgsSingleSymbolRenderer, QgsVectorLayer)
from qgis.PyQt.QtCore import QVariant
from qgis.PyQt.QtGui import QColor

from ..core.camera import Camera

__all__ = ["camera_layer", "footprint_layer", "show_camera_layers", "remove_camera_layers", "crs_from_wkt",
           "GROUP_NAME", "rebuilt_on_reopen",
           "derived_layers_only", "mark_modified_later", "style_xyz_layer"]

GROUP_NAME = "Monoplot"
_ROLE = "monoplot/role"


def crs_from_wkt(wkt: str) -> QgsCoordinateReferenceSystem:
    """The QGIS CRS of a core ``crs_wkt`` (WKT or "EPSG:n"); an invalid CRS for "".

    When QGIS does not take the WKT (seen intermittently in a fresh QGIS session running Processing algorithms: an
    XYZ raster refused with "unreadable CRS", map features written without a CRS), GDAL's reading of it is tried:
    its EPSG code, else its PROJ string."""
    if not wkt:
        return QgsCoordinateReferenceSystem()
    if ":" in wkt[:12] and "[" not in wkt:
        return QgsCoordinateReferenceSystem(wkt)  # "EPSG:n"
    crs = QgsCoordinateReferenceSystem.fromWkt(wkt)
    if crs.isValid():
        return crs
    from osgeo import osr

    srs = osr.SpatialReference()
    if srs.ImportFromWkt(wkt) != 0:
        return crs
    srs.AutoIdentifyEPSG()
    code = srs.GetAuthorityCode(None)
    if code and srs.GetAuthorityName(None) == "EPSG":
        crs = QgsCoordinateReferenceSystem(f"EPSG:{code}")
    if not crs.isValid():
        crs = QgsCoordinateReferenceSystem.fromProj(srs.ExportToProj4())
    return crs


def _crs(camera: Camera, fallback: Optional[QgsCoordinateReferenceSystem]) -> QgsCoordinateReferenceSystem:
    crs = crs_from_wkt(camera.crs_wkt)
    return crs if crs.isValid() else (fallback or QgsCoordinateReferenceSystem())


@contextmanager
def derived_layers_only(project: QgsProject) -> Iterator[None]:
    """Inside the block, rebuilding layers that Monoplot derives from the project's state (camera, footprint, the
    map layers of drawn features) does not mark a clean project modified: reopening a saved project asked "save
    the current project?" on every close (desktop trial)."""
    dirty = project.isDirty()
    try:
        yield
    finally:
        if not dirty and project.isDirty():
            project.setDirty(False)


def mark_modified_later(project: QgsProject) -> None:
    """Mark ``project`` modified once the event loop runs: work restored from an autosave is not in the project file
    yet, and QGIS clears the modified flag at the end of reading a project (a flag set while it reads is lost)."""
    from qgis.PyQt.QtCore import QTimer

    QTimer.singleShot(0, lambda: project.setDirty(True))


def rebuilt_on_reopen(layer: QgsVectorLayer) -> QgsVectorLayer:
    """Mark a memory layer that Monoplot fills again from the project's state when the project is opened (camera,
    footprint, drawn features): QGIS then leaves it out of its "temporary scratch layers ... will be permanently
    lost" question on closing, which every quit asked because of these layers alone (desktop trial)."""
    layer.setCustomProperty("skipMemoryLayersCheck", 1)  # the property QGIS's own check reads
    return layer


def camera_layer(camera: Camera, crs: Optional[QgsCoordinateReferenceSystem] = None,
                 name: str = "Monoplot camera") -> QgsVectorLayer:
    """Point memory layer with the camera position and its parameters as attributes."""
    crs = _crs(camera, crs)
    layer = QgsVectorLayer(f"Point?crs={crs.authid() or 'EPSG:4326'}", name, "memory")
    if not crs.authid():
        layer.setCrs(crs)
    layer.dataProvider().addAttributes([QgsField(n, QVariant.Double) for n in CAMERA_FIELDS])
    layer.updateFields()
    layer.dataProvider().addFeatures([_camera_feature(layer, camera)])
    symbol = QgsMarkerSymbol.createSimple({"name": "star", "color": "255,40,40", "size": "6",
                                           "outline_color": "white", "outline_width": "0.6"})
    layer.setRenderer(QgsSingleSymbolRenderer(symbol))
    layer.setCustomProperty(_ROLE, "camera")
    return rebuilt_on_reopen(layer)


#: the attributes of the camera layer's point
CAMERA_FIELDS = ("x", "y", "z", "heading", "pitch", "roll", "fov", "focal_px")


def _camera_feature(layer: QgsVectorLayer, camera: Camera) -> QgsFeature:
    f = QgsFeature(layer.fields())
    x, y, z = camera.position
    f.setGeometry(QgsGeometry.fromPointXY(QgsPointXY(x, y)))
    f.setAttributes([x, y, z, camera.heading, camera.pitch, camera.roll, camera.fov, camera.focal_px])
    return f


def _footprint_features(wkt: str) -> list:
    geom = QgsGeometry.fromWkt(wkt) if wkt else QgsGeometry()
    if geom.isNull():
        return []
    f = QgsFeature()
    f.setGeometry(geom)
    return [f]


def footprint_layer(wkt: str, crs: QgsCoordinateReferenceSystem, name: str = "Monoplot view footprint"
                    ) -> QgsVectorLayer:
    """Polygon memory layer holding the visible area (WKT polygon or multipolygon in ``crs``)."""
    layer = QgsVectorLayer(f"MultiPolygon?crs={crs.authid() or 'EPSG:4326'}", name, "memory")
    if not crs.authid():
        layer.setCrs(crs)
    layer.dataProvider().addFeatures(_footprint_features(wkt))
    symbol = QgsFillSymbol.createSimple({"color": "40,130,255,55", "outline_color": "40,130,255",
                                         "outline_width": "0.5"})
    layer.setRenderer(QgsSingleSymbolRenderer(symbol))
    layer.setCustomProperty(_ROLE, "footprint")
    return rebuilt_on_reopen(layer)


def remove_camera_layers(project: QgsProject, other: bool = False) -> None:
    """Remove the fitted camera's layers (``other``: those of a camera shown beside it)."""
    roles = ("other camera", "other footprint") if other else ("camera", "footprint")
    ids = [lid for lid, lyr in project.mapLayers().items() if lyr.customProperty(_ROLE) in roles]
    if ids:
        project.removeMapLayers(ids)
        group = project.layerTreeRoot().findGroup(GROUP_NAME)
        if group is not None and not group.children():  # an empty group stayed in the Layers panel (a trial)
            group.parent().removeChildNode(group)


def show_camera_layers(project: QgsProject, camera: Camera, footprint_wkt: str,
                       crs: Optional[QgsCoordinateReferenceSystem] = None, other: str = ""):
    """Replace the camera and footprint layers of ``project`` (top of a "Monoplot" group); returns both.

    ``other``: a camera shown beside the fitted one, not instead of it (e.g. ``"automatic, uncertain"``: a doubtful
    automatic registration the person's own fit was kept over), in its own pair of layers named after it; purple.
    """
    if not other:
        refilled = _refill_camera_layers(project, camera, footprint_wkt, _crs(camera, crs))
        if refilled is not None:
            return refilled
    remove_camera_layers(project, other=bool(other))
    suffix = f" ({other})" if other else ""
    cam = camera_layer(camera, crs, name="Monoplot camera" + suffix)
    foot = footprint_layer(footprint_wkt, cam.crs(), name="Monoplot view footprint" + suffix)
    if other:  # purple: it stands out on a grey hillshade and from the fitted camera's red and blue
        cam.renderer().symbol().setColor(QColor(150, 50, 210))
        cam.renderer().symbol().setSize(9.0)  # larger: a rim around the fitted camera's star when they are close
        foot.setRenderer(QgsSingleSymbolRenderer(QgsFillSymbol.createSimple(
            {"color": "150,50,210,35", "outline_color": "150,50,210", "outline_width": "0.7",
             "outline_style": "dash"})))
        cam.setCustomProperty(_ROLE, "other camera")
        foot.setCustomProperty(_ROLE, "other footprint")
    root = project.layerTreeRoot()
    group = root.findGroup(GROUP_NAME) or root.insertGroup(0, GROUP_NAME)
    for layer in (foot, cam):
        project.addMapLayer(layer, False)
        group.insertLayer(0, layer)
    return cam, foot


def _refill_camera_layers(project: QgsProject, camera: Camera, footprint_wkt: str,
                          crs: QgsCoordinateReferenceSystem):
    """(camera layer, footprint layer) of ``project`` filled anew with ``camera`` and its footprint, when both are
    there as Monoplot made them and in ``crs``; else None. Layers removed and added again marked a reopened project
    modified in the desktop, after the read (the layer tree's deferred update: "save the project?" on every quit,
    a trial); their features replaced do not, and the person's styling of them stays."""
    found = {role: [lyr for lyr in project.mapLayers().values() if lyr.customProperty(_ROLE) == role]
             for role in ("camera", "footprint")}
    if len(found["camera"]) != 1 or len(found["footprint"]) != 1:
        return None
    cam, foot = found["camera"][0], found["footprint"][0]
    if not (isinstance(cam, QgsVectorLayer) and isinstance(foot, QgsVectorLayer) and cam.isValid()
            and foot.isValid() and cam.providerType() == "memory" and foot.providerType() == "memory"
            and cam.crs() == crs and foot.crs() == crs and tuple(cam.fields().names()) == CAMERA_FIELDS):
        return None
    for layer, features in ((cam, [_camera_feature(cam, camera)]), (foot, _footprint_features(footprint_wkt))):
        provider = layer.dataProvider()
        provider.truncate()
        if features and not provider.addFeatures(features)[0]:
            return None
        layer.updateExtents()
        layer.triggerRepaint()
    return cam, foot


def style_xyz_layer(layer) -> None:
    """An XYZ raster layer (:mod:`..outputs.xyz_raster`) as the dock and Processing show it: no CRS (photo pixel
    space, drawn without reprojection), Z (band 3) as the colour ramp of :mod:`..outputs.xyz_style` (the look its
    style file gives a file added by hand) over the layer's Z range."""
    from qgis.core import (QgsColorRampShader, QgsCoordinateReferenceSystem, QgsGradientColorRamp,
                           QgsGradientStop, QgsRasterBandStats, QgsRasterShader, QgsSingleBandPseudoColorRenderer)
    from qgis.PyQt.QtGui import QColor

    from ..outputs.xyz_style import Z_BAND, Z_OPACITY, Z_RAMP

    layer.setCrs(QgsCoordinateReferenceSystem())
    provider = layer.dataProvider()
    if provider is None or provider.bandCount() < Z_BAND:
        return
    stats = provider.bandStatistics(Z_BAND, QgsRasterBandStats.Stats.Min | QgsRasterBandStats.Stats.Max)
    if stats.minimumValue < stats.maximumValue:
        (_, first), *middle, (_, last) = Z_RAMP
        ramp = QgsGradientColorRamp(QColor(first), QColor(last), False,
                                    [QgsGradientStop(t, QColor(colour)) for t, colour in middle])
        shader_fn = QgsColorRampShader(stats.minimumValue, stats.maximumValue, ramp,
                                       QgsColorRampShader.Type.Interpolated)
        shader_fn.classifyColorRamp(len(Z_RAMP), -1)
        shader = QgsRasterShader()
        shader.setRasterShaderFunction(shader_fn)
        renderer = QgsSingleBandPseudoColorRenderer(provider, Z_BAND, shader)
        renderer.setClassificationMin(stats.minimumValue)
        renderer.setClassificationMax(stats.maximumValue)
        layer.setRenderer(renderer)
    layer.setOpacity(Z_OPACITY)
