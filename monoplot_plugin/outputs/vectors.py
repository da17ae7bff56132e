"""3-D map vector layers from features digitised on the photo: GeoPackage (default) or ESRI Shapefile.

A :class:`MapFeature` is one feature already in map coordinates (X, Y, Z in the DEM's CRS), with the parts that fell
on sky already split off (see :mod:`.digitise`). :func:`write_vector_layer` writes a list of them with

- Z geometries: ``Point Z`` for points, ``MultiLineString Z`` for lines (a line crossing sky becomes several
  parts), ``MultiPolygon Z`` for polygons;
- the user's attribute fields (name, type) plus computed ones, in map units of the CRS:
  ``area`` (planimetric, polygons), ``area3d`` (along the terrain's surface, polygons: the area times the DEM's mean
  surface factor inside, :func:`~monoplot_plugin.workflow.features.surface_factor`), ``length`` (planimetric) and
  ``length3d`` (along the terrain, lines),
  ``sky_parts`` (how many pieces of the drawn feature were over sky or off the DEM and were left out),
  ``silhouette`` (polygons: how many times the outline crosses a silhouette, where it then encloses ground the photo
  does not show, which its area counts), and
  ``xy_error_m`` (the expected horizontal position error of the feature's ground points, metres, RMS, from the fit's
  pixel error: :func:`~monoplot_plugin.core.transforms.ground_error_m`; empty when no fit vouches for the camera),
  ``z_error_m`` (the same for their heights);
  the dock and Processing add :data:`FIT_STATUS_FIELD`, the verdict of the camera the features were mapped with.

Shapefile limits are checked up front with a clear message: field names of at most 10 characters, one geometry
type per file. Attributes are written as UTF-8 (``.cpg`` file).
"""

from __future__ import annotations

import datetime
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
from osgeo import ogr

from ._gdal import gdal_errors_as_exceptions, gdal_failure, srs_from_user, vector_verifier
from .safe_write import atomic_output

__all__ = ["MapFeature", "polygon_area", "write_vector_layer", "read_vector_layer", "FIELD_TYPES", "driver_for_path",
           "COMPUTED_FIELDS", "INTEGER_FIELDS", "FIT_STATUS_FIELD", "other_layers"]

#: User field types and their OGR types.
FIELD_TYPES = {"string": ogr.OFTString, "integer": ogr.OFTInteger, "real": ogr.OFTReal, "date": ogr.OFTDate}
#: Fields Monoplot adds, by geometry kind.
COMPUTED_FIELDS = {"point": ("sky_parts", "xy_error_m", "z_error_m", "m_per_px", "m_px_max"),
                   "line": ("length", "length3d", "sky_parts", "xy_error_m", "z_error_m", "m_per_px", "m_px_max"),
                   "polygon": ("area", "area3d", "area_error", "length", "sky_parts", "silhouette", "xy_error_m",
                               "z_error_m", "m_per_px", "m_px_max")}
#: The field of the verdict (ok / uncertain / poor) of the camera a map feature was mapped with, beside the
#: measures (dock and Processing; empty when unknown): a trial's outline from an "uncertain" camera, 72 % too small,
#: read in its exported file as any other.
FIT_STATUS_FIELD = "fit_status"
#: The computed fields that are whole numbers.
INTEGER_FIELDS = ("sky_parts", "silhouette")
_OGR_GEOMETRY = {"point": ogr.wkbPoint25D, "line": ogr.wkbMultiLineString25D, "polygon": ogr.wkbMultiPolygon25D}


