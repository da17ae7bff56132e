"""Camera files in the dock: a camera JSON or KML loaded as the rough or the fitted camera, and saved (split from
:mod:`.io_actions`, which puts them in the camera tab's "Camera files" menu).

The reader and writer are the workflow's (:mod:`..workflow.camera_files`, shared with Processing). A fitted camera
loaded from a file comes back with its own fit's verdict only when it is about this photo (see
:func:`~..workflow.camera_files.fitted_on_photo`).
"""

from __future__ import annotations

import dataclasses
import os
from typing import Optional

import numpy as np
from qgis.core import Qgis
from qgis.PyQt.QtCore import QCoreApplication

from ..core.camera import Camera
from ..core.fit.check_points import judge_by_checks
from ..workflow.camera_files import fitted_on_photo, load_camera, save_camera, written_fit
from ..workflow.fit import ground_height_sigma, measured_on_pairs
from ..workflow.inputs import InputError

__all__ = ["load_camera_file", "save_camera_file"]

INFO, WARNING, CRITICAL = Qgis.MessageLevel.Info, Qgis.MessageLevel.Warning, Qgis.MessageLevel.Critical


def tr(text: str) -> str:
    return QCoreApplication.translate("MonoplotIo", text)


def load_camera_file(controller, path: str, as_fitted: bool = False,
                     default_fov: Optional[float] = None) -> Optional[Camera]:
    """Read a camera JSON (Processing's ``fitcamera`` output, a saved one) or a KML PhotoOverlay as the rough camera,
    or (``as_fitted``) as the fitted camera: overlay, footprint and per-pixel XYZ are rendered in a task, and the
    check points, if any, are measured on it."""
    c = controller
    if c.image is None or c.dem is None:
        c.message.emit(tr("Load the photo and choose the DEM before loading a camera."), WARNING)
        return None
    notes = []
    try:
        camera = load_camera(path, c.photo_size, c.dem.crs_wkt, notes, rough=not as_fitted,
                             default_fov=None if as_fitted else default_fov)
    except InputError as exc:
        c.message.emit(str(exc), CRITICAL)
        return None
    if not camera.crs_wkt:
        camera = dataclasses.replace(camera, crs_wkt=c.dem.crs_wkt)
    name = os.path.basename(path)
    moved = "".join(" " + note[0].upper() + note[1:] + "." for note in notes)  # transformed into the DEM's CRS
    if not as_fitted:
        c.set_prior(camera)
        note = c.under_terrain_note(camera)
        c.message.emit(tr("Rough camera loaded from {0}.").format(name) + moved + note, WARNING if note else INFO)
        return camera
    info = {"loaded_from": path}
    n_check, check_rmse = measured_on_pairs(camera, *c.check_points()[1:])
    if n_check:
        info.update(check_rmse_px=check_rmse, n_check=n_check)
    # nothing here fitted it: only check points can say it is right (never a green "ok" by default)
    info["status"], verdict = judge_by_checks(info.get("check_rmse_px", float("nan")), info.get("n_check", 0),
                                              float(np.hypot(*c.photo_size)))
    info["message"] = tr("Camera loaded from {0}.").format(name) + moved + " " + verdict
    fit = written_fit(path)
    written, why = str(fit.get("status") or ""), str(fit.get("message") or "")
    sigma = {str(k): float(v) for k, v in (fit.get("sigma") or {}).items() if isinstance(v, (int, float))}
    elsewhere = written == "ok" and not n_check and fitted_on_photo(fit, c.state.photo_path or "") is False
    if written in ("uncertain", "poor") and not n_check:  # its own fit doubted it: so does the dock
        info["status"] = "poor" if written == "poor" else info["status"]  # unchecked: "uncertain" already
        info["message"] += " " + tr("It was written by a fit whose verdict was \"{0}\": {1}").format(written, why)
        if sigma:  # how doubtful, per parameter (a trial's reloaded "uncertain" camera showed no ± at all)
            info["sigma"] = sigma
    elif elsewhere:
        # its fit verified it on another photo: that "ok" says nothing of this one (a trial loaded frame 1's camera
        # onto frame 5, after a 4 degree remount: "ok", and a front 168 m off where its error said 6.9 m)
        info["message"] += " " + tr(
            "It was fitted on another photo ({0}), not on this one: its \"ok\" does not carry over (a camera turned "
            "by a few degrees looks the same in the file). Fit it on this photo's points, use it as the rough camera "
            "for Find camera automatically, or mark check points; for frames of a fixed camera, change the photo "
            "with \"Keep the points\", which measures the turn.").format(str(fit.get("photo") or tr("unknown")))
        if sigma:
            info["sigma"] = sigma
    elif written == "ok" and not n_check:
        # its own fit verified it (the dock's Save fitted camera, fitcamera): that verdict and its σ come back with
        # it (a trial's "ok" camera reloaded as "uncertain", and the features drawn on it lost their xy error)
        info["status"] = "ok"
        info["message"] = tr("Camera loaded from {0}.").format(name) + moved + " " + tr(
            "Loaded with its own fit's verdict, \"ok\" (check points here would measure it again): {0}").format(
            why.strip() or tr("no details."))
        if sigma:
            info["sigma"] = sigma
        # its fit's figures: features drawn on it get their xy_error_m from them (a trial's had none)
        info.update({k: fit[k] for k in ("mode", "rmse_px", "loo_rmse_px", "sigma_px", "correlation") if k in fit})
    # where it stood, whatever its verdict: held on the ground, and how high above it (a time-lapse trial's camera,
    # 1.6 m up, read "ground + 0 m" once reloaded)
    info.update({k: fit[k] for k in ("on_ground", "eye_height_m") if k in fit})
    if info.get("on_ground") and info.get("sigma"):  # its Z as sure as the terrain under its X, Y ± (as fitted)
        info["ground_sigma_m"] = ground_height_sigma(camera, info["sigma"], c.dem)
    ids, uv, xyz = c.pair_arrays(c.state.valid_pairs())
    n_pairs, pairs_rmse = measured_on_pairs(camera, uv, xyz)
    if n_pairs:  # how the camera fits the pairs already there (a measure of agreement, not of accuracy)
        info.update(rmse_px=pairs_rmse, mode="paired", n_pairs=len(ids), n_photo=len(ids), n_map=len(ids),
                    n_matched=n_pairs)
        info["message"] += " " + tr("On the {0} pairs already there it gives {1:.1f} px RMSE.").format(
            n_pairs, pairs_rmse)
    c.set_fitted(camera, info, background=True)
    if elsewhere:  # said where the person looks, not only in the fit tab (a re-check trial on the camera tab)
        c.message.emit(tr("Fitted camera loaded from {0}: \"uncertain\" here, it was fitted on another photo "
                          "({1}); see the fit tab.").format(name, str(fit.get("photo") or tr("unknown"))) + moved,
                       WARNING)
    elif info["status"] != "ok":  # its status where the person looks, in the colour it has (a trial's "uncertain"
        # camera loaded with a blue "Fitted camera loaded" and nothing more)
        c.message.emit(tr("Fitted camera loaded from {0}: \"{1}\"; see the fit tab for why.").format(
            name, tr(info["status"])) + moved, WARNING)
    else:
        c.message.emit(tr("Fitted camera loaded from {0}.").format(name) + moved, INFO)
    return camera


def save_camera_file(controller, path: str, which: str = "fitted") -> bool:
    """Write the fitted (``which="fitted"``) or rough camera as Monoplot JSON, or as KML for a ``.kml`` path."""
    c = controller
    camera = c.fitted if which == "fitted" else c.prior
    if camera is None:
        c.message.emit(tr("There is no {0} camera to save.").format(tr("fitted") if which == "fitted"
                                                                    else tr("rough")), WARNING)
        return False
    if not camera.crs_wkt and c.dem is not None:
        camera = dataclasses.replace(camera, crs_wkt=c.dem.crs_wkt)
    try:
        info = (c.state.fit_info or {}) if which == "fitted" else {}
        save_camera(path, camera, name=os.path.splitext(os.path.basename(c.state.photo_path or path))[0],
                    verdict=info if info.get("status") else None,
                    photo_path=(c.state.photo_path or "") if info.get("status") else "")
    except (OSError, ValueError) as exc:
        c.message.emit(tr("Cannot write {0}: {1}").format(path, exc), CRITICAL)
        return False
    c.message.emit(tr("Camera written to {0}.").format(path), INFO)
    return True
