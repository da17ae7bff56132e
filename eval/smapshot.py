"""`make eval`: the fit on 100 real small GCP sets (smapshot's nadir validation set, ../shared/data/smapshot_nadir).

Each set has 6-14 real pixel <-> 3-D correspondences of a historical aerial photograph (no image, no DEM). Per set:

- ``paired``: a 7-parameter paired fit started from the stored position and focal length (angles from a PnP solve):
  the reference camera of that set.
- ``unpaired``: the same points with the photo order shuffled, no pairing, from the reference camera perturbed by up
  to 50 m in position and 3 deg in heading, pitch and roll (seeded): the unpaired mode on small real sets, where
  nearest-point matching is ambiguous. A fit succeeds when the set's GCPs project within 1 px RMS of where the
  reference camera puts them.

Printed: one JSON line per mode (success rate, the verdict's confusion matrix status x success / failure, "ok"
precision, median fit time) and the failures reported "ok" by id.

Run: ``.venv/bin/python -m eval.smapshot [--data DIR] [--sets N]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from monoplot_plugin.core.camera import Camera, fov_from_focal  # noqa: E402
from monoplot_plugin.core.fit import STATUSES, fit_camera  # noqa: E402


def lv95(lon, lat, alt):
    """(N, 3) Swiss LV95 metres (EPSG:2056) from WGS 84 degrees and metres (heights kept)."""
    from osgeo import osr

    src, dst = osr.SpatialReference(), osr.SpatialReference()
    src.ImportFromEPSG(4326)
    dst.ImportFromEPSG(2056)
    for s in (src, dst):
        s.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    t = osr.CoordinateTransformation(src, dst)
    out = np.array([t.TransformPoint(float(x), float(y)) for x, y in zip(np.atleast_1d(lon), np.atleast_1d(lat))])
    out[:, 2] = np.atleast_1d(alt)
    return out


def reference(entry):
    """(uv (N, 2), xyz (N, 3), reference camera, paired result) of one set."""
    g = entry["gcp_json"]
    uv = np.array([[p["x"], p["y"]] for p in g], dtype=float)
    xyz = lv95([p["longitude"] for p in g], [p["latitude"] for p in g], [p["altitude"] for p in g])
    position = lv95(entry["lng"], entry["lat"], entry["alt"])[0]
    size = (int(entry["width"]), int(entry["height"]))
    # A camera looking straight down at the points' centre, at the stored position and focal length; the paired
    # fit (PnP starts inside) finds the angles.
    d = xyz.mean(axis=0) - position
    heading = math.degrees(math.atan2(d[0], d[1]))
    pitch = math.degrees(math.atan2(d[2], math.hypot(d[0], d[1])))
    start = Camera(tuple(position), heading, max(-89.0, pitch), 0.0, fov_from_focal(entry["focal"], size[0]), size)
    pairs = np.column_stack([np.arange(len(uv))] * 2)
    paired = fit_camera(uv, xyz, start, pairs=pairs)
    return uv, xyz, paired.camera, paired


def confusion(records):
    table = {s: {"success": 0, "failure": 0} for s in STATUSES}
    for r in records:
        table.setdefault(r["status"], {"success": 0, "failure": 0})
        table[r["status"]]["success" if r["success"] else "failure"] += 1
    ok = table["ok"]["success"] + table["ok"]["failure"]
    return table, (round(table["ok"]["success"] / ok, 3) if ok else None)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("MONOPLOT_SMAPSHOT",
                                                         str(REPO.parent / "shared" / "data" / "smapshot_nadir")))
    parser.add_argument("--sets", type=int, default=100)
    args = parser.parse_args(argv)
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:
        pass
    path = Path(args.data) / "images_nadir.json"
    if not path.is_file():
        print(json.dumps({"case": "smapshot", "error": f"data not found in {path.parent}"}))
        return 1
    entries = json.loads(path.read_text())[:args.sets]
    paired_records, unpaired_records = [], []
    t0 = time.perf_counter()
    for k, entry in enumerate(entries):
        uv, xyz, ref, paired = reference(entry)
        truth_uv = ref.project(xyz)
        paired_records.append({"id": entry["id"], "status": paired.status, "success": paired.status == "ok",
                               "rmse_px": round(float(paired.rmse_px), 2), "fit_s": paired.elapsed_s})
        rng = np.random.default_rng(k)
        prior = ref.with_parameters(x=ref.position[0] + rng.uniform(-50, 50), y=ref.position[1] + rng.uniform(-50, 50),
                                    z=ref.position[2] + rng.uniform(-50, 50), heading=ref.heading + rng.uniform(-3, 3),
                                    pitch=ref.pitch + rng.uniform(-3, 3), roll=ref.roll + rng.uniform(-3, 3))
        order = rng.permutation(len(uv))
        r = fit_camera(uv[order], xyz, prior, position_sigma_m=75.0, angle_sigma_deg=4.5)
        err = float(np.sqrt(np.nanmean(np.sum((r.camera.project(xyz) - truth_uv) ** 2, axis=1))))
        unpaired_records.append({"id": entry["id"], "status": r.status, "success": bool(err <= 1.0),
                                 "error_px": round(err, 2), "points": len(uv), "fit_s": r.elapsed_s})
    for mode, records in (("paired", paired_records), ("unpaired_shuffled", unpaired_records)):
        table, precision = confusion(records)
        line = {"case": f"smapshot_{mode}", "sets": len(records),
                "success_rate": round(float(np.mean([r["success"] for r in records])), 3), "confusion": table,
                "ok_precision": precision, "median_fit_s": round(float(np.median([r["fit_s"] for r in records])), 2),
                "failures_reported_ok": [r["id"] for r in records if r["status"] == "ok" and not r["success"]]}
        if mode == "paired":
            line["median_rmse_px"] = round(float(np.median([r["rmse_px"] for r in records])), 2)
        print(json.dumps(line), flush=True)
    print(json.dumps({"case": "smapshot", "runtime_s": round(time.perf_counter() - t0, 1)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
