"""What a fitted camera says about the points, for a :class:`~monoplot_plugin.gui.controller.MonoplotController`
(a mixin): residual segments of the matched and the check points, the ground under a photo pixel and the pixel of
a map point, the message bar's summary of a fit, the report's points and σ. Its needs are :class:`ResultsHost`,
checked by ``tests/gui/test_controller_interfaces.py``."""

from __future__ import annotations

import math
from typing import List, Optional, Protocol, Tuple

import numpy as np
from qgis.core import Qgis
from qgis.PyQt.QtCore import QTimer

from ..state import ACCEPTED
from . import engine
from ..core.fit.verdict import pairs_wanted
from .summary import unpartnered_text

__all__ = ["ResultsMixin", "ResultsHost", "MOVED_SIGMAS"]

#: How many position σ (stated by the person, or a GPS's) a fit may move the camera before an "ok" is doubted.
MOVED_SIGMAS = 3.0


class ResultsHost(Protocol):
    """What :class:`ResultsMixin` uses of the controller."""

    state: object  # ProjectState
    image: object  # QImage of the photo or None
    dem: object  # core Dem or None
    xyz: Optional[np.ndarray]  # (H, W, 3) per-pixel map XYZ of the fitted camera, NaN = sky
    fitted: object  # Camera or None
    photo_size: Optional[Tuple[int, int]]
    _fit_ids: Tuple[List[str], List[str]]
    fitInfoChanged: object  # pyqtSignal()
    message: object  # pyqtSignal(str, level)

    prior: object  # Camera or None (PriorsMixin)

    def fit_inputs(self): ...

    def _accepted_for_fit(self) -> Tuple[list, list]: ...

    def _changed(self) -> None: ...

    def tr(self, text: str) -> str: ...