@dataclass
class MapFeature:
    """One feature in map coordinates.

    Attributes:
        kind: "point", "line" or "polygon".
        parts: list of (N, 3) arrays of X, Y, Z (map units). point: one (1, 3) array; line: one array per piece;
            polygon: one closed or open ring per polygon (exterior rings; each becomes a polygon of the multipolygon).
        attributes: values of the user's fields by name.
        sky_parts: number of pieces left out because they were over sky / off the DEM.
        xy_error_m: expected horizontal position error of the ground points (metres, RMS over the feature's
            samples), None when unknown.
        z_error_m: the same for the ground points' heights (metres, RMS), None when unknown.
        silhouettes: polygons: silhouette crossings of the outline (:func:`~..core.transforms.silhouette_crossings`).
        m_per_px, m_px_max: the horizontal shift (metres, RMS) one pixel of photo error causes on the ground,
            median and largest over the feature's samples, whatever the camera's verdict (the far, grazing part of
            a flood line drawn from 8 m above a floodplain: 300 m a pixel where its near part had 0.3 m); None
            when unknown.
    """

    kind: str
    parts: List[np.ndarray]
    attributes: Dict[str, object] = field(default_factory=dict)
    sky_parts: int = 0
    xy_error_m: Optional[float] = None
    silhouettes: int = 0
    z_error_m: Optional[float] = None
    m_per_px: Optional[float] = None
    m_px_max: Optional[float] = None
    #: polygons: how much the area changes with the camera's error (map units squared), None: the buffer estimate
    area_error_m2: Optional[float] = None
    #: polygons: the terrain's surface over its map area inside the outline (``area3d`` = area x it), None: unknown
    surface_factor: Optional[float] = None

    def __post_init__(self):
        if self.kind not in _OGR_GEOMETRY:
            raise ValueError(f"kind must be point, line or polygon, got {self.kind!r}")
        self.parts = [np.asarray(p, dtype=np.float64).reshape(-1, 3) for p in self.parts]

    def ogr_geometry(self) -> ogr.Geometry:
        """The OGR geometry (Point Z / MultiLineString Z / MultiPolygon Z)."""
        if self.kind == "point":
            geom = ogr.Geometry(ogr.wkbPoint25D)
            x, y, z = self.parts[0][0]
            geom.AddPoint(float(x), float(y), float(z))
            return geom
        geom = ogr.Geometry(_OGR_GEOMETRY[self.kind])
        for part in self.parts:
            if self.kind == "line":
                sub = ogr.Geometry(ogr.wkbLineString25D)
                for x, y, z in part:
                    sub.AddPoint(float(x), float(y), float(z))
            else:
                ring = ogr.Geometry(ogr.wkbLinearRing)  # AddPoint with z makes it 3-D
                closed = part if np.array_equal(part[0], part[-1]) else np.vstack([part, part[:1]])
                for x, y, z in closed:
                    ring.AddPoint(float(x), float(y), float(z))
                sub = ogr.Geometry(ogr.wkbPolygon25D)
                sub.AddGeometry(ring)
            geom.AddGeometry(sub)
        return geom

    def measures(self) -> Dict[str, float]:
        """Computed fields (see :data:`COMPUTED_FIELDS`) in map units.

        A polygon's ``area_error`` (map units squared) is ``area_error_m2`` when the feature has it (how much the
        area changes when the camera is off by its pixel error: :func:`~..workflow.features.area_error_m2`), else,
        with ``xy_error_m``, the glacier inventories' buffer estimate: the area between the outline moved out and in
        by its horizontal error, perimeter x xy_error_m (cautious: it moves every piece of the outline outward at
        once, where a camera's error moves the whole outline together).

        >>> MapFeature("polygon", [[[0, 0, 5], [10, 0, 5], [10, 20, 9], [0, 20, 9]]]).measures()
        {'area': 200.0, 'length': 60.0, 'silhouette': 0, 'sky_parts': 0}
        >>> MapFeature("polygon", [[[0, 0, 5], [10, 0, 5], [10, 20, 9], [0, 20, 9]]], xy_error_m=0.5).measures()
        {'area': 200.0, 'length': 60.0, 'silhouette': 0, 'area_error': 30.0, 'sky_parts': 0, 'xy_error_m': 0.5}
        """
        out: Dict[str, float] = {}
        if self.kind == "polygon":
            out["area"] = float(sum(abs(_shoelace(p[:, :2])) for p in self.parts))
            if self.surface_factor is not None and np.isfinite(self.surface_factor):
                out["area3d"] = round(out["area"] * float(self.surface_factor), 1)
            out["length"] = float(sum(_path_length(_closed(p)[:, :2]) for p in self.parts))
            out["silhouette"] = int(self.silhouettes)
            if self.area_error_m2 is not None and np.isfinite(self.area_error_m2):
                out["area_error"] = round(float(self.area_error_m2), 1)
            elif self.xy_error_m is not None and np.isfinite(self.xy_error_m):
                out["area_error"] = round(out["length"] * float(self.xy_error_m), 1)
        elif self.kind == "line":
            out["length"] = float(sum(_path_length(p[:, :2]) for p in self.parts))
            out["length3d"] = float(sum(_path_length(p) for p in self.parts))
        out["sky_parts"] = int(self.sky_parts)
        for name in ("xy_error_m", "z_error_m", "m_per_px", "m_px_max"):
            value = getattr(self, name)
            if value is not None and np.isfinite(value):  # else the field stays empty
                out[name] = round(float(value), 3)
        return out


