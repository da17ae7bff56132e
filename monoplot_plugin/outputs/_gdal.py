"""Small GDAL/OGR helpers shared by the writers (no qgis import)."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Optional

from osgeo import gdal, ogr, osr

from .safe_write import OutputError, incomplete_write


@contextmanager
def gdal_errors_as_exceptions():
    """Turn GDAL/OGR/OSR errors into Python exceptions inside the block, restoring the caller's setting after
    (QGIS and other plugins run in the same process)."""
    saved = (gdal.GetUseExceptions(), ogr.GetUseExceptions(), osr.GetUseExceptions())
    gdal.UseExceptions()
    ogr.UseExceptions()
    osr.UseExceptions()
    try:
        yield
    finally:
        # GDAL keeps a stack of error handlers: undo in the reverse order.
        for module, was in reversed(list(zip((gdal, ogr, osr), saved))):
            if not was:
                module.DontUseExceptions()


def gdal_failure(exc: Exception, target) -> OutputError:
    """An :class:`OutputError` with a readable reason for a GDAL/OGR failure while writing ``target``."""
    text = str(exc)
    low = text.lower()
    if "no space left" in low or "disk full" in low or "enospc" in low:
        return OutputError(f"cannot write {target}: the disk is full ({text})")
    if "write error" in low or "too large" in low or "short write" in low or _nearly_full(target):
        return incomplete_write(target, text)
    if "permission denied" in low or "read-only" in low:
        return OutputError(f"cannot write {target}: permission denied ({text})")
    return OutputError(f"cannot write {target}: {text}")


def _nearly_full(target) -> bool:
    """True when the target's file system has less than 1 MiB free (GDAL's own message rarely says so)."""
    import shutil
    from pathlib import Path

    try:
        return shutil.disk_usage(Path(target).parent).free < 1 << 20
    except OSError:
        return False


def srs_from_user(crs) -> osr.SpatialReference:
    """An osr.SpatialReference (traditional GIS axis order: x = easting) from WKT, 'EPSG:n' or PROJ text."""
    srs = osr.SpatialReference()
    if srs.SetFromUserInput(str(crs)) != 0:
        raise ValueError(f"unreadable CRS: {str(crs)[:80]}")
    srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    return srs


def crs_authid(crs) -> Optional[str]:
    """'EPSG:21781'-style identifier of a CRS, or None when it has none.

    >>> crs_authid("EPSG:21781")
    'EPSG:21781'
    """
    if not crs:
        return None
    try:
        srs = srs_from_user(crs)
    except (ValueError, RuntimeError):
        return None
    for target in ("PROJCS", "GEOGCS", None):
        name, code = srs.GetAuthorityName(target), srs.GetAuthorityCode(target)
        if name and code:
            return f"{name}:{code}"
    srs.AutoIdentifyEPSG()
    name, code = srs.GetAuthorityName(None), srs.GetAuthorityCode(None)
    return f"{name}:{code}" if name and code else None


def linear_unit_name(crs) -> str:
    """'metre' etc.: the horizontal unit of a projected CRS (used for area/length field docs and raster units)."""
    srs = srs_from_user(crs)
    return srs.GetLinearUnitsName() if srs.IsProjected() else "degree"


def raster_verifier(width: int, height: int, bands: int):
    """A ``verify(path)`` for :func:`~.safe_write.atomic_output`: the GeoTIFF opens with the expected size and band
    count, and the last row of blocks of every band decodes (a file cut short by a full disk does not)."""

    def verify(path: str) -> None:
        with gdal_errors_as_exceptions():
            ds = gdal.Open(path)
            if (ds.RasterXSize, ds.RasterYSize, ds.RasterCount) != (width, height, bands):
                raise OutputError(f"the file written is {ds.RasterXSize}x{ds.RasterYSize} with {ds.RasterCount} "
                                  f"bands, not {width}x{height} with {bands}")
            for index in range(1, bands + 1):
                band = ds.GetRasterBand(index)
                block = band.GetBlockSize()[1] or 1
                top = max(0, height - min(height, block))
                band.ReadRaster(0, top, width, height - top)
                band.ReadRaster(0, 0, width, min(height, block))
            ds = None

    return verify


def vector_verifier(feature_count: int, layer_name: Optional[str] = None):
    """A ``verify(path)``: the vector file opens with OGR, has the layer, and holds ``feature_count`` features."""

    def verify(path: str) -> None:
        with gdal_errors_as_exceptions():
            ds = ogr.Open(path)
            if ds is None or ds.GetLayerCount() == 0:
                raise OutputError("the file written has no layer")
            layer = ds.GetLayerByName(layer_name) if layer_name else ds.GetLayer(0)
            if layer is None:
                layer = ds.GetLayer(0)
            count = layer.GetFeatureCount()
            ds = None
        if count != feature_count:
            raise OutputError(f"the file written holds {count} of {feature_count} features")

    return verify


def image_verifier(fmt: str):
    """A ``verify(path)`` for PNG and PDF files: complete (PNG ends with its IEND chunk, PDF with %%EOF)."""

    def verify(path: str) -> None:
        with open(path, "rb") as fh:
            head = fh.read(8)
            fh.seek(0, 2)
            size = fh.tell()
            fh.seek(max(0, size - 1024))
            tail = fh.read()
        if fmt == "png":
            ok = head.startswith(b"\x89PNG\r\n\x1a\n") and b"IEND" in tail[-16:]
        else:
            ok = head.startswith(b"%PDF") and b"%%EOF" in tail
        if not ok:
            raise OutputError(f"the {fmt.upper()} file written is incomplete ({size} bytes)")

    return verify
