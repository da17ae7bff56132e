"""``make demo``: the whole Monoplot pipeline, offline, through ``qgis_process``, on a scene it generates itself.

1. Scene (:mod:`demo.scene`): procedural terrain (core/synthetic.py) written as a GeoTIFF DEM; a photo rendered from
   a hidden, known camera with texture, haze and noise; a rough prior camera (the hidden one, perturbed).
2. ``monoplot:suggestphotopoints`` and ``monoplot:suggestdempoints`` (qgis_process).
3. Automatic curation, a simulation of the user (:func:`demo.scene.curate`): keep DEM points the hidden camera sees
   and photo points within a few pixels of one of them; like a user accepting good suggestions and rejecting the
   rest. The hidden camera is used here and for scoring only, never by the fit.
4. ``monoplot:fitcamera`` (unpaired point sets, from the prior) -> camera.json.
5. ``monoplot:computexyz`` -> xyz.tif.
6. A glacier outline digitised on the photo (simulated: the hidden camera's view of a known map polygon) ->
   ``monoplot:phototomap`` -> outline.gpkg and outline.shp.
7. ``monoplot:maptophoto`` draws the mapped outline back onto the photo (round trip, should land on the traced
   pixels); ``monoplot:orthophoto`` -> ortho.tif; ``monoplot:report`` -> report.png.

Prints where the outputs are, the pose error of the fitted camera against the hidden one, and writes everything
to ``demo-output/summary.json``. ``--quick`` makes a smaller scene (CI).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from demo import scene as scene_module  # noqa: E402
from monoplot_plugin.core.camera import Camera  # noqa: E402
from monoplot_plugin.processing import cli  # noqa: E402


def pose_error(fitted: Camera, truth: Camera) -> dict:
    """Differences between two cameras: position (m), angles and field of view (degrees)."""
    def angle(a, b):
        return abs((a - b + 180.0) % 360.0 - 180.0)

    return {
        "position_m": float(np.linalg.norm(np.subtract(fitted.position, truth.position))),
        "heading_deg": angle(fitted.heading, truth.heading),
        "pitch_deg": angle(fitted.pitch, truth.pitch),
        "roll_deg": angle(fitted.roll, truth.roll),
        "fov_deg": abs(fitted.fov - truth.fov),
    }


def reprojection_error(fitted: Camera, truth: Camera, xyz: np.ndarray) -> float:
    """RMS pixel distance between where the two cameras put the same ground points (check points)."""
    a, b = fitted.project(xyz), truth.project(xyz)
    d = np.linalg.norm(a - b, axis=1)
    d = d[np.isfinite(d)]
    return float(np.sqrt(np.mean(d ** 2))) if len(d) else float("inf")


def run(out_dir: Path, quick: bool = False, verbose: bool = True) -> dict:
    start = time.time()
    say = print if verbose else (lambda *a, **k: None)
    if out_dir.exists():
        shutil.rmtree(out_dir)
    out_dir.mkdir(parents=True)
    timings = {}

    t = time.time()
    sc = scene_module.make_scene(out_dir / "scene", quick=quick)
    timings["scene_s"] = time.time() - t
    say(f"scene: DEM {sc.dem_path.name} {sc.dem_shape[1]}x{sc.dem_shape[0]} cells, photo {sc.truth.width}x"
        f"{sc.truth.height} px rendered from a hidden camera ({timings['scene_s']:.1f} s)")

    env = cli.prepare_environment(str(out_dir / ".qgis"))
    common = {"DEM": str(sc.dem_path)}

    def qp(algorithm, params):
        t0 = time.time()
        result = cli.run(f"monoplot:{algorithm}", params, env)
        timings[algorithm] = round(time.time() - t0, 2)
        say(f"qgis_process run monoplot:{algorithm}  ({timings[algorithm]:.1f} s)")
        return result["results"]

    photo_points = out_dir / "suggested_photo_points.gpkg"
    dem_points = out_dir / "suggested_dem_points.gpkg"
    qp("suggestphotopoints", {"PHOTO": str(sc.photo_path), "MAX_POINTS": sc.max_points, "OUTPUT": str(photo_points)})
    qp("suggestdempoints", {**common, "CAMERA": str(sc.prior_path), "MAX_POINTS": sc.max_points,
                            "OUTPUT": str(dem_points)})

    curated = scene_module.curate(photo_points, dem_points, sc, out_dir)
    say(f"curation (simulated user): kept {curated['n_photo']} of {curated['n_photo_suggested']} photo points and "
        f"{curated['n_dem']} of {curated['n_dem_suggested']} DEM points; {curated['n_added']} added by hand")

    camera_path = out_dir / "camera.json"
    fit = qp("fitcamera", {**common, "PHOTO": str(sc.photo_path), "PRIOR": str(sc.prior_path),
                           "PHOTO_CSV": str(curated["photo_csv"]), "DEM_CSV": str(curated["dem_csv"]),
                           "PAIRED": False, "OUTPUT": str(camera_path)})
    fitted = Camera.load(camera_path)

    qp("computexyz", {**common, "CAMERA": str(camera_path), "OUTPUT": str(out_dir / "xyz.tif")})
    outline_photo = scene_module.digitise_outline(sc, out_dir / "outline_on_photo.geojson")
    for ext in ("gpkg", "shp"):
        qp("phototomap", {**common, "INPUT": str(outline_photo), "CAMERA": str(camera_path), "STEP": 2,
                          "OUTPUT": str(out_dir / f"outline.{ext}")})
    back = out_dir / "outline_back_on_photo.gpkg"
    qp("maptophoto", {**common, "INPUT": str(out_dir / "outline.gpkg"), "CAMERA": str(camera_path), "HIDDEN": True,
                      "OUTPUT": str(back)})
    qp("orthophoto", {**common, "CAMERA": str(camera_path), "PHOTO": str(sc.photo_path),
                      "OUTPUT": str(out_dir / "ortho.tif")})
    qp("report", {**common, "CAMERA": str(camera_path), "PHOTO": str(sc.photo_path),
                  "POINTS_CSV": str(curated["check_csv"]), "OUTPUT": str(out_dir / "report.png")})

    errors = pose_error(fitted, sc.truth)
    prior_errors = pose_error(Camera.load(sc.prior_path), sc.truth)
    check = scene_module.check_points(sc)
    outline_error = scene_module.outline_error(out_dir / "outline.gpkg", sc, fitted)
    summary = {
        "quick": quick,
        "seconds": round(time.time() - start, 1),
        "pose_error": errors,
        "prior_pose_error": prior_errors,
        "check_reprojection_rmse_px": reprojection_error(fitted, sc.truth, check),
        "prior_check_reprojection_rmse_px": reprojection_error(Camera.load(sc.prior_path), sc.truth, check),
        "fit_rmse_px": fit.get("RMSE_PX"),
        "outline_mean_error_m": outline_error,
        "outline_round_trip_px": scene_module.round_trip_error(back, outline_photo),
        "curation": {k: v for k, v in curated.items() if k.startswith("n_")},
        "timings_s": timings,
        "outputs": {name: str(out_dir / name) for name in (
            "camera.json", "xyz.tif", "outline.gpkg", "outline.shp", "outline_back_on_photo.gpkg", "ortho.tif",
            "report.png")},
    }
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    say("")
    say("outputs in " + str(out_dir) + "/:")
    for name, path in summary["outputs"].items():
        say(f"  {name:27s} {path}")
    say(f"pose error vs the hidden camera: position {errors['position_m']:.1f} m, heading "
        f"{errors['heading_deg']:.3f} deg, pitch {errors['pitch_deg']:.3f} deg, roll {errors['roll_deg']:.3f} deg, "
        f"fov {errors['fov_deg']:.3f} deg (prior was off by {prior_errors['position_m']:.0f} m, "
        f"{prior_errors['heading_deg']:.1f} deg heading)")
    say(f"check points: {summary['check_reprojection_rmse_px']:.2f} px RMSE (prior: "
        f"{summary['prior_check_reprojection_rmse_px']:.1f} px); outline mean error {outline_error:.1f} m; "
        f"photo -> map -> photo round trip {summary['outline_round_trip_px']:.2f} px")
    say(f"demo finished in {summary['seconds']:.1f} s; summary: {out_dir / 'summary.json'}")
    return summary


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "demo-output"), help="output folder (erased first)")
    parser.add_argument("--quick", action="store_true", help="smaller scene, for CI")
    args = parser.parse_args(argv)
    try:
        run(Path(args.out).resolve(), quick=args.quick)
    except cli.QgisProcessError as exc:
        print(f"demo failed: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
