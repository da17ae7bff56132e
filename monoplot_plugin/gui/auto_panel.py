"""The dock's "Find camera automatically" button (issue 13): the automatic registration in a background task.

The dock calls :func:`install_auto_panel` once; the button sits in the "Fit and results" tab (the dock's
``add_output_action`` extension point). The registration runs as the controller's task (progress bar, Cancel
button, busy state shared with the fit); when it ends, the camera is shown like a fit's (overlay, XYZ, status and
message in the fit tab) and the photo and DEM points it matched are added as *accepted* points, so the person checks
them (reject the wrong ones, pair a few, mark check points) and the semi-automatic fit takes over. The overlay then
also shows the DEM's skyline and occluding contours under the camera found (magenta) over the photo's detected
skyline (cyan): where they part, the camera or the skyline is wrong.
"""

from __future__ import annotations

import logging
import math
from typing import Optional

import numpy as np
from qgis.core import Qgis
from qgis.PyQt.QtCore import QObject, Qt
from qgis.PyQt.QtWidgets import QAction, QSizePolicy, QToolButton

from ..adapters import layers as camera_layers
from ..adapters.photo import qimage_to_array
from ..core.auto.overlay import draw_alignment
from ..core.fit import sigma_pixels
from ..state import ACCEPTED, MAP, PHOTO, REJECTED, SUGGESTED, Point, replace_in_views
from ..workflow import auto as auto_step
from ..workflow.progress import part
from ..workflow.spread import plain_correlation
from . import engine
from .camera_follow import CamerasFollowEdit, camera_snapshot
from .fit_settings import fit_arguments, height_arguments

__all__ = ["install_auto_panel", "AutoPanel"]


def install_auto_panel(dock) -> "AutoPanel":
    """Add the "Find camera automatically" button to ``dock`` (a MonoplotDock); returns its owner."""
    return AutoPanel(dock)


#: the rough camera's σ for the registration of what the fit settings hold fixed (field of view, position, heading
#: and pitch together): the search stays within a few hundredths of a degree, a metre
FIXED_FOV_SIGMA_DEG = 0.02
FIXED_POSITION_SIGMA_M = 1.0
FIXED_ANGLE_SIGMA_DEG = 0.05
#: share of the field of view: its σ in the search when the rough camera's comes from the photo's lens (EXIF focal
#: length: a 35 mm equivalent is rounded to the millimetre, and its crop factor taken on the diagonal)
LENS_FOV_SHARE = 0.04


