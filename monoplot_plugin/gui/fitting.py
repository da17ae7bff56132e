"""The dock's Fit: the accepted points it uses, the camera it starts from, the fit in a task, and the automatic
registration's verdict capping a fit that rests on its matches alone.

A mixin of :class:`~.controller.MonoplotController` (it uses the controller's state, stack, task runner and
signals); the fit itself is the workflow's (:mod:`..workflow.fit` through :mod:`.engine`).
"""

from __future__ import annotations

import math
from typing import List, Tuple

import numpy as np
from qgis.core import Qgis

from ..core.fit import sigma_pixels
from ..state import ACCEPTED, MAP, PHOTO, Point
from ..workflow import auto as auto_step
from ..workflow import fit as fit_step
from . import engine
from .fit_settings import fit_arguments, height_arguments
from .refit import inputs_key

INFO, WARNING = Qgis.MessageLevel.Info, Qgis.MessageLevel.Warning


class FittingMixin:
    """Fit the camera to the accepted points (:meth:`fit`)."""

    def _accepted_for_fit(self) -> Tuple[List[Point], List[Point]]:
        """(photo points, map points with a height) the fit would use: the accepted ones, map points off the DEM
        and without a height of their own left out."""
        photo = self.state.in_space(PHOTO, (ACCEPTED,))
        world = [p for p in self.state.in_space(MAP, (ACCEPTED,))]
        if self.dem is not None:
            world = [p if p.z is not None else
                     Point(**{**p.__dict__, "z": float(self.dem.sample(p.x, p.y, to_extent=True))}) for p in world]
        return photo, [p for p in world if p.z is not None and math.isfinite(p.z)]

    def heightless_text(self, kept=None) -> str:
        """What the fit leaves out of the accepted map points for want of a height (off the DEM, or on a void, and
        no height of their own), "" when none: a trial's pair was dropped without a word. ``kept``: the ids of the
        map points the fit takes, when known (:meth:`fit_inputs` found them)."""
        kept = {p.id for p in self._accepted_for_fit()[1]} if kept is None else set(kept)
        left = [p for p in self.state.in_space(MAP, (ACCEPTED,)) if p.id not in kept]
        # check points too: a trial's lake check point, on a void, was left out of "7.3 px RMSE on 3" unsaid
        unchecked = sum(self._ground_z(b) is None for _, b in self.state.check_pairs())
        checks = (self.tr("1 check point's map point has no height (off the DEM or on a void) and is not measured: "
                          "move it onto the DEM.") if unchecked == 1 else
                  self.tr("{0} check points' map points have no height (off the DEM or on a void) and are not "
                          "measured: move them onto the DEM.").format(unchecked)) if unchecked else ""
        if not left:
            return checks
        paired = {b.id for _, b in self.state.valid_pairs()}
        n_paired = sum(p.id in paired for p in left)
        text = (self.tr("1 accepted DEM point has no height (off the DEM or on a void) and is left out")
                if len(left) == 1 else
                self.tr("{0} accepted DEM points have no height (off the DEM or on a void) and are left out")
                .format(len(left)))
        if n_paired:
            text += self.tr(", with its pair") if n_paired == 1 else self.tr(", with {0} pairs").format(n_paired)
        return text + self.tr(": move them onto the DEM.") + (" " + checks if checks else "")

    def fit_inputs(self):
        """(photo uv (N, 2), map xyz (M, 3), pairs [(i, j)]) of the accepted points, or a reason string."""
        photo, world = self._accepted_for_fit()
        if len(photo) < self.MIN_POINTS or len(world) < self.MIN_POINTS:
            return self.tr("The fit needs at least {0} accepted points on the photo and on the map "
                           "(now {1} and {2}).").format(self.MIN_POINTS, len(photo), len(world))
        index_photo = {p.id: i for i, p in enumerate(photo)}
        index_world = {p.id: i for i, p in enumerate(world)}
        pairs = [(index_photo[a.id], index_world[b.id]) for a, b in self.state.valid_pairs()
                 if a.id in index_photo and b.id in index_world]
        if len(pairs) < self.MIN_POINTS:
            pairs = []  # a paired fit uses the pairs only: fewer than 4 would under-determine the 7 unknowns
        uv = np.array([(p.x, p.y) for p in photo], dtype=np.float64)
        xyz = np.array([(p.x, p.y, p.z) for p in world], dtype=np.float64)
        self._fit_ids = ([p.id for p in photo], [p.id for p in world])
        return uv, xyz, pairs

    def fit_start(self):
        """The camera a fit starts from: the rough camera, else the fitted one; the fitted one when it was loaded
        from a file (a batch's or a saved camera, loaded to go on from: a trial's next Fit started from the photo's
        EXIF GPS camera instead) or found by the automatic registration (not "poor"). None without either."""
        info = self.state.fit_info or {}
        if self.fitted is not None and info.get("loaded_from"):
            return self.fitted
        from .priors import HEADING_GUESSED

        guessed = bool(self.state.settings.get(HEADING_GUESSED))  # the rough camera's heading is no one's word
        if self.fitted is not None and info.get("status") != "poor" and (
                info.get("mode") == "automatic" or (guessed and info.get("from_fitted_prior") == self.state.prior)):
            # the registration's camera, not the rough one it searched from (and, while that rough camera's heading
            # is a guess, the fits that went on from it): a phone trial's refits started from its EXIF camera aimed
            # at the DEM's centre, 155° off, and were refused ("Every DEM point is behind the initial camera")
            return self._held_at_prior(self.fitted)
        return self.prior or self.fitted

    def _held_at_prior(self, camera):
        """``camera`` standing at the rough camera's position where the fit settings hold the position (x and y
        unticked; its height too when z is): "if the GPS position is right, untick position and fit again" meant the
        rough camera's position, and after Find camera automatically the fit held the registration's, 68 m from it
        (a phone trial; the advice came back unchanged). A rough camera on the ground gives its height too: a height
        belongs to its place there (a time-lapse trial's mast, 3 m above a steep flank: the registration's camera, 3
        m above the ground 10 m uphill, held at the mast's X, Y kept its height, 14 m above the ground, "ok")."""
        prior = self.prior
        free = fit_arguments(self.state.settings)[0]
        if prior is None or free is None:
            return camera
        values = {}
        if not {"x", "y"} & set(free):
            values.update(x=prior.position[0], y=prior.position[1])
            on_ground = height_arguments(self.state.settings)["on_ground"]
            if self.dem is not None and fit_step.on_ground_rule(prior, self.dem, on_ground)[0]:
                values["z"] = prior.position[2]
        if "z" not in free:
            values["z"] = prior.position[2]
        return camera.with_parameters(**values) if values else camera

    def fit(self) -> bool:
        """Fit the camera to the accepted points in a task (prior = start); result applied on the main thread."""
        if self.image is None or self.dem is None:
            self.message.emit(self.tr("Load a photo and choose a DEM first."), WARNING)
            return False
        start = self.fit_start()
        # gone on from the fitted camera, not the rough one: the next fit does too, until the rough camera changes
        from_fitted = self.state.prior if start is not None and self.state.prior is not None and \
            start.to_dict() == self.state.fitted else None
        paired_xyz = self.pair_arrays(self.state.valid_pairs())[2] if start is None else ()
        if len(paired_xyz) >= fit_step.MIN_PAIRS_WITHOUT_PRIOR:  # no rough camera: solved from them, as fitcamera
            start = fit_step.start_above_points(paired_xyz, self.photo_size, self.dem.crs_wkt)
            self.message.emit(self.tr("No rough camera: the camera is solved from the {0} pairs alone.").format(
                len(paired_xyz)), INFO)
        if start is None:
            self.message.emit(self.tr("Give a rough camera first (map tool or KML), or pair {0} or more "
                                      "points.").format(fit_step.MIN_PAIRS_WITHOUT_PRIOR), WARNING)
            return False
        inputs = self.fit_inputs()
        if isinstance(inputs, str):
            self.message.emit(inputs, WARNING)
            return False
        uv, xyz, pairs = inputs
        heightless = self.heightless_text(kept=self._fit_ids[1])
        if heightless:
            self.message.emit(heightless, WARNING)
        n_links = len(self.state.valid_pairs())
        if 0 < n_links < self.MIN_POINTS:
            # not "ignored": their points are fitted, unpaired (a time-lapse trial read "3 pair(s) ignored" and then
            # "were fitted as unpaired points" in the fit's message)
            self.message.emit(self.tr("Your {0} linked pair(s) are fitted as unpaired points: a paired fit needs at "
                                      "least {1}.").format(n_links, self.MIN_POINTS), INFO)
        photo_ids, world_ids = self._fit_ids
        point_xy = {pid: (self.state.points[pid].x, self.state.points[pid].y) for pid in photo_ids + world_ids}
        check_ids, check_uv, check_xyz = self.check_points()
        dem = self.dem

        free, options = fit_arguments(self.state.settings)  # the dock's fit settings (gui/fit_settings.py)
        height = height_arguments(self.state.settings)  # on the ground / in the air / automatic
        key = inputs_key(uv, xyz, pairs, start, free, (options, height), check_uv, check_xyz)
        known = self._known_fit[1] if self._known_fit[0] == key else None  # the background refit's, if the same
        # A refit of these very inputs under way (the person clicked Fit soon after the last accept): wait for it
        # rather than cancel it and start the same fit again; the Fit fits itself when the refit fails.
        awaited = None if known is not None else self.running_refit(key)
        self.awaited_refit = awaited

        def work(progress, is_canceled):
            done = known
            if awaited is not None:
                progress(0.0, "waiting for the background fit of these points")
                done = awaited.wait(is_canceled)
            return engine.fit_and_render(uv, xyz, pairs, start, dem, progress, is_canceled, check_uv, check_xyz,
                                         free=free, options=options, done=done, **height)

        def apply(outcome):
            if from_fitted is not None:
                outcome.info["from_fitted_prior"] = from_fitted
            # the matches the fit used, by point id (indices would drift with later edits)
            outcome.info["matched"] = [[photo_ids[i], world_ids[j]] for i, j in outcome.info.pop("matched_idx", [])]
            outcome.info["check_error_px"] = dict(zip(check_ids, outcome.info.pop("check_errors", [])))
            outcome.info["outliers"] = [photo_ids[i] for i in outcome.info.pop("outlier_idx", [])]
            # what the camera was fitted to, to say when the points have changed since (fit_points_changed)
            outcome.info["fit_point_xy"] = point_xy  # point id -> (x, y)
            sigma = outcome.info.get("sigma")
            self.cap_by_automatic(outcome.info, photo_ids + world_ids, len(pairs), len(check_ids))
            if outcome.info.get("sigma") != sigma:  # widened to the registration's: its pixel error with it
                widened = sigma_pixels(outcome.camera, outcome.info["sigma"], xyz)
                outcome.info["sigma_px"] = engine.finite_or_none(widened)
            outcome.info.update(self.moved_from_prior(outcome.camera, xyz, options))
            self.doubt_a_moved_camera(outcome.info)
            if heightless:  # said before the fit too; the fit's message stays with its camera
                outcome.info["message"] = (outcome.info.get("message", "") + " " + heightless).strip()
            if 0 < n_links < self.MIN_POINTS:  # said before the fit too, but its message replaced that at once
                outcome.info["message"] = (outcome.info.get("message", "") + " " + self.tr(
                    "Your {0} linked pair(s) were fitted as unpaired points: a paired fit needs at least {1}.")
                    .format(n_links, self.MIN_POINTS)).strip()
            self._apply_fit(outcome)

        title = self.tr("Fit camera") if known is None else self.tr("Fit camera (already fitted in the background)")
        return self._start("fit", title, work, apply)

    def cap_by_automatic(self, info: dict, ids, n_pairs: int, n_check: int) -> None:
        """A fit on the points ``ids`` while they are all the automatic registration's own matches: its status capped
        by the registration's verdict (:func:`~..workflow.auto.cap_by_automatic`) and its σ no smaller than the
        registration's (the greyed ± showed 0.5 m after a 200 m registration), in ``info``."""
        labels = [self.state.points[i].label for i in ids if i in self.state.points]
        automatic = str(self.state.settings.get("automatic_status") or "")
        info["status"], info["message"] = auto_step.cap_by_automatic(
            info.get("status", "ok"), info.get("message", ""), labels, n_pairs, n_check, automatic)
        if automatic and auto_step.rests_on_automatic(labels, n_pairs, n_check):
            info["sigma"] = auto_step.sigma_at_least(info.get("sigma"), self.state.settings.get("automatic_sigma"))

    def remember_fit(self, key: tuple, done) -> None:
        """A background refit finished: the Fit button's fit of the same inputs (``refit.inputs_key``) renders its
        camera instead of fitting again."""
        self._known_fit = (key, done)
