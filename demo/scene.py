"""The demo's scene and its simulated user: terrain, hidden camera, photo, prior, curation, digitising, scoring.

Everything that knows the hidden camera lives here: the pipeline itself (qgis_process) never sees it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from osgeo import ogr

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain
from monoplot_plugin.core.xyz import compute_xyz
from monoplot_plugin.processing.inputs import write_points_csv

#: Curation tolerance (pixels): a suggested photo point is "accepted" when a DEM point the hidden camera sees
#: projects within this distance of it; DEM points are accepted when such a photo point exists.
CURATION_TOLERANCE_PX = 4.0
#: Fewest accepted pairs; below it the simulated user clicks visible DEM landmarks on the photo by hand
#: (their exact projection plus 1 px of hand jitter), as a real user adds points the detectors missed.
MIN_POINTS = 10
#: Points the simulated user adds by hand in the part of the photo where no suggestion was accepted (usually the
#: foreground: suggestions favour ridges and far slopes, and points at one distance leave the camera's position
#: and orientation ambiguous). Each is a ground point seen there, clicked on the photo with 1 px of jitter and on
#: the map exactly (a real user would pick a recognisable boulder or path junction).
HAND_POINTS = 6


@dataclass
class Scene:
    dem_path: Path
    dem_shape: tuple
    photo_path: Path
    prior_path: Path
    truth: Camera
    dem: Dem
    xyz_truth: np.ndarray
    max_points: int
    quick: bool


def make_scene(folder: Path, quick: bool = False, seed: int = 4) -> Scene:
    """Write dem.tif, photo.png and prior.json in ``folder``; the hidden camera stays in memory (and in
    hidden_camera.json, for the curious, never read by the pipeline)."""
    import cv2

    folder.mkdir(parents=True, exist_ok=True)
    shape, cell = ((160, 160), 50.0) if quick else ((280, 280), 30.0)
    dem = synthetic_terrain(shape, cell=cell, seed=seed)
    dem_path = folder / "dem.tif"
    dem.save(str(dem_path))
    dem = Dem.open(str(dem_path))
    rows, cols = dem.shape
    # the photographer stands on a spur near the south edge, 450 m above the ground, looking north
    x, y = dem.cell_to_map(cols * 0.45, rows * 0.93)
    ground = float(dem.sample(np.array([x]), np.array([y]))[0])
    size = (480, 360) if quick else (960, 720)
    truth = Camera((float(x), float(y), ground + 450.0), heading=-6.0, pitch=-9.0, roll=1.0, fov=55.0,
                   image_size=size, crs_wkt=dem.crs_wkt)
    photo = render_photo(truth, dem, seed=seed, haze=True, noise=True)
    photo_path = folder / "photo.png"
    cv2.imwrite(str(photo_path), photo[:, :, ::-1])
    truth.save(folder / "hidden_camera.json")
    # a rough prior, as from a map and a guess of the view: 150 m away, a few degrees off
    prior = truth.with_parameters(x=truth.position[0] + 120.0, y=truth.position[1] - 80.0,
                                  z=truth.position[2] + 40.0, heading=truth.heading + 3.0,
                                  pitch=truth.pitch - 1.5, roll=0.0, fov=truth.fov + 4.0)
    prior_path = folder / "prior.json"
    prior.save(prior_path)
    return Scene(dem_path, dem.shape, photo_path, prior_path, truth, dem, compute_xyz(truth, dem),
                 max_points=60 if quick else 120, quick=quick)


def _read_points(path: Path, fields) -> np.ndarray:
    ds = ogr.Open(str(path))
    layer = ds.GetLayer(0)
    values = [[feature.GetField(f) for f in fields] for feature in layer]
    return np.array(values, dtype=float).reshape(-1, len(fields))


def _visible(sc: Scene, world: np.ndarray):
    from monoplot_plugin.core.lookup import visibility_of_points

    return visibility_of_points(sc.truth, world, sc.xyz_truth)


def curate(photo_points: Path, dem_points: Path, sc: Scene, out_dir: Path, seed: int = 0) -> dict:
    """The simulated user: accept consistent suggestions, add points by hand if too few; write CSV files.

    Returns counts and the paths of the curated photo points, DEM points (unpaired sets, different order) and a
    paired check-point CSV (for the report)."""
    uv = _read_points(photo_points, ("u_px", "v_px"))
    world = _read_points(dem_points, ("X", "Y", "Z"))
    projected, seen = _visible(sc, world)
    keep_photo = np.zeros(len(uv), dtype=bool)
    keep_dem = np.zeros(len(world), dtype=bool)
    if len(uv) and seen.any():
        d = np.linalg.norm(uv[:, None, :] - projected[None, seen, :], axis=2)
        near = d.min(axis=1) <= CURATION_TOLERANCE_PX
        keep_photo = near
        keep_dem[np.flatnonzero(seen)] = (d <= CURATION_TOLERANCE_PX).any(axis=0)
    photo_kept, dem_kept = uv[keep_photo], world[keep_dem]
    rng = np.random.default_rng(seed)
    added = 0
    if min(len(photo_kept), len(dem_kept)) < MIN_POINTS:
        candidates = np.flatnonzero(seen & ~keep_dem)
        rng.shuffle(candidates)
        extra = candidates[: MIN_POINTS - min(len(photo_kept), len(dem_kept))]
        if len(extra) < MIN_POINTS - min(len(photo_kept), len(dem_kept)):  # too few suggested: click summits
            extra_world = _visible_ground_points(sc, MIN_POINTS, rng)
        else:
            extra_world = world[extra]
        clicks = sc.truth.project(extra_world) + rng.normal(0.0, 1.0, (len(extra_world), 2))
        photo_kept = np.vstack([photo_kept, clicks])
        dem_kept = np.vstack([dem_kept, extra_world])
        added = len(extra_world)
    hand = _hand_points(sc, photo_kept, HAND_POINTS, rng)
    if len(hand):
        photo_kept = np.vstack([photo_kept, sc.truth.project(hand) + rng.normal(0.0, 1.0, (len(hand), 2))])
        dem_kept = np.vstack([dem_kept, hand])
        added += len(hand)
    photo_csv, dem_csv, check_csv = out_dir / "curated_photo_points.csv", out_dir / "curated_dem_points.csv", \
        out_dir / "check_points.csv"
    write_points_csv(str(photo_csv), uv=photo_kept)
    write_points_csv(str(dem_csv), xyz=dem_kept[rng.permutation(len(dem_kept))])  # unpaired: order lost
    check = check_points(sc)
    # marked as check points: the report measures the camera on them (its page said "40 paired points, ...
    # leave-one-out 0.0 px" of these exact projections, as if the fit had used them)
    write_points_csv(str(check_csv), uv=sc.truth.project(check), xyz=check, check=[True] * len(check))
    return {"photo_csv": photo_csv, "dem_csv": dem_csv, "check_csv": check_csv,
            "n_photo_suggested": len(uv), "n_dem_suggested": len(world), "n_photo": len(photo_kept),
            "n_dem": len(dem_kept), "n_added": added}


def _hand_points(sc: Scene, accepted_uv: np.ndarray, n: int, rng) -> np.ndarray:
    """(k <= n, 3) ground points in the emptiest horizontal band of the photo (lower half first)."""
    h, w = sc.xyz_truth.shape[:2]
    bands = np.linspace(0, h, 5).astype(int)
    counts = [int(((accepted_uv[:, 1] >= a) & (accepted_uv[:, 1] < b)).sum()) for a, b in zip(bands, bands[1:])]
    ground_rows = [int(np.isfinite(sc.xyz_truth[a:b, :, 2]).mean() * (b - a)) for a, b in zip(bands, bands[1:])]
    order = sorted(range(4), key=lambda i: (counts[i], -i))  # emptiest, lowest first
    band = next((i for i in order if ground_rows[i] > 0), None)
    if band is None:
        return np.zeros((0, 3))
    rows, cols = np.nonzero(np.isfinite(sc.xyz_truth[bands[band]:bands[band + 1], :, 2]))
    rows += bands[band]
    # spread across the band: one point per slice of columns
    picks = []
    for lo, hi in zip(np.linspace(0, w, n + 1)[:-1], np.linspace(0, w, n + 1)[1:]):
        inside = np.flatnonzero((cols >= lo + 8) & (cols < hi - 8) & (rows > bands[band] + 8) & (rows < h - 8))
        if len(inside):
            picks.append(rng.choice(inside))
    return sc.xyz_truth[rows[picks], cols[picks]]


def _visible_ground_points(sc: Scene, n: int, rng) -> np.ndarray:
    rows, cols = np.nonzero(np.isfinite(sc.xyz_truth[..., 2]))
    pick = rng.choice(len(rows), n, replace=False)
    return sc.xyz_truth[rows[pick], cols[pick]]


def check_points(sc: Scene, n: int = 40) -> np.ndarray:
    """(n, 3) ground points spread over the photo's ground (fixed seed): independent check points."""
    return _visible_ground_points(sc, n, np.random.default_rng(12345))