class AutoPanel(QObject):
    """The button and its task of one dock."""

    def __init__(self, dock):
        super().__init__(dock)
        self.dock = dock
        self.controller = dock.controller
        self.action = QAction(self.tr("Find camera automatically"), dock)
        self.action.setToolTip(self.tr("Align the photo's skyline and ridges with the DEM's from the rough camera, "
                                       "then fit Monoplot's suggestions: no clicks. The matched points become "
                                       "accepted points to check."))
        self.action.triggered.connect(self.run)
        dock.add_output_action(self.action)
        # ... and under the rough camera's buttons, where the camera it starts from is given (a trial looked for it
        # there, and found it at the bottom of the fit tab among the products)
        self.camera_tab_button = QToolButton(dock)
        self.camera_tab_button.setDefaultAction(self.action)
        self.camera_tab_button.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextOnly)
        self.camera_tab_button.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
        layout = dock.cameraTabLayout
        layout.insertWidget(layout.indexOf(dock.cameraButtons) + 1, self.camera_tab_button)
        #: (the "Automatic points" edit, the fit before it, the fit it brought): an Undo of those points takes
        #: the registration's camera back too, a Redo brings it again (a trial: after the Undo the fit tab still
        #: spoke of its 134 points, and the next Suggest drew DEM suggestions from its "uncertain" camera)
        self._follower = CamerasFollowEdit(self.controller, background=True,
                                           on_restored=lambda camera: camera or dock._update_camera_layers())

    def run(self) -> bool:
        """Start the registration from the rough camera (prior, else the fitted camera) in a task."""
        c = self.controller
        if c.image is None or c.dem is None:
            c.message.emit(self.tr("Load a photo and choose a DEM first."), Qgis.MessageLevel.Warning)
            return False
        prior = c.prior  # a new Camera at every read: compared by this one, not by identity
        start = prior or c.fitted
        if start is None:
            c.message.emit(self.tr("Give a rough camera first (map tool, KML or EXIF)."), Qgis.MessageLevel.Warning)
            return False
        from .priors import HEADING_GUESSED

        heading_known = not (prior is not None and start is prior and c.state.settings.get(HEADING_GUESSED))
        if not heading_known:
            # the ordinary search keeps near the rough camera's view: from a heading aimed at the DEM's centre it
            # could not find a view tens of degrees away (trials B and C: "uncertain", or a camera with 24° of roll)
            c.message.emit(self.tr("The photo's EXIF has no direction of view: every direction is searched, which "
                                   "takes three to four times as long. Draw the view direction on the map (Camera "
                                   "tab) to save the time."), Qgis.MessageLevel.Info)
        photo = qimage_to_array(c.image)  # a copy: the task must not share Qt objects
        dem = c.dem
        _, check_uv, check_xyz = c.check_points()  # the person's check points measure the camera found
        sigmas = self.prior_sigmas(prior is not None)
        height = height_arguments(c.state.settings)  # "camera height: on the ground" holds the search there too
        # a view far from the rough heading (a trial's 183°) is looked for over every direction when the edges fit
        # loosely near it, unless the person gave the angles' uncertainty (Angles ±): then the heading is that sure
        search_wider = sigmas["angle_sigma_deg"] is None
        free = fit_arguments(c.state.settings)[0]
        hold = free is not None and not {"x", "y"} & set(free) and prior is not None and start is prior

        def work(progress, is_canceled):
            done = auto_step.register(photo, dem, start, **sigmas, progress=part(progress, 0.0, 0.9),
                                      is_canceled=is_canceled, heading_known=heading_known,
                                      every_direction_if_loose=search_wider, hold_position=hold, **height)
            overlay, xyz, footprint = engine.render_products(done.camera, dem, is_canceled)
            # the DEM's silhouettes under the camera found over the photo's detected skyline
            overlay = draw_alignment(overlay, done.camera, done.result.skyline, dem)
            checked = auto_step.judge_by_check_points(done.result.status, done.result.message, done.camera,
                                                      check_uv, check_xyz, done.result.rmse_px)
            progress(1.0, "")
            return done, overlay, xyz, footprint, checked

        return c.run_task("auto", self.tr("Find camera automatically"), work, self._apply)

    def prior_sigmas(self, from_prior: bool) -> dict:
        """The rough camera's uncertainty for the registration: what the person set in the fit settings
        (Position ±, Angles ±, Field of view ±); without a Position ±, for a rough camera at the photo's EXIF GPS
        position, a GPS's usual error (a trial's phone photo over a floodplain, GPS 32 m off: registered 251 m
        from where it stood with the default 200 m, 16 m and 90 m with 30 m in two runs, "uncertain" each time);
        without a Field of view ±, for a rough camera whose field of view is the photo's lens's (EXIF),
        :data:`LENS_FOV_SHARE` of it; else the registration's defaults."""
        from .priors import GPS_POSITION_M, GPS_SOURCE

        c = self.controller
        options = fit_arguments(c.state.settings)[1]
        sigmas = {name: getattr(options, name, None) for name in ("position_sigma_m", "angle_sigma_deg",
                                                                   "fov_sigma_deg")}
        if sigmas["position_sigma_m"] is None and from_prior and c.state.settings.get("prior_source") == GPS_SOURCE:
            sigmas["position_sigma_m"] = GPS_POSITION_M
        free = fit_arguments(c.state.settings)[0]
        if free is not None:  # what the fit may not change is known: the search keeps it too (a trial's 35 mm lens,
            # 54.43° and its box unchecked: Find camera returned 54.86° and 61.06°, and its camera 16 px off)
            for name, held, value in (("fov_sigma_deg", {"fov"}, FIXED_FOV_SIGMA_DEG),
                                      ("position_sigma_m", {"x", "y"}, FIXED_POSITION_SIGMA_M),
                                      ("angle_sigma_deg", {"heading", "pitch"}, FIXED_ANGLE_SIGMA_DEG)):
                if not held & set(free):  # held, even where a ± is stated (that ± is for the others' σ): a
                    # time-lapse trial's mast, Position ± 5 m and position unticked, was moved 9-10 m by the search
                    sigmas[name] = value if sigmas[name] is None else min(float(sigmas[name]), value)
        lens = c.exif_lens() if sigmas["fov_sigma_deg"] is None and c.prior is not None else None
        if lens is not None and lens.fov and abs(c.prior.fov - lens.fov) < 0.05:
            # the lens is known: a drone trial's 24 mm equivalent (71.6°) left the search free to end at 113.7°
            sigmas["fov_sigma_deg"] = LENS_FOV_SHARE * float(lens.fov)
        return sigmas

    def _earlier_against_stated(self, found) -> Optional[tuple]:
        """(metres, σ, metres) when the fitted camera (an earlier registration's) lies more than twice the position σ
        the person stated (Position ±, a GPS's usual error for an EXIF position, 1 m for a held one) from the rough
        camera, and ``found`` nearer to it: the earlier camera contradicts what they now say more, so it does not
        win on the edge score (a time-lapse trial: a first run 70 m off; a second with Position ± 20 m was set
        aside for fitting the edges a little less well). None otherwise (no σ stated: the edge scores decide)."""
        from .priors import GPS_POSITION_M, GPS_SOURCE

        c = self.controller
        prior, earlier = c.prior, c.fitted
        if prior is None or earlier is None:
            return None
        free, options = fit_arguments(c.state.settings)  # None without fit settings
        sigma = getattr(options, "position_sigma_m", None)
        if sigma is None and c.state.settings.get("prior_source") == GPS_SOURCE:
            sigma = GPS_POSITION_M
        if free is not None and not {"x", "y"} & set(free):  # held: where the person says the camera stood
            sigma = FIXED_POSITION_SIGMA_M
        if not sigma:
            return None

        def away(camera) -> float:
            return float(np.linalg.norm(np.subtract(camera.position, prior.position)[:2]))

        return (away(earlier), float(sigma), away(found)) if away(earlier) > max(2.0 * sigma, away(found)) else None

    def _apply(self, value) -> None:
        done, overlay, xyz, footprint, checked = value
        c = self.controller
        r = done.result
        status = checked["status"]
        kept = (c.state.fit_info or {}).get("status")
        earlier = _earlier_automatic_edge(c.state.fit_info)  # the fitted camera is an earlier registration's
        edge = engine.finite_or_none(r.evidence.get("auto_edge_score"))
        # a doubtful run does not simply replace a fitted camera that is not doubtful
        doubtful = c.fitted is not None and kept in ("ok", "uncertain") and status != "ok"
        against = self._earlier_against_stated(done.camera) if doubtful and earlier is not None else None
        if doubtful and earlier is not None and (edge is None or edge > earlier) and against is None:
            # a run again with other settings (a trial: ± 150 m, 8°) was told "your fitted camera and your points are
            # kept" of the first run's own camera: the two are compared as the registration compares its cameras
            camera_layers.show_camera_layers(self.dock.project, done.camera, footprint, c.dem_crs,
                                             other=self.tr("automatic, {0}").format(status))
            logging.getLogger(__name__).info("Automatic registration set aside (%s): %s", status, checked["message"])
            c.message.emit(self.tr("This automatic registration ended {0} and fits the photo's edges less well (edge "
                                   "score {1}, lower is better) than the earlier one ({2}): the earlier "
                                   "camera and its points are kept. This one is on the map in purple; its report is "
                                   "in the Monoplot log.").format(status, *_two_scores(edge, earlier)),
                           Qgis.MessageLevel.Warning)
            return
        if doubtful and earlier is None:
            # Nothing lost: a doubtful automatic camera never replaces the person's own fit and points.
            # ... but the person can look at it: its position and footprint on the map, beside their own
            camera_layers.show_camera_layers(self.dock.project, done.camera, footprint, c.dem_crs,
                                             other=self.tr("automatic, {0}").format(status))
            # the registration's own report goes to the log: in the dock it pushed the fit tab's buttons out of view
            # (its "prior" is the rough camera it started from; the dock keeps the fitted one: said first, a trial
            # read "The prior is kept" in the log against "your fitted camera is kept" in the bar)
            logging.getLogger(__name__).info("Automatic registration set aside (%s); the fitted camera is kept. "
                                             "The registration's report (\"prior\" = the rough camera it started "
                                             "from): %s", status, checked["message"])
            c.message.emit(self.tr("Automatic registration ended {0}; your fitted camera ({1}) and your points are "
                                   "kept. The automatic camera is on the map in purple, as \"Monoplot camera "
                                   "(automatic, {0})\"; its report is in the Monoplot log.").format(status, kept)
                           + _check_points_compared(checked, c.state.fit_info, self.tr),
                           Qgis.MessageLevel.Warning)
            return
        uv, world = done.matched_points()
        if not len(uv) and status != "ok":
            # nothing matched (a photo in fog: "RMSE nan px on 0 photo points", and the rough camera became the
            # "fitted" one, products enabled): no camera is set, the rough one stays what it was
            logging.getLogger(__name__).info("Automatic registration found nothing (%s): %s", status,
                                             checked["message"])
            # core.auto gave the prior back: its edges matched (loosely, or no better), or not at all
            kept = bool(r.evidence.get("auto_prior_kept")) and not r.evidence.get("auto_no_edges")
            text = self.tr("Automatic registration found no camera better than the rough one ({0}): the rough camera "
                           "stays.") if kept else self.tr("Automatic registration found no match between the photo "
                                                         "and the DEM ({0}): no camera was set.")
            # why, where the person looks (a time-lapse trial found it only in the log: "no clear skyline")
            why = str(r.evidence.get("auto_prior_kept_why") or "")
            # whole: the status line shows its start, its tool tip all of it (cut, a re-check trial lost the end)
            why = (" " + self.tr("Why: {0}.").format(why)) if why else ""
            c.message.emit(text.format(status) + why + " " + self.tr("Suggest points and pick a few you recognise "
                                                                     "instead (the report is in the Monoplot log)."),
                           Qgis.MessageLevel.Warning)
            return
        camera_layers.remove_camera_layers(self.dock.project, other=True)  # an earlier one set aside is stale now
        label = auto_step.AUTOMATIC_LABEL  # a later fit on these points alone is capped by this verdict
        # An earlier run's matches the person went through (rejected some) are their curation: the ones kept stay
        # and a new match where they decided already is left out (a trial's second run took its 161 kept points
        # away and brought back its 41 rejected ones as undecided). Untouched earlier matches are replaced.
        reviewed = any(p.label == label and p.status == REJECTED for p in c.state.points.values())
        n_found = len(uv)  # the registration's own matches, whatever is added of them below
        if reviewed:
            keep = _not_decided_already(c.state, label, uv, world)
            uv, world = uv[keep], world[keep]
        # a "poor" camera's matches are probably wrong: offered as undecided suggestions, not accepted (a desktop
        # trial: a camera 95 deg off put its 74 matches in the accepted set)
        taken = SUGGESTED if status == "poor" else ACCEPTED
        photo_pts = [Point.new(PHOTO, float(u), float(v), status=taken, label=label) for u, v in uv]
        map_pts = [Point.new(MAP, float(x), float(y), float(z), status=taken, label=label) for x, y, z in world]
        replaced = 0
        before = camera_snapshot(c, prior=False, settings=_REGISTRATION_SETTINGS)
        c.state.settings["automatic_status"] = status
        c.state.settings["automatic_sigma"] = {k: float(v) for k, v in (r.std or {}).items()}
        edit = None
        if photo_pts:
            machine = None if reviewed else label
            edit = replace_in_views(c.state, {PHOTO: photo_pts, MAP: map_pts}, self.tr("Automatic points"), machine)
            # what goes: the undecided suggestions, and an earlier run's matches nobody went through (a second run
            # had doubled them); the message counts both (it said "0 replaced" while 161 went)
            replaced = sum(1 for pid, after in edit.after.items() if after is None)
            self._follower.forget()  # the listener must not act on this push
            edit = edit if c.stack.push(edit) else None
        finite = engine.finite_or_none
        info = {"status": status, "rmse_px": finite(r.rmse_px), "loo_rmse_px": finite(r.loo_rmse_px),
                "sigma": {k: float(v) for k, v in (r.std or {}).items()}, "converged": status == "ok",
                "correlation": plain_correlation(getattr(r, "correlation", None)),
                # its σ as a pixel error on the terrain it matched: what its products are worth
                "sigma_px": finite(sigma_pixels(done.camera, r.std or {}, world)),
                # ... unless its σ are the rough camera's own (the edges did not narrow them): no figure then
                "sigma_is_prior": bool(r.evidence.get("auto_sigma_is_prior")),
                "message": str(checked["message"]), "mode": "automatic", "n_photo": n_found,
                "n_map": n_found, "n_pairs": 0, "n_matched": n_found, "elapsed_s": float(r.elapsed_s),
                "check_rmse_px": checked["check_rmse_px"], "n_check": checked["n_check"],
                # the registration's pairs, as an unpaired fit records its own: residuals in the dock, points in
                # the report (it showed none after a registration)
                "matched": [(p.id, m.id) for p, m in zip(photo_pts, map_pts)], "auto_edge_score": edge}
        if len(world):  # how far it went from the rough camera, as a fit says it ("uncertain" beyond 3 σ stated)
            info.update(c.moved_from_prior(done.camera, world, fit_arguments(c.state.settings)[1]))
            c.doubt_a_moved_camera(info)
        if reviewed:  # before the fit's own message, which must be the last word (it says "poor" when it is)
            c.message.emit(self.tr("Your decisions on the earlier automatic points are kept: new matches where you "
                                   "had accepted or rejected one were left out ({0} of {1}).").format(
                n_found - len(photo_pts), n_found), Qgis.MessageLevel.Info)
        c.show_fit(engine.FitOutcome(done.camera, info, overlay, xyz, footprint))
        if edit is not None:
            self._follower.watch(edit, before, camera_snapshot(c, prior=False, settings=_REGISTRATION_SETTINGS))
        if status == "poor" and photo_pts:
            c.message.emit(self.tr("Automatic registration ended poor: its {0} + {1} matched points are left "
                                   "undecided (they are probably wrong), and replaced {2} undecided suggestions (Undo "
                                   "brings them back).").format(len(photo_pts), len(map_pts), replaced),
                           Qgis.MessageLevel.Warning)
        elif replaced:
            c.message.emit(self.tr("{0} undecided suggestions and earlier unreviewed matches were replaced by the "
                                   "{1} + {2} matched points (Undo brings them back).").format(
                replaced, len(photo_pts), len(map_pts)), Qgis.MessageLevel.Info)
        if against is not None and edge is not None and edge > earlier:
            # said last: it explains the replacement (a re-check trial saw it pushed off the bar by the count)
            c.message.emit(self.tr("This registration fits the photo's edges a little less well than the earlier one "
                                   "({0} against {1}, lower is better), but the earlier camera is {2:.0f} m "
                                   "from the rough camera, more than twice the position uncertainty you gave (± "
                                   "{3:.0f} m), and this one {4:.0f} m: this one replaces it (Undo brings the "
                                   "earlier one back).").format(
                *_two_scores(edge, earlier), *against), Qgis.MessageLevel.Info)


