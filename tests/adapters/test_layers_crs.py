"""The QGIS CRS of a core camera's or DEM's WKT, also when QGIS's own WKT reading fails."""

from osgeo import osr
from qgis.core import QgsCoordinateReferenceSystem

from monoplot_plugin.adapters.layers import crs_from_wkt


def _wkt(epsg: int) -> str:
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(epsg)
    return srs.ExportToWkt()


def test_a_wkt_qgis_does_not_take_is_read_through_gdal(monkeypatch):
    """In a fresh QGIS session QGIS intermittently refused a DEM's WKT (an XYZ raster failed, map features came
    without a CRS): GDAL's reading (its EPSG code) stands in."""
    assert crs_from_wkt(_wkt(21781)).authid() == "EPSG:21781"
    assert crs_from_wkt("EPSG:32632").authid() == "EPSG:32632" and not crs_from_wkt("").isValid()
    monkeypatch.setattr(QgsCoordinateReferenceSystem, "fromWkt", staticmethod(lambda wkt: QgsCoordinateReferenceSystem()))
    assert crs_from_wkt(_wkt(21781)).authid() == "EPSG:21781"
    assert crs_from_wkt(_wkt(32632)).authid() == "EPSG:32632"