def _closed(ring: np.ndarray) -> np.ndarray:
    return ring if np.array_equal(ring[0], ring[-1]) else np.vstack([ring, ring[:1]])


def polygon_area(xy: np.ndarray) -> float:
    """Area of a ring (N, 2) (map units squared)."""
    return abs(_shoelace(np.asarray(xy, dtype=np.float64)))


def _shoelace(xy: np.ndarray) -> float:
    """Signed area of a ring (N, 2); coordinates centred first, since map coordinates are large numbers."""
    xy = xy - xy.mean(axis=0)
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _path_length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()) if len(points) > 1 else 0.0


def driver_for_path(path) -> str:
    """OGR driver from the file suffix: .gpkg -> GPKG, .shp -> ESRI Shapefile.

    >>> driver_for_path("glacier.SHP"), driver_for_path("a.gpkg")
    ('ESRI Shapefile', 'GPKG')
    """
    suffix = Path(path).suffix.lower()
    drivers = {".gpkg": "GPKG", ".shp": "ESRI Shapefile"}
    if suffix not in drivers:
        raise ValueError(f"unsupported vector format {suffix!r}: use .gpkg (default) or .shp")
    return drivers[suffix]


def _check_fields(fields: Sequence[Tuple[str, str]], kind: str, driver: str) -> None:
    names = [name for name, _ in fields]
    for name, ftype in fields:
        if ftype not in FIELD_TYPES:
            raise ValueError(f"field {name!r}: type must be one of {sorted(FIELD_TYPES)}, got {ftype!r}")
        if name.lower() in COMPUTED_FIELDS[kind] or name.lower() == "fid":
            raise ValueError(f"field name {name!r} is reserved for the value Monoplot computes")
        if driver == "ESRI Shapefile" and len(name.encode("utf-8")) > 10:
            raise ValueError(f"field name {name!r} is too long for a Shapefile (10 characters at most)")
    if len({n.lower() for n in names}) != len(names):
        raise ValueError(f"field names must be unique (case-insensitively): {names}")


def write_vector_layer(path, features: Sequence[MapFeature], crs_wkt: str, *,
                       fields: Sequence[Tuple[str, str]] = (), kind: Optional[str] = None,
                       layer_name: Optional[str] = None, overwrite: bool = False) -> Path:
    """Write map features as a 3-D vector file.

    Args:
        path: ``.gpkg`` (GeoPackage, default format) or ``.shp`` (ESRI Shapefile), any Unicode path.
        features: the features, all of one kind.
        crs_wkt: the DEM's CRS (WKT or "EPSG:n").
        fields: user attribute fields as (name, type) with type in :data:`FIELD_TYPES`; computed fields are added.
        kind: "point", "line" or "polygon"; needed when ``features`` is empty.
        layer_name: GeoPackage layer name (default: the file's stem).
        overwrite: replace an existing file (default: refuse with OutputExistsError). An existing GeoPackage that
            holds other layers keeps them: only the layer ``layer_name`` is replaced (a desktop trial: saving the
            drawn lines over a GeoPackage of two other layers deleted them).
    Returns:
        the Path written.
    """
    kinds = {f.kind for f in features}
    if kind is None:
        if len(kinds) != 1:
            raise ValueError("give kind= for an empty feature list" if not kinds else
                             f"one geometry kind per layer, got {sorted(kinds)}")
        kind = kinds.pop()
    elif kinds - {kind}:
        raise ValueError(f"features of kind {sorted(kinds - {kind})} in a {kind} layer")
    target = Path(os.fspath(path))
    driver_name = driver_for_path(target)
    fields = list(fields)
    _check_fields(fields, kind, driver_name)
    srs = srs_from_user(crs_wkt)
    name = layer_name or target.stem
    verify = vector_verifier(len(features), name if driver_name == "GPKG" else None)
    keep_others = driver_name == "GPKG" and overwrite and bool(other_layers(target, name))
    with atomic_output(target, overwrite, verify=verify) as tmp:
        ds = layer = None
        try:
            with gdal_errors_as_exceptions():
                if keep_others:  # the file's other layers kept: a copy of it, this layer replaced in the copy
                    shutil.copyfile(target, tmp)
                    ds = ogr.Open(tmp, 1)
                    for index in range(ds.GetLayerCount() - 1, -1, -1):
                        if ds.GetLayer(index).GetName() == name:
                            ds.DeleteLayer(index)
                else:
                    ds = ogr.GetDriverByName(driver_name).CreateDataSource(tmp)
                options = ["ENCODING=UTF-8"] if driver_name == "ESRI Shapefile" else ["SPATIAL_INDEX=YES"]
                layer = ds.CreateLayer(name if driver_name == "GPKG" else Path(tmp).stem, srs,
                                       _OGR_GEOMETRY[kind], options=options)
                _fill_layer(layer, features, fields, kind)
                ds.FlushCache()
        except RuntimeError as exc:
            raise gdal_failure(exc, target) from exc
        finally:
            layer = ds = None  # close before the temporary file is renamed or removed
    return target