def _earlier_automatic_edge(info) -> Optional[float]:
    """The edge score of the fitted camera when it is an automatic registration's (``info``: the fit's record),
    else None (the person's own fit, or a record from before the score was kept)."""
    info = info or {}
    if info.get("mode") != "automatic":
        return None
    return engine.finite_or_none(info.get("auto_edge_score"))


def _not_decided_already(state, label: str, uv, world) -> np.ndarray:
    """(N,) bool: the matches (photo ``uv`` (N, 2), DEM ``world`` (N, 3)) with neither side within
    :data:`SAME_POINT_PX` pixels (photo) or :data:`SAME_POINT_M` metres (map) of an earlier automatic point the
    person accepted or rejected."""
    decided = [p for p in state.points.values() if p.label == label and p.status in (ACCEPTED, REJECTED)]
    keep = np.ones(len(uv), dtype=bool)
    for space, values, radius in ((PHOTO, np.asarray(uv, float).reshape(-1, 2), SAME_POINT_PX),
                                  (MAP, np.asarray(world, float).reshape(-1, 3)[:, :2], SAME_POINT_M)):
        old = np.array([(p.x, p.y) for p in decided if p.space == space]).reshape(-1, 2)
        if len(old) and len(values):
            near = np.linalg.norm(values[:, None, :] - old[None, :, :], axis=2).min(axis=1) <= radius
            keep &= ~near
    return keep