def outline_polygon_map(sc: Scene, radius: float = None) -> np.ndarray:
    """(N, 3) a closed 'glacier tongue' outline on the terrain: an ellipse around a ground point seen in the
    lower middle of the photo."""
    h, w = sc.xyz_truth.shape[:2]
    centre = None
    for frac in (0.75, 0.7, 0.8, 0.65, 0.85, 0.6):
        p = sc.xyz_truth[int(h * frac), w // 2]
        if np.isfinite(p).all():
            centre = p
            break
    if centre is None:
        raise RuntimeError("the hidden camera sees no ground in the lower middle of the photo")
    distance = np.linalg.norm(centre - np.asarray(sc.truth.position))
    radius = radius or 0.08 * distance
    t = np.linspace(0, 2 * np.pi, 73)
    x = centre[0] + radius * 1.5 * np.cos(t)
    y = centre[1] + radius * 0.8 * np.sin(t)
    z = sc.dem.sample(x, y)
    return np.column_stack([x, y, z])


def digitise_outline(sc: Scene, path: Path) -> Path:
    """The simulated user traces the outline on the photo: a polygon in photo pixel space (x = u, y = -v),
    written as a GeoPackage layer without CRS (the photo has none). Hidden vertices are skipped, as a user
    traces only what the photo shows."""
    polygon = outline_polygon_map(sc)
    uv, seen = _visible(sc, polygon)
    uv = uv[seen]
    path = path.with_suffix(".gpkg")
    driver = ogr.GetDriverByName("GPKG")
    if path.exists():
        driver.DeleteDataSource(str(path))
    ds = driver.CreateDataSource(str(path))
    layer = ds.CreateLayer("outline_on_photo", None, ogr.wkbPolygon)
    layer.CreateField(ogr.FieldDefn("name", ogr.OFTString))
    ring = ogr.Geometry(ogr.wkbLinearRing)
    for u, v in np.vstack([uv, uv[:1]]):
        ring.AddPoint_2D(float(u), -float(v))
    geometry = ogr.Geometry(ogr.wkbPolygon)
    geometry.AddGeometry(ring)
    feature = ogr.Feature(layer.GetLayerDefn())
    feature.SetField("name", "glacier tongue")
    feature.SetGeometry(geometry)
    layer.CreateFeature(feature)
    ds = None
    return path


def outline_error(mapped_path: Path, sc: Scene, fitted: Camera) -> float:
    """Mean 3-D distance (m) between the mapped outline's vertices and the ground the hidden camera sees at the
    same photo pixels (how far the fitted camera puts the traced outline from where it really is)."""
    ds = ogr.Open(str(mapped_path))
    layer = ds.GetLayer(0)
    vertices = []
    for feature in layer:
        geometry = feature.GetGeometryRef()
        for i in range(geometry.GetGeometryCount()):
            part = geometry.GetGeometryRef(i)
            rings = [part.GetGeometryRef(j) for j in range(part.GetGeometryCount())] or [part]
            for ring in rings:
                vertices.extend(ring.GetPoints())
    mapped = np.array(vertices, dtype=float).reshape(-1, 3)
    # each mapped vertex is the fitted camera's ground at a traced pixel: compare with the truth's ground there
    from monoplot_plugin.core.lookup import sample_xyz

    truth_ground = sample_xyz(sc.xyz_truth, fitted.project(mapped))
    d = np.linalg.norm(mapped - truth_ground, axis=1)
    d = d[np.isfinite(d)]
    return float(d.mean()) if len(d) else float("nan")


def _ring_vertices(path: Path) -> np.ndarray:
    """(N, 2) x, y of every vertex of every polygon in the first layer of a vector file."""
    ds = ogr.Open(str(path))
    layer = ds.GetLayer(0)
    points = []
    for feature in layer:
        geometry = feature.GetGeometryRef()
        parts = [geometry] if geometry.GetGeometryType() in (ogr.wkbPolygon, ogr.wkbPolygon25D) else \
            [geometry.GetGeometryRef(i) for i in range(geometry.GetGeometryCount())]
        for part in parts:
            for j in range(part.GetGeometryCount()):
                points.extend(p[:2] for p in part.GetGeometryRef(j).GetPoints())
    return np.array(points, dtype=float).reshape(-1, 2)


def round_trip_error(back_on_photo: Path, traced: Path) -> float:
    """Mean distance (px) from the vertices of the outline drawn back onto the photo to the traced outline's
    boundary (photo -> map -> photo with the same camera: about the XYZ raster's pixel quantisation)."""
    back = _ring_vertices(back_on_photo)
    ring = _ring_vertices(traced)
    if len(back) == 0 or len(ring) < 2:
        return float("nan")
    a, b = ring[:-1], ring[1:]
    ab = b - a
    t = np.clip(((back[:, None, :] - a[None]) * ab[None]).sum(-1) / np.maximum((ab ** 2).sum(-1), 1e-12)[None],
                0.0, 1.0)
    nearest = a[None] + t[..., None] * ab[None]
    return float(np.linalg.norm(back[:, None, :] - nearest, axis=2).min(axis=1).mean())