def other_layers(path, layer_name: str) -> List[str]:
    """The names of the layers of the GeoPackage ``path`` other than ``layer_name`` ([] when it does not exist or
    is not a readable GeoPackage)."""
    target = Path(os.fspath(path))
    if not target.is_file() or target.suffix.lower() != ".gpkg":
        return []
    with gdal_errors_as_exceptions():
        try:
            ds = ogr.Open(str(target))
        except RuntimeError:
            return []
        names = [ds.GetLayer(i).GetName() for i in range(ds.GetLayerCount())] if ds is not None else []
        ds = None
    return [n for n in names if n != layer_name]


def _fill_layer(layer: ogr.Layer, features: Sequence[MapFeature], fields, kind: str) -> None:
    for fname, ftype in fields:
        layer.CreateField(ogr.FieldDefn(fname, FIELD_TYPES[ftype]))
    for cname in COMPUTED_FIELDS[kind]:
        defn = ogr.FieldDefn(cname, ogr.OFTInteger if cname in INTEGER_FIELDS else ogr.OFTReal)
        if cname not in INTEGER_FIELDS:
            defn.SetWidth(18)
            defn.SetPrecision(3)
        layer.CreateField(defn)
    layer.StartTransaction()
    for feature in features:
        ogr_feature = ogr.Feature(layer.GetLayerDefn())
        for fname, ftype in fields:
            _set_field(ogr_feature, fname, ftype, feature.attributes.get(fname))
        for cname, value in feature.measures().items():
            ogr_feature.SetField(cname, value)
        ogr_feature.SetGeometry(feature.ogr_geometry())
        layer.CreateFeature(ogr_feature)
    layer.CommitTransaction()


def _set_field(feature: ogr.Feature, name: str, ftype: str, value) -> None:
    if value is None:
        feature.SetFieldNull(name)
    elif ftype == "date":
        if isinstance(value, str):
            value = datetime.date.fromisoformat(value)
        feature.SetField(name, value.year, value.month, value.day, 0, 0, 0, 0)
    elif ftype == "integer":
        feature.SetField(name, int(value))
    elif ftype == "real":
        feature.SetField(name, float(value))
    else:
        feature.SetField(name, str(value))


def read_vector_layer(path) -> Tuple[List[dict], str]:
    """Read a vector file back (first layer): ([{'geometry': ogr WKT, 'attributes': {...}}], CRS WKT).

    Convenience for tests and the report; the geometry is returned as ISO WKT with Z.
    """
    with gdal_errors_as_exceptions():
        ds = ogr.Open(os.fspath(path))
        layer = ds.GetLayer(0)
        srs = layer.GetSpatialRef()
        rows = []
        for feature in layer:
            geom = feature.GetGeometryRef()
            rows.append({"geometry": geom.ExportToIsoWkt() if geom is not None else None,
                         "attributes": feature.items()})
    return rows, srs.ExportToWkt() if srs is not None else ""