#: a new automatic match this close to a point the person decided on is that point again (pixels, metres)
SAME_POINT_PX, SAME_POINT_M = 2.0, 5.0


#: what a registration sets besides the camera, and an Undo of its points takes back
_REGISTRATION_SETTINGS = ("automatic_status", "automatic_sigma")


def _check_points_compared(checked: dict, fit_info, tr=str) -> str:
    """" Check points: automatic camera 8.3 px, yours 17.3 px." when both cameras were measured on check points
    (a trial found the set-aside camera's better figure in the log only), else "".

    >>> _check_points_compared({"check_rmse_px": 8.31, "n_check": 2}, {"check_rmse_px": 17.3, "n_check": 2})
    ' Check points: the automatic camera 8.3 px, yours 17.3 px.'
    >>> _check_points_compared({"check_rmse_px": None, "n_check": 0}, {"check_rmse_px": 17.3})
    ''
    """
    auto = checked.get("check_rmse_px")
    own = (fit_info or {}).get("check_rmse_px") if isinstance(fit_info, dict) else None
    if auto is None or own is None or not (math.isfinite(auto) and math.isfinite(own)):
        return ""
    return tr(" Check points: the automatic camera {0:.1f} px, yours {1:.1f} px.").format(auto, own)


def _two_scores(a: Optional[float], b: float):
    """Two edge scores as text, with the digits it takes to tell them apart (a trial read "less well (edge score
    0.106) than the earlier one (0.106)").

    >>> _two_scores(0.10612, 0.10598), _two_scores(0.257, 0.240), _two_scores(None, 0.2)
    (('0.1061', '0.1060'), ('0.257', '0.240'), ('nan', '0.200'))
    """
    a = float("nan") if a is None else float(a)
    for digits in range(3, 7):
        if f"{a:.{digits}f}" != f"{b:.{digits}f}":
            break
    return f"{a:.{digits}f}", f"{b:.{digits}f}"