class ResultsMixin:
    """Residuals and lookups under the fitted camera; needs a :class:`ResultsHost`."""

    def _ground_z(self, p: object) -> Optional[float]:
        if p.z is not None:
            return p.z
        z = float(self.dem.sample(p.x, p.y, to_extent=True)) if self.dem is not None else float("nan")
        return z if math.isfinite(z) else None

    def check_points(self):
        """(photo ids, uv (C, 2), xyz (C, 3)) of the check pairs: paired points kept out of the fit."""
        return self.pair_arrays(self.state.check_pairs())

    def pair_arrays(self, point_pairs):
        """(photo ids, uv (K, 2), xyz (K, 3)) of (photo point, map point) pairs whose ground height is known."""
        pairs = [(a, b, self._ground_z(b)) for a, b in point_pairs]
        pairs = [(a, b, z) for a, b, z in pairs if z is not None]
        uv = np.array([(a.x, a.y) for a, _, _ in pairs], dtype=np.float64).reshape(-1, 2)
        xyz = np.array([(b.x, b.y, z) for _, b, z in pairs], dtype=np.float64).reshape(-1, 3)
        return [a.id for a, _, _ in pairs], uv, xyz

    def fit_points_changed(self) -> bool:
        """True when the points a fit would use now are not those of the fitted camera's fit (accepted, rejected,
        moved or undone since): the fit tab says so. False without a record (a camera from a file, older state)."""
        fitted = self.state.fit_info.get("fit_point_xy")  # point id -> (x, y) the fit used
        if self.fitted is None or fitted is None:
            return False
        photo, world = self._accepted_for_fit()
        now = photo + world
        return {p.id for p in now} != set(fitted) or any(tuple(fitted[p.id]) != (p.x, p.y) for p in now)

    def moved_from_prior(self, camera, xyz: np.ndarray, options) -> dict:
        """How far a fit took the camera from the rough one (``moved_m``, horizontally) against the rough camera's
        one-σ position (``position_sigma_m``): the fit settings' Position ±; without it, for a rough camera at the
        photo's EXIF GPS position a GPS's usual error (``moved_from_gps``), else the fit's default (5 % of the median
        range of ``xyz``, the (M, 3) DEM points fitted, 100 m at least). {} without a rough camera."""
        from ..core.fit import FitOptions
        from .priors import GPS_POSITION_M, GPS_SOURCE

        prior = self.prior
        if prior is None:
            return {}
        moved = float(np.linalg.norm(np.subtract(camera.position, prior.position)[:2]))
        reach = np.hypot(*(np.asarray(xyz)[:, :2] - np.asarray(prior.position[:2])).T)
        sigmas = (options or FitOptions()).prior_sigmas(prior.fov, float(np.median(reach)))
        sigma = sigmas["position_m"]
        # a GPS position needs no σ of 5 % of the range (a trial's drone: 369 m off, under that 2σ, unsaid)
        gps = self.state.settings.get("prior_source") == GPS_SOURCE and \
            (options is None or options.position_sigma_m is None)
        stated = gps or (options is not None and options.position_sigma_m is not None)
        return {"moved_m": moved, "position_sigma_m": GPS_POSITION_M if gps else sigma, "moved_from_gps": gps,
                "position_sigma_stated": bool(stated), "fov_deg": float(camera.fov),
                "prior_fov_deg": float(prior.fov), "fov_sigma_deg": sigmas["fov_deg"]}

    def moved_advice(self, info: dict) -> str:
        """What to do about a fit not "ok" that took the camera more than twice the position σ from the rough camera
        (a GPS position: fix it), or its field of view far from the rough one's (give the lens); "" otherwise."""
        if info.get("sees_no_terrain"):  # the points' CRS is wrong, not the position or lens (a re-check trial)
            return ""
        return " ".join(text for text in (self._position_advice(info), self._lens_advice(info)) if text)

    def _lens_advice(self, info: dict) -> str:
        """A fit not "ok" whose field of view ended more than three σ (and 5°) from the rough camera's: a re-check
        trial's poor fit at a 146.6° field of view said nothing of it."""
        fov, prior_fov, sigma = info.get("fov_deg"), info.get("prior_fov_deg"), info.get("fov_sigma_deg")
        if info.get("status", "ok") == "ok" or fov is None or prior_fov is None or not sigma or \
                abs(fov - prior_fov) <= max(3.0 * sigma, 5.0):
            return ""
        return self.tr("The fit took the field of view to {0:.1f}° from the rough camera's {1:.1f}°: if you know "
                       "the lens, give it (Lens, in the Camera tab) and untick field of view in the fit "
                       "settings, then fit again.").format(fov, prior_fov)

    def _position_advice(self, info: dict) -> str:
        moved, sigma = info.get("moved_m"), info.get("position_sigma_m")
        if info.get("status", "ok") == "ok" or moved is None or not sigma or moved <= 2.0 * sigma:
            return ""
        if info.get("moved_from_gps"):
            # fixing, not a Position ±: the σ steers where the search starts, not where the fit ends (a trial gave
            # ± 10 m as advised and got the same camera, 47 m off)
            return self.tr("The fit moved the camera {0:.0f} m from the photo's GPS position, which is usually "
                           "within {1:.0f} m: if it is right, fix the position in the fit settings (untick "
                           "position) and fit again.").format(moved, sigma)
        # a trial's phone photo: GPS 23 m off, the fit "uncertain" 211 m away, and nothing said it had moved
        if not info.get("position_sigma_stated", True):  # a flood trial read "Position ± 153 m", never set
            return self.tr("The fit moved the camera {0:.0f} m from the rough camera, more than twice the uncertainty "
                           "assumed for its position (± {1:.0f} m, 5 % of the distance to the terrain; Position ± in "
                           "the fit settings says better): if the rough position is right (a GPS position), fix the "
                           "position in the fit settings (untick position) and fit again.").format(moved, sigma)
        return self.tr("The fit moved the camera {0:.0f} m from the rough camera, more than twice its stated "
                       "uncertainty (Position ± {1:.0f} m): if the rough position is right (a GPS position), fix the "
                       "position in the fit settings (untick position) and fit again.").format(moved, sigma)

    def doubt_a_moved_camera(self, info: dict) -> None:
        """An "ok" fit without check points that took the camera more than :data:`MOVED_SIGMAS` times the position
        σ the person gave (or a GPS's) from the rough camera contradicts what they know: "uncertain", said in the
        message (in place). A trial's phone photo: "ok" at 1.9 px 117 m behind its GPS position (± 30 m), distant
        terrain trading the position for the field of view. A fit that is not "ok" gets :meth:`moved_advice` in its
        message, for the fit tab (a re-check trial found it in the message bar only, which pointed to the tab)."""
        advice = self.moved_advice(info)
        if advice and advice not in info.get("message", ""):
            info["message"] = (info.get("message", "") + " " + advice).strip()
        moved, sigma = info.get("moved_m"), info.get("position_sigma_m")
        if info.get("status") != "ok" or info.get("n_check") or not info.get("position_sigma_stated") or \
                moved is None or not sigma or moved <= MOVED_SIGMAS * sigma:
            return
        where = self.tr("the photo's GPS position") if info.get("moved_from_gps") else self.tr("the rough camera")
        info["status"] = "uncertain"
        info["message"] = (info.get("message", "") + " " + self.tr(
            "Uncertain: the fit moved the camera {0:.0f} m from {1}, more than {2:.0f} times its Position ± {3:.0f} "
            "m: check points (key C) would say which is right; if the position is, fix it in the fit settings and "
            "fit again.").format(moved, where, MOVED_SIGMAS, sigma)).strip()

    def residuals(self) -> List[Tuple[str, Tuple[float, float], Tuple[float, float]]]:
        """(photo point id, its pixel, the pixel of its DEM match under the fitted camera) for each accepted photo
        point the last fit matched (its pairs, or the automatic pairs of an unpaired fit); without that record
        (older state), each point's nearest projected accepted DEM point."""
        cam = self.fitted
        if cam is None:
            return []
        matched = self.state.fit_info.get("matched")
        if matched:
            out = []
            pts = self.state.points
            links = [(pts[a], pts[b]) for a, b in matched if a in pts and b in pts
                     and pts[a].status == ACCEPTED and pts[b].status == ACCEPTED]
            if not links:
                return []
            world = np.array([(b.x, b.y, b.z if b.z is not None else float(self.dem.sample(b.x, b.y, to_extent=True))
                               if self.dem is not None else 0.0) for _, b in links])
            proj = cam.project(world)
            for (a, _), q in zip(links, proj):
                if np.isfinite(q).all():
                    out.append((a.id, (a.x, a.y), (float(q[0]), float(q[1]))))
            return out
        inputs = self.fit_inputs()
        if isinstance(inputs, str):
            return []
        uv, xyz, pairs = inputs
        photo_ids = self._fit_ids[0]
        segs = engine.residual_segments(cam, uv, xyz, pairs)
        return [(pid, a, b) for pid, (a, b) in zip(photo_ids, segs)]

    def check_residuals(self) -> List[Tuple[str, Tuple[float, float], Tuple[float, float]]]:
        """(photo point id, its pixel, the pixel of its map partner under the fitted camera) per check pair."""
        cam = self.fitted
        ids, uv, xyz = self.check_points()
        if cam is None or not ids:
            return []
        proj = cam.project(xyz)
        return [(pid, (float(a[0]), float(a[1])), (float(q[0]), float(q[1])))
                for pid, a, q in zip(ids, uv, proj) if np.isfinite(q).all()]

    def remeasure_checks(self) -> bool:
        """Measure the fitted camera again on the check pairs as they are now (imported or marked after the fit, or
        moved): ``fit_info``'s ``check_rmse_px`` and ``n_check``, and its status lowered by the check points' rule
        (:func:`~..workflow.auto.judge_by_check_points`, as for a loaded camera or Find camera) from the status the
        fit had before. Emits ``fitInfoChanged`` and returns True when something changed. O(check pairs).

        Without this, check points imported after a fit showed no accuracy until the next Fit (desktop trial)."""
        from ..workflow.auto import judge_by_check_points

        cam, info = self.fitted, self.state.fit_info
        if cam is None or not isinstance(info, dict) or not info:
            return False
        ids, uv, xyz = self.check_points()
        key = [list(ids), np.round(uv, 2).tolist(), np.round(xyz, 2).tolist()]
        if info.get("checks_measured") == key:
            return False
        errors = np.hypot(*(cam.project(xyz) - uv).T) if len(ids) else np.zeros(0)
        if "checks_measured" not in info and _as_the_fit_measured(info, ids, errors):
            # its status already says what they said; nothing recorded (a reopened project, or a plugin reload,
            # must not become "modified" by it)
            return False
        before = info.get("status_before_checks", info.get("status", "ok"))
        message = info.get("message_before_checks", info.get("message", ""))
        own = info.get("rmse_px")  # the fit's residuals: check points far beyond them make it "poor", as in a fit
        judged = judge_by_check_points(before, message, cam, uv, xyz, float(own) if own is not None else np.nan,
                                       info.get("mode") == "paired")
        info.update(checks_measured=key, status_before_checks=before, message_before_checks=message,
                    status=judged["status"], message=judged["message"], check_rmse_px=judged["check_rmse_px"],
                    n_check=len(ids), check_error_px={i: float(e) for i, e in zip(ids, errors) if np.isfinite(e)})
        self._changed()
        self.fitInfoChanged.emit()
        if judged["check_rmse_px"] is not None:  # every change of the check set (a trial's bar kept "on 1" at 7)
            text = self.tr("Check points: {0:.1f} px RMSE on {1}; camera status {2}.").format(
                judged["check_rmse_px"], len(ids), self.tr(judged["status"]))
            level = Qgis.MessageLevel.Success if judged["status"] == "ok" else Qgis.MessageLevel.Warning
            # after the message of the edit that brought them (an import's summary replaced it at once)
            QTimer.singleShot(0, lambda: self.message.emit(text, level))
        return True

    def ground_accuracy_text(self) -> str:
        """" (check points 7.7 px: about 40 m on the ground, the median over the terrain seen, 4.3 km away at the
        median)": what a product of the fitted camera is worth on the ground, for the "Written: ..." message
        (:func:`~..workflow.features.pixel_error`: the check points, else a paired fit's residuals or their
        leave-one-out error, an unpaired fit's σ as a pixel error; without either its error is not known); "" without
        a camera or an XYZ raster."""
        from ..core.fit import check_bound_px
        from ..workflow.features import pixel_error
        from ..workflow.products import ground_error_spread, ground_error_words

        info = self.state.fit_info if isinstance(self.state.fit_info, dict) else {}
        error_px, source = pixel_error(info, only_ok=False)
        if self.fitted is None or self.xyz is None:
            return ""
        if source == "unpaired":
            return self.tr(" (no check points: an unpaired fit's residuals do not say how far off its products are "
                           "on the ground; mark a few accepted pairs as check points to know)")
        if source == "sigma" and info.get("sigma_is_prior"):
            # a figure from σ no data narrowed is no measure (a trial: "about 820 m on the ground", the camera 13 m
            # off at the median)
            return self.tr(" (the camera's σ are no smaller than the rough camera's: the photo's edges did not "
                           "narrow them, so its error on the ground is not known; mark a few accepted pairs as check "
                           "points to know)")
        if error_px is None:
            return ""
        words = ground_error_words(ground_error_spread(self.fitted, self.xyz, error_px, self.dem))
        if not words:
            return ""
        check, n_check = info.get("check_rmse_px"), int(info.get("n_check") or 0)
        # the check points' RMSE and what so many of them vouch for (workflow.features.pixel_error)
        checks = self.tr("check points {0:.1f} px RMSE on {1}, at most {2:.1f} px at 95 %").format(
            check, n_check, check_bound_px(check, n_check)) if check is not None and np.isfinite(check) else ""
        what = {"check": checks,
                "loo": self.tr("fit residuals left out one at a time {0:.1f} px").format(error_px),
                "fit": self.tr("fit residuals {0:.1f} px").format(error_px),
                # an upper estimate: the σ counted as independent (on 148 "ok" synthetic fits the camera's error
                # on the terrain was 0.16 of it at the median, within it in 98.6 %)
                "sigma": self.tr("the camera's σ {0:.1f} px, an upper estimate").format(error_px)}[source]
        if source != "check":  # the larger of two measures, or the only one
            what += self.tr(", more than the {0}").format(checks) if checks else self.tr(", no check points")
        return " (" + what + ": " + words + ")"

    def residual_segments(self) -> List[Tuple[Tuple[float, float], Tuple[float, float]]]:
        """(photo pixel, matched DEM point's pixel) segments of :meth:`residuals`."""
        return [(a, b) for _, a, b in self.residuals()]

    def in_picture(self, overlay: Optional[np.ndarray], xyz: Optional[np.ndarray]):
        """(overlay RGBA, per-pixel XYZ) of a fitted camera (:func:`engine.render_products`, any size) with a scanned
        print's border and caption left out, as the products leave them out (:func:`~..workflow.products.
        picture_area`): transparent and NaN there (the relief was drawn over the paper, the cursor gave it map
        coordinates). The photo's area is found once per photo."""
        from ..workflow.products import area_at, blank_outside

        area = self._picture_area()
        if area is None:
            return overlay, xyz
        if overlay is not None:
            overlay = overlay.copy()
            overlay[~area_at(area, overlay.shape[:2]), 3] = 0
        return overlay, None if xyz is None else blank_outside(xyz, area)

    def _picture_area(self) -> Optional[np.ndarray]:
        from ..adapters.photo import qimage_to_array
        from ..workflow.products import picture_area

        key = (self.state.photo_path, self.photo_size)
        cached = self.__dict__.get("_picture_cache")
        if cached is None or cached[0] != key:
            area = None if self.image is None else picture_area(qimage_to_array(self.image))
            cached = self.__dict__["_picture_cache"] = (key, area)
        return cached[1]

    def ground_at_pixel(self, u: float, v: float) -> Optional[Tuple[float, float, float]]:
        """Map (X, Y, Z) seen at photo pixel (u, v), or None (sky, outside, no fit)."""
        if self.xyz is None:
            return None
        return engine.lookup_xyz(self.xyz, self.photo_size, u, v)

    def camera_spread(self):
        """The fitted camera's σ and correlations as the products carry them
        (:func:`~..workflow.spread.camera_spread`), or None."""
        from ..workflow.spread import camera_spread

        return camera_spread(self.state.fit_info if isinstance(self.state.fit_info, dict) else None, self.dem)

    def ground_error_at_pixel(self, u: float, v: float) -> Optional[Tuple[float, float, str, float]]:
        """(horizontal error in metres, RMS, of the ground seen at photo pixel (u, v); the pixel error it is carried
        from; where that comes from: "check", "loo", "fit" or "sigma", see :func:`~..workflow.features.pixel_error`,
        or "sigma_here" where the camera's σ at that ground is larger, :mod:`~..workflow.spread`; the error of its
        height in metres, NaN where not known), for the cursor readout; None where it is not known (no fit, sky, σ
        no data narrowed, an unpaired fit without σ or check points). The same figure as the features'
        ``xy_error_m`` (:func:`~..workflow.spread.ground_errors_m`): a trial read X, Y, Z to a tenth of a metre with
        nothing saying they were good to 50 m; another read "± 6 m" on near ground 73 m off."""
        from ..workflow.features import pixel_error
        from ..workflow.spread import ground_errors_m, pixel_errors

        info = self.state.fit_info if isinstance(self.state.fit_info, dict) else {}
        ground = self.ground_at_pixel(u, v)
        if self.fitted is None or self.dem is None or info.get("sigma_is_prior") or ground is None:
            return None
        error_px, source = pixel_error(info, only_ok=False)
        if error_px is None:
            return None
        # once per pixel and camera (its XYZ raster is replaced with it): the mouse moves many times over a pixel,
        # and the footprint costs five rays on the DEM
        key = (math.floor(u), math.floor(v), float(error_px), id(self.xyz))
        cached = self.__dict__.get("_ground_error_cache")
        if cached is None or cached[0] != key:
            spread = self.camera_spread()
            here = float(pixel_errors(error_px, spread, self.fitted, np.array([ground]))[0])
            pixel = [[math.floor(u) + 0.5, math.floor(v) + 0.5]]
            error_m, height_m = (float(ground_errors_m(error_px, spread, self.fitted, self.dem, pixel, up)[0])
                                 for up in (False, True))
            cached = self.__dict__["_ground_error_cache"] = (key, (error_m, here, height_m))
        error_m, here, height_m = cached[1]
        if here > error_px:
            error_px, source = here, "sigma_here"
        return (error_m, float(error_px), source, height_m) if np.isfinite(error_m) else None

    def pixel_of_ground(self, x: float, y: float) -> Tuple[Optional[Tuple[float, float]], str]:
        """(pixel, "visible" | "hidden" | "outside" | "") of map point (x, y) under the fitted camera."""
        cam = self.fitted
        if cam is None or self.dem is None:
            return None, ""
        pixel, where = engine.locate_in_photo(cam, self.dem, self.xyz, x, y)
        if pixel is not None and where == "visible":
            from ..workflow.products import in_picture

            if not in_picture(np.array([pixel]), self._picture_area())[0]:
                # on a print's paper, caption or scanner strip (no XYZ there, read as sky: "visible", a trial)
                return pixel, "outside"
        return pixel, where

    def fit_summary(self, info: dict) -> Tuple[str, object]:
        """(message, Qgis message level) of a fit for the message bar: what the RMSE is over, the check points'
        accuracy first when there are some, and the verdict when it is not "ok"."""
        rmse = info.get("rmse_px")
        status = info.get("status", "ok")
        level = Qgis.MessageLevel.Success if status == "ok" else Qgis.MessageLevel.Warning
        text = self.tr("Camera fitted: RMSE {0:.1f} px on {1} photo points.").format(
            rmse if rmse is not None else float("nan"), info.get("n_photo", 0))
        n_matched, n_photo = info.get("n_matched"), info.get("n_photo", 0)
        n_pairs = info.get("n_pairs") or 0
        if info.get("mode") == "paired" and n_pairs:  # its pairs only; the unpaired points wait
            text = self.tr("Camera fitted: RMSE {0:.1f} px on {1} pairs.").format(
                rmse if rmse is not None else float("nan"), n_pairs)
            more = pairs_wanted(n_pairs, len(info.get("free") or ()))  # the fit tab's advice, here too (a trial)
            if more:
                text += " " + self.tr("Pair {0} more point(s): too few pairs to test the camera.").format(more)
            unused = unpartnered_text(info, self.tr)
            if unused and info.get("alone_status"):  # fitted on their own too, the paired fit kept (a trial)
                text += " " + self.tr("The {0} were also fitted on their own, your pairs as check points: "
                                      "{1}, so the paired fit is kept.").format(unused, self.tr(info["alone_status"]))
            elif unused:  # a trial's curation of 18 DEM points went unsaid: both sides are counted
                text += " " + self.tr("Not used by a paired fit: {0}; pair them (select one, Shift+click its "
                                      "partner) to use them.").format(unused)
        if info.get("mode") == "automatic":  # its own matches: they agree with it by construction (a trial read
            # "RMSE 2.3 px on 202 photo points" as the accuracy of a camera 28 px off)
            text = self.tr("Camera fitted: its {1} matched points agree to {0:.1f} px.").format(
                rmse if rmse is not None else float("nan"), n_photo)
        if info.get("mode") == "unpaired" and n_matched is not None and n_matched < n_photo:
            # the RMSE is over the matched points only: say how many, or "30 photo points" overstates a weak fit
            text = self.tr("Camera fitted: RMSE {0:.1f} px on the {1} of {2} photo points that matched a DEM "
                           "point.").format(rmse if rmse is not None else float("nan"), n_matched, n_photo)
        check = info.get("check_rmse_px")
        if check is not None and info.get("pairs_checked"):  # the pairs checked a fit of the other points
            n_check, k = info.get("n_check", 0), info["pairs_checked"]
            checks = self.tr("your {0} pairs, kept out as check points").format(k) if n_check == k else \
                self.tr("{0} check points, your {1} pairs among them").format(n_check, k)
            text = self.tr("Camera fitted: {0:.1f} px RMSE on {1}; the camera from the points without a partner "
                           "(fit: {2:.1f} px on {3} matched points).").format(
                check, checks, float("nan") if rmse is None else rmse, n_photo if n_matched is None else n_matched)
        elif check is not None and info.get("mode") == "paired" and n_pairs:  # its pairs, as the tab says
            text = self.tr("Camera fitted: {0:.1f} px RMSE on {1} check points (fit: {2:.1f} px on {3} "
                           "pairs).").format(check, info.get("n_check", 0),
                                             rmse if rmse is not None else float("nan"), n_pairs)
        elif check is not None:  # the real accuracy first: the message bar shows only its start
            text = self.tr("Camera fitted: {0:.1f} px RMSE on {1} check points (fit: {2:.1f} px on {3} photo "
                           "points).").format(check, info.get("n_check", 0),
                                              rmse if rmse is not None else float("nan"),
                                              info.get("n_photo", 0))
        elif info.get("mode") in ("unpaired", "automatic") and status != "poor":
            text += " " + self.tr("(How well the automatic pairs agree, not the accuracy: pair a few points you "
                                  "recognise, Shift+click a point then its partner in the other view, and mark "
                                  "them as check points, key C.)")
        # the verdict first, and where its reasons are right after it: the message bar shows one line, and the
        # status line under the dock about three (a re-check trial's lost "See the fit tab..." at its end); "Camera
        # fitted: RMSE 3.0 px" read as a success when 3 of 8 points had matched (desktop trial, 2026-12-03)
        if status == "poor":
            text = text.replace(self.tr("Camera fitted:"), self.tr("Camera fit probably wrong (status poor; see the "
                                                                   "fit tab for why and what to do):"), 1)
        elif status != "ok":
            text = text.replace(self.tr("Camera fitted:"), self.tr("Camera fitted, {0} (see the fit tab for why and "
                                                                   "what to do):").format(self.tr(status)), 1)
        if status != "ok" and self.tr("see the fit tab") not in text:  # a text of another form: at its end
            text += " " + self.tr("See the fit tab for why and what to do.")
        advice = self.moved_advice(info)
        if advice:
            text += " " + advice
        clearance = info.get("clearance_m")
        if info.get("height_freed") and clearance is not None:  # the import warned it would be held on the ground
            text += " " + self.tr("The pairs placed the camera {0:.0f} m above the terrain: its height was fitted "
                                  "freely, not held on the ground.").format(clearance)
        if clearance is not None and round(-clearance) >= 1:  # not "0 m below the terrain: the fit is wrong" (a trial)
            level = Qgis.MessageLevel.Warning
            text += " " + self.tr("The camera ended {0:.0f} m below the terrain: the fit is wrong; reject "
                                  "doubtful points or improve the rough camera.").format(-clearance)
        return text, level

    def report_checks(self):
        """The check pairs as the report's ``ReportPoints`` (None without any), read on the main thread; with them
        the person's pairs when the fit kept them out as check points (``pairs_checked``: a fit of the points
        without a partner won), as the fit tab counts them."""
        from ..outputs.report import ReportPoints

        point_pairs = self.state.check_pairs()
        if (self.state.fit_info or {}).get("pairs_checked"):
            point_pairs += self.state.valid_pairs()  # accepted pairs: never check pairs too
        ids, uv, xyz = self.pair_arrays(point_pairs)
        partners = [self.state.partner(i) for i in ids]
        return ReportPoints(uv, xyz, self._pair_names(ids, partners)) if ids else None

    def _pair_names(self, photo_ids, map_ids):
        """The report's names of pairs: the points' own labels (a GCP table's ids: a trial's P01-P10 came out as
        1-8) when every pair has one and no two are the same, else None (numbered 1, 2, ...)."""
        points = self.state.points
        names = [getattr(points.get(a), "label", "") or getattr(points.get(b), "label", "")
                 for a, b in zip(photo_ids, map_ids)]
        return names if names and all(names) and len(set(names)) == len(names) else None

    def report_inputs(self):
        """(ReportPoints of the fit's pairs or None, the fit's sigmas or None) for the report, read on the main
        thread."""
        from ..outputs.report import ReportPoints

        points = None
        info = self.state.fit_info or {}
        info = info if isinstance(info, dict) else {}
        inputs = self.fit_inputs()
        if not isinstance(inputs, str):
            uv, world, pairs = inputs
            if not pairs or info.get("pairs_checked"):  # the person's pairs checked it (report_checks shows them)
                # An unpaired fit: the report shows the automatic pairs the fit matched (by id) and their RMSE;
                # without them its photo panel promised control points and showed none.
                photo_ids, world_ids = self._fit_ids
                index_photo = {pid: i for i, pid in enumerate(photo_ids)}
                index_world = {pid: i for i, pid in enumerate(world_ids)}
                pairs = [(index_photo[a], index_world[b]) for a, b in info.get("matched") or []
                         if a in index_photo and b in index_world]
            if pairs:
                i, j = np.asarray(pairs, dtype=int).T
                photo_ids, world_ids = self._fit_ids
                names = self._pair_names([photo_ids[k] for k in i], [world_ids[k] for k in j])
                points = ReportPoints(np.asarray(uv)[i], np.asarray(world)[j], names)
        # the dock's fit stores its standard deviations as "sigma" (gui/engine.py); a core summary says "std"
        std = info.get("sigma") or info.get("std")
        return points, (std or None)


def _as_the_fit_measured(info: dict, ids, errors: np.ndarray) -> bool:
    """True when the check pairs ``ids`` with their pixel ``errors`` now are those the fit (or the camera's
    loading) measured: its ``check_error_px`` per point, else its count and RMSE (0.001 px)."""
    recorded = info.get("check_error_px")
    if isinstance(recorded, dict) and recorded:
        return set(recorded) == set(ids) and all(abs(float(recorded[i]) - float(e)) < 1e-3
                                                 for i, e in zip(ids, errors) if np.isfinite(e))
    rmse = info.get("check_rmse_px")
    if len(ids) != (info.get("n_check") or 0):
        return False
    finite = errors[np.isfinite(errors)]
    if rmse is None or not len(finite):
        return rmse is None and not len(finite)
    return abs(float(rmse) - float(np.sqrt(np.mean(finite ** 2)))) < 1e-3
