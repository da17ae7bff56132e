"""DEMs larger than memory (``make bench``): per-pixel XYZ over a DEM file read by windows and levels of detail.

Two JSON lines, on generated terrain only (a periodic procedural block of 2048 x 2048 cells, tiled by GDAL VRTs with
explicit overview levels: seconds to make, nothing of 1.6 G cells computed in Python; written to a temporary folder,
``MONOPLOT_BENCH_DIR`` if set, and deleted after):

- ``xyz_lod<lod>_24mp_dem1.7g`` (one per ``--lod`` value): 24 MP over a 40,960 x 40,960 DEM (1.68 G cells, 1 m,
  40 km square, overviews 2-128): seconds (median of the timed runs, after one warm-up), peak MB of the process (the
  DEM reads included), the bands.
- ``xyz_lod<lod>_vs_full_24mp_dem105m``: a 10,240 x 10,240 DEM (105 M cells, 2 m) that fits in memory: the level-of-
  detail result against the full-resolution z-buffer, pixel by pixel where both see terrain: ground distance in cells
  of the level used, and the displacement seen from the camera in pixels (|delta| f / distance); the share of pixels
  within one cell and within half a pixel, with percentiles; and both timings.
- ``trace_drawn_polygon_and_line_24mp_dem105m``: on that DEM, a polygon and a line drawn on the photo traced onto
  the terrain as the dock does after each edit (exact lines of sight): seconds per pair.

- ``xyz_product_24mp_dem1.7g`` and ``qgis_process_computexyz_24mp_dem1.7g`` (``--only product``): the same DEM
  through the product path (the workflow's DEM input opens it by windows on its own; the XYZ GeoTIFF written), in
  this process and with ``qgis_process``.

    .venv/bin/python bench/bench_large_dem.py [--repeat 2] [--lod 1,2] [--only big,compare,product]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

from bench.run_bench import peak_mb, reset_peak  # noqa: E402

TILE = 2048
FACTORS = (2, 4, 8, 16, 32, 64, 128)


def periodic_terrain(n: int = TILE, seed: int = 0, base: float = 1000.0, relief: float = 700.0) -> np.ndarray:
    """(n, n) float32 heights that tile seamlessly: filtered noise in the Fourier domain (periodic by
    construction), folded into ridges."""
    rng = np.random.default_rng(seed)
    k = np.fft.fftfreq(n)
    kk = np.hypot(*np.meshgrid(k, k))
    spectrum = np.fft.fft2(rng.standard_normal((n, n))) / (kk + 2.0 / n) ** 2.0
    spectrum[0, 0] = 0.0
    z = np.real(np.fft.ifft2(spectrum))
    z = (z - z.min()) / (z.max() - z.min())
    ridges = 1.0 - np.abs(2.0 * z - 1.0)
    z = 0.6 * z + 0.4 * ridges ** 2
    return (base + relief * (z - z.min()) / (z.max() - z.min())).astype(np.float32)


def write_tiles(folder: str, z: np.ndarray) -> None:
    """tile_1.tif (the block) and tile_<f>.tif, its block averages of f x f cells."""
    from osgeo import gdal

    drv = gdal.GetDriverByName("GTiff")
    for f in (1,) + FACTORS:
        n = z.shape[0] // f
        level = z.reshape(n, f, n, f).mean(axis=(1, 3)).astype(np.float32) if f > 1 else z
        ds = drv.Create(os.path.join(folder, f"tile_{f}.tif"), n, n, 1, gdal.GDT_Float32,
                        ["TILED=YES", "BLOCKXSIZE=256", "BLOCKYSIZE=256"] if n >= 256 else [])
        ds.GetRasterBand(1).WriteArray(level)
        ds = None


def write_vrt(folder: str, tiles: int, cell: float, name: str) -> str:
    """A VRT of ``tiles`` x ``tiles`` copies of the block (cells of ``cell`` metres, EPSG:2056), with one VRT per
    overview level declared as its overviews. Returns its path."""
    from osgeo import osr

    srs = osr.SpatialReference()
    srs.ImportFromEPSG(2056)
    wkt = srs.ExportToWkt().replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    x0, y0 = 2600000.0, 1200000.0 + tiles * TILE * cell

    def level_xml(f: int, overviews: str) -> str:
        n = TILE // f
        size = tiles * n
        sources = "".join(
            f'<SimpleSource><SourceFilename relativeToVRT="1">tile_{f}.tif</SourceFilename><SourceBand>1</SourceBand>'
            f'<SrcRect xOff="0" yOff="0" xSize="{n}" ySize="{n}"/>'
            f'<DstRect xOff="{j * n}" yOff="{i * n}" xSize="{n}" ySize="{n}"/></SimpleSource>'
            for i in range(tiles) for j in range(tiles))
        return (f'<VRTDataset rasterXSize="{size}" rasterYSize="{size}"><SRS>{wkt}</SRS>'
                f'<GeoTransform>{x0}, {cell * f}, 0, {y0}, 0, {-cell * f}</GeoTransform>'
                f'<VRTRasterBand dataType="Float32" band="1">{sources}{overviews}</VRTRasterBand></VRTDataset>')

    overviews = ""
    for f in FACTORS:
        ovr = f"{name}_ovr{f}.vrt"
        with open(os.path.join(folder, ovr), "w") as fh:
            fh.write(level_xml(f, ""))
        overviews += (f'<Overview><SourceFilename relativeToVRT="1">{ovr}</SourceFilename>'
                      f'<SourceBand>1</SourceBand></Overview>')
    path = os.path.join(folder, f"{name}.vrt")
    with open(path, "w") as fh:
        fh.write(level_xml(1, overviews))
    return path


def camera_for(source, width: int, height: int):
    """The run_bench scene's camera: near the south-west corner, 300 m above the highest terrain, looking north-east
    across the DEM, 6 degrees down, 60 degree field of view."""
    from monoplot_plugin.core.camera import Camera

    rows, cols = source.shape
    g = source.geotransform
    x = g[0] + cols * 0.1 * g[1]
    y = g[3] + rows * 0.9 * g[5]
    return Camera((x, y, source.zmax + 300.0), heading=45.0, pitch=-6.0, roll=0.0, fov=60.0,
                  image_size=(width, height))


def bench_big(folder: str, args, lod_value: float) -> dict:
    from monoplot_plugin.core.dem_window import DemSource
    from monoplot_plugin.core.xyz_lod import compute_xyz_lod

    path = write_vrt(folder, 20, 1.0, "big")
    source = DemSource(path)
    cam = camera_for(source, 6000, 4000)
    t0 = time.perf_counter()
    res = compute_xyz_lod(cam, source, lod=lod_value)
    first = time.perf_counter() - t0
    hit = float(res.hit.mean())
    del res
    reset_peak()
    times = []
    for _ in range(args.repeat):
        source = DemSource(path)  # reopened: nothing cached in the source between runs (GDAL's block cache stays)
        t0 = time.perf_counter()
        res = compute_xyz_lod(cam, source, lod=lod_value)
        times.append(time.perf_counter() - t0)
        bands = res.bands
        del res
    return {"name": f"xyz_lod{lod_value:g}_24mp_dem1.7g", "image": list(cam.image_size), "dem": list(source.shape),
            "gcells": round(source.cells / 1e9, 2), "cell_m": source.cell_size, "levels": source.levels,
            "lod": lod_value, "seconds": round(float(np.median(times)), 3), "first_s": round(first, 3),
            "min_s": round(min(times), 3), "peak_mb": round(peak_mb(), 1), "hit_fraction": round(hit, 3),
            "bands": [{"factor": f, "near_m": round(a), "far_m": None if not np.isfinite(b) else round(b),
                       "window": list(shape), "mcells_read": round(n / 1e6, 1), "s": round(s, 3)}
                      for f, a, b, shape, n, s in bands],
            "repeat": args.repeat, "load_avg_1min": round(os.getloadavg()[0], 2)}


def bench_compare(folder: str, args, lods) -> list:
    from monoplot_plugin.core.dem import Dem
    from monoplot_plugin.core.dem_window import DemSource
    from monoplot_plugin.core.xyz import compute_xyz
    from monoplot_plugin.core.xyz_lod import compute_xyz_lod

    path = write_vrt(folder, 5, 2.0, "mid")
    source = DemSource(path)
    cam = camera_for(source, 6000, 4000)
    dem = Dem.open(path)
    reset_peak()
    t0 = time.perf_counter()
    full = compute_xyz(cam, dem)
    full_s = time.perf_counter() - t0
    cell0 = dem.cell_size
    lines = []
    for lod_value in lods:
        t0 = time.perf_counter()
        lod = compute_xyz_lod(cam, source, lod=lod_value)
        lod_s = time.perf_counter() - t0
        both = lod.hit & np.isfinite(full[..., 0])
        p, q = lod.xyz[both], full[both]
        ground = np.hypot(p[:, 0] - q[:, 0], p[:, 1] - q[:, 1])
        cells = ground / (cell0 * lod.factor[both])
        rng = np.linalg.norm(q - np.asarray(cam.position), axis=1)
        px = np.linalg.norm(p - q, axis=1) * cam.focal_px / rng
        coarse = lod.factor[both] > 1
        # how the coarse misses (beyond one cell) miss: the LOD point's height above or below the full-resolution
        # surface (on the terrain, or not), and the depth jump (> 5 %: a different surface, a ridge the averaged
        # level lowered; less: the same slope met a little farther or nearer along a grazing ray)
        miss = coarse & (cells > 1.0)
        dz = np.abs(p[miss, 2] - dem.sample(p[miss, 0], p[miss, 1]))
        jump = np.abs(np.linalg.norm(p[miss] - np.asarray(cam.position), axis=1) - rng[miss]) / rng[miss]
        pct = lambda a: [round(float(v), 3) for v in np.percentile(a, [50, 95, 99])] if a.size else None  # noqa
        share = lambda m: round(float(m.mean()), 4) if m.size else None  # noqa: E731
        lines.append({
            "name": f"xyz_lod{lod_value:g}_vs_full_24mp_dem105m", "image": list(cam.image_size),
            "dem": list(source.shape), "cell_m": cell0, "lod": lod_value, "lod_s": round(lod_s, 3),
            "full_s": round(full_s, 3), "hit_lod": round(float(lod.hit.mean()), 4),
            "hit_full": round(float(np.isfinite(full[..., 0]).mean()), 4), "pixels_compared": int(both.sum()),
            "pixels_coarse": int(coarse.sum()), "within_1_cell": share(cells <= 1.0),
            "within_half_px": share(px <= 0.5), "coarse_within_1_cell": share(cells[coarse] <= 1.0),
            "coarse_within_half_px": share(px[coarse] <= 0.5), "cells_p50_p95_p99": pct(cells),
            "px_p50_p95_p99": pct(px), "coarse_px_p50_p95_p99": pct(px[coarse]),
            "coarse_misses": int(miss.sum()), "misses_other_surface": share(jump > 0.05),
            "misses_height_off_full_m_p50_p95": pct(dz)[:2] if dz.size else None, "peak_mb": round(peak_mb(), 1),
            "load_avg_1min": round(os.getloadavg()[0], 2)})
        del lod
    lines.append(bench_trace(dem, cam, args))
    del dem
    return lines


def bench_trace(dem, cam, args) -> dict:
    """A polygon and a line drawn on the 24 MP photo, traced onto the 105 M-cell DEM as the dock does after each
    edit and for every drawn feature when the camera or the DEM changes (exact lines of sight, densified to 1 px,
    with the ground error): seconds per feature pair, on the main thread in the dock."""
    from monoplot_plugin.workflow.features import photo_to_map_feature

    w, h = cam.image_size
    polygon = np.array([[0.25 * w, 0.62 * h], [0.75 * w, 0.6 * h], [0.8 * w, 0.85 * h], [0.2 * w, 0.88 * h]])
    line = np.array([[0.05 * w, 0.58 * h], [0.95 * w, 0.6 * h]])

    def trace():
        return (photo_to_map_feature("polygon", polygon, camera=cam, dem=dem, pixel_rmse=2.0),
                photo_to_map_feature("line", line, camera=cam, dem=dem, pixel_rmse=2.0))

    t0 = time.perf_counter()
    mapped = trace()
    first = time.perf_counter() - t0
    times = []
    for _ in range(max(3, args.repeat)):
        t0 = time.perf_counter()
        trace()
        times.append(time.perf_counter() - t0)
    return {"name": "trace_drawn_polygon_and_line_24mp_dem105m", "dem": list(dem.shape),
            "dtype": str(dem.elevation.dtype),
            "samples": [int(sum(len(p) for p in m.parts)) if m is not None else 0 for m in mapped],
            "seconds": round(float(np.median(times)), 3), "first_s": round(first, 3),
            "load_avg_1min": round(os.getloadavg()[0], 2)}


def bench_product(folder: str, args) -> list:
    """The product path on the 1.68 G-cell DEM, as the dock and Processing run it: the workflow's DEM input (which
    opens it by windows on its own, since it does not fit in memory) and the XYZ product written to a file; then the
    same through ``qgis_process run monoplot:computexyz`` (a process of its own: its wall time and peak)."""
    import resource
    import subprocess

    from monoplot_plugin.core.dem_window import DemSource
    from monoplot_plugin.processing import cli
    from monoplot_plugin.workflow import products
    from monoplot_plugin.workflow.inputs import load_dem
    from monoplot_plugin.workflow.xyz import clear_cache

    path = write_vrt(folder, 20, 1.0, "big")
    cam = camera_for(DemSource(path), 6000, 4000)
    out = os.path.join(folder, "xyz.tif")
    lines = []
    reset_peak()
    times = []
    for _ in range(args.repeat):
        clear_cache()
        t0 = time.perf_counter()
        dem, notes = load_dem(path)
        t1 = time.perf_counter()
        products.write_xyz(out, cam, dem, overwrite=True)
        times.append((t1 - t0, time.perf_counter() - t1))
        kind = type(dem).__name__
        del dem
    clear_cache()
    lines.append({"name": "xyz_product_24mp_dem1.7g", "dem_type": kind, "load_s": round(min(t[0] for t in times), 3),
                  "xyz_and_write_s": round(float(np.median([t[1] for t in times])), 3),
                  "peak_mb": round(peak_mb(), 1), "note": notes[0] if notes else "", "repeat": args.repeat,
                  "load_avg_1min": round(os.getloadavg()[0], 2)})
    cam_path = os.path.join(folder, "camera.json")
    cam.save(cam_path)
    env = cli.prepare_environment()
    command = [cli.qgis_process_binary(), "--json", "run", "monoplot:computexyz", "--",
               *cli.parameter_arguments({"CAMERA": cam_path, "DEM": path, "OUTPUT": out})]
    t0 = time.perf_counter()
    proc = subprocess.run(command, env=env, capture_output=True, text=True, timeout=1800)
    seconds = time.perf_counter() - t0
    lines.append({"name": "qgis_process_computexyz_24mp_dem1.7g", "ok": proc.returncode == 0,
                  "seconds": round(seconds, 3), "peak_mb": round(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
                                                                / 1024.0, 1),
                  "error": "" if proc.returncode == 0 else (proc.stdout + proc.stderr)[-500:],
                  "load_avg_1min": round(os.getloadavg()[0], 2)})
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--lod", default="1,2", help="comma-separated lod values (cells per pixel footprint)")
    parser.add_argument("--only", default="big,compare")
    args = parser.parse_args()
    only = set(args.only.split(","))
    folder = tempfile.mkdtemp(prefix="monoplot-large-dem-", dir=os.environ.get("MONOPLOT_BENCH_DIR"))
    try:
        write_tiles(folder, periodic_terrain())
        lods = [float(v) for v in args.lod.split(",")]
        if "big" in only:
            for lod_value in lods:
                print(json.dumps(bench_big(folder, args, lod_value)), flush=True)
        if "product" in only:
            for line in bench_product(folder, args):
                print(json.dumps(line), flush=True)
        if "compare" in only:
            for line in bench_compare(folder, args, lods):
                print(json.dumps(line), flush=True)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
