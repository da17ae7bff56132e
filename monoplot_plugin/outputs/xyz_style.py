"""How an XYZ raster (:mod:`.xyz_raster`) looks in QGIS: Z (band 3) as a colour ramp from low (blue) to high (red).

One definition, used twice: the dock and Processing style the layers they add with it
(:func:`~..adapters.layers.style_xyz_layer`), and every XYZ raster written gets it as a QGIS style file beside it
(``name.qml`` for ``name.tif``), which QGIS loads by itself when the file is added by hand (Browser, drag and drop,
Add Raster Layer). Without it QGIS drew the three coordinate bands as red, green and blue: a grey-brown noise that
a desktop trial took for a broken file.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional, Sequence, Tuple
from xml.sax.saxutils import quoteattr

__all__ = ["Z_RAMP", "Z_OPACITY", "Z_BAND", "style_path", "write_xyz_style"]

#: (position 0-1 between the lowest and the highest Z, colour): the "Spectral" ramp reversed, low blue, high red.
Z_RAMP: Sequence[Tuple[float, str]] = ((0.0, "#2b83ba"), (0.25, "#abdda4"), (0.5, "#ffffbf"), (0.75, "#fdae61"),
                                       (1.0, "#d7191c"))
#: Opacity of the layer: the terrain under it stays readable.
Z_OPACITY = 0.8
#: Band of the XYZ raster drawn.
Z_BAND = 3


def style_path(raster_path) -> Path:
    """The QGIS style file QGIS looks for beside a raster: the same name with ``.qml``.

    >>> style_path("/data/photo_xyz.tif").name
    'photo_xyz.qml'
    """
    return Path(os.fspath(raster_path)).with_suffix(".qml")


def write_xyz_style(raster_path, z_min: Optional[float], z_max: Optional[float]) -> Optional[Path]:
    """Write :func:`style_path` of ``raster_path``: Z from ``z_min`` (first colour of :data:`Z_RAMP`) to ``z_max``
    (last). Nothing (None) without a finite range, or when the file cannot be written: the raster is the product,
    its look is a convenience.

    >>> import tempfile, xml.etree.ElementTree as ET
    >>> path = write_xyz_style(Path(tempfile.mkdtemp()) / "a.tif", 500.0, 1500.0)
    >>> renderer = ET.parse(path).find("pipe/rasterrenderer")
    >>> renderer.get("type"), renderer.get("band"), [i.get("value") for i in renderer.iter("item")][:2]
    ('singlebandpseudocolor', '3', ['500', '750'])
    """
    if z_min is None or z_max is None or not (float(z_min) <= float(z_max)) or float(z_max) - float(z_min) > 1e12:
        return None
    low, high = float(z_min), float(z_max)
    if high == low:
        high = low + 1.0
    items = "\n".join(
        f'          <item value="{low + t * (high - low):.6g}" color="{colour}" alpha="255" '
        f'label={quoteattr(f"{low + t * (high - low):.6g}")}/>' for t, colour in Z_RAMP)
    text = f"""<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>
<qgis version="3.22.0" styleCategories="AllStyleCategories">
  <customproperties>
    <Option type="Map">
      <Option name="identify/format" value="Value" type="QString"/>
    </Option>
  </customproperties>
  <pipe>
    <rasterrenderer type="singlebandpseudocolor" band="{Z_BAND}" opacity="{Z_OPACITY}" alphaBand="-1"
                    classificationMin="{low:.6g}" classificationMax="{high:.6g}" nodataColor="">
      <rastershader>
        <colorrampshader colorRampType="INTERPOLATED" classificationMode="1" clip="0" labelPrecision="1"
                         minimumValue="{low:.6g}" maximumValue="{high:.6g}">
{items}
        </colorrampshader>
      </rastershader>
    </rasterrenderer>
  </pipe>
  <blendMode>0</blendMode>
</qgis>
"""
    target = style_path(raster_path)
    try:
        target.write_text(text, encoding="utf-8")
    except OSError:
        return None
    return target
