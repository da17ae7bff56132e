"""The next frame of a fixed camera, its points kept: the points and cameras follow the frame's turn.

A time-lapse trial kept the first frame's points on later frames ("Keep the points"): the mount had turned by up to
0.5°, so the kept photo points sat 7-28 px off their features, and a drift-corrected camera loaded for the frame was
judged "uncertain" against them (check points 9.8-28.9 px off on correct cameras). The frame is now registered on the
previous one as the batch does (:func:`~..workflow.frames.turn_from_previous_frame`), and when it turned, the photo
points move with it (one undoable edit) and the rough and fitted cameras turn by the same rotation.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from qgis.core import Qgis
from qgis.PyQt.QtCore import QCoreApplication

from ..adapters.photo import qimage_to_array
from ..core.drift import corrected_camera, turned_pixels
from ..state import PHOTO, Edit
from ..workflow.frames import DRIFT_TOLERANCE_PX, turn_from_previous_frame
from .camera_follow import CamerasFollowEdit, camera_snapshot


def tr(text: str) -> str:
    return QCoreApplication.translate("Monoplot", text)


def follow_the_turn(controller, previous) -> None:
    """After ``controller`` loaded another frame keeping its points (``previous``: the last frame's QImage): register
    the frame on it and, when it turned by :data:`DRIFT_TOLERANCE_PX` or more, move the photo points and turn the
    cameras; say what was done (or that the frames did not match, the points left where they were)."""
    c = controller
    state = c.state
    camera = c.fitted if c.fitted is not None else c.prior
    if camera is None or previous is None:
        return
    drift = turn_from_previous_frame(qimage_to_array(previous), qimage_to_array(c.image), camera)
    if not drift.ok:
        if c.fitted is not None:
            _unchecked_here(c, drift.message)
        c.message.emit(tr("This frame could not be matched to the previous one ({0}): its points and camera are "
                          "kept as they were; check them.").format(drift.message), Qgis.MessageLevel.Warning)
        return
    if drift.pixels < DRIFT_TOLERANCE_PX:  # said: the frame was checked (a re-check trial heard nothing)
        c.message.emit(tr("This frame was matched to the previous one ({0} matches): it has not turned ({1:.2f} px), "
                          "the points and camera stay as they are.").format(drift.inliers, drift.pixels),
                       Qgis.MessageLevel.Info)
        return
    before = camera_snapshot(c)
    photo = [p for p in state.points.values() if p.space == PHOTO]
    moved = turned_pixels(camera, drift.rotation, np.array([(p.x, p.y) for p in photo])) if photo else []
    # the cameras turn first, then the points: the check points are measured once, with the turned camera on the
    # turned points (measured in between, a trial's 13.1 px read "18.2 px, 5 times the camera's residuals")
    if c.prior is not None:
        c.set_prior(corrected_camera(c.prior, drift.rotation))
    if c.fitted is not None:
        info = dict(state.fit_info or {})
        for key in ("status", "message"):  # the check points' verdict is made again on the turned points
            if f"{key}_before_checks" in info:
                info[key] = info.pop(f"{key}_before_checks")
        info.pop("checks_measured", None)
        turned = tr("Turned onto this frame by {0:.3f}° ({1:.1f} px) from the previous one.").format(
            drift.degrees, drift.pixels)
        # one such sentence, the last frame's: a time-lapse trial's third frame read "Turned … by 1.773° … Turned …
        # by 3.512°", the second from the second frame, not the first
        kept = [part for part in info.get("message", "").split(". ")
                if not part.startswith(tr("Turned onto this frame"))]
        info["message"] = (". ".join(kept).rstrip(". ") + ". " + turned).lstrip(". ").strip()
        if photo and info.get("fit_point_xy"):  # the points the fit used moved with the camera: not "changed"
            xy = dict(info["fit_point_xy"])
            xy.update({p.id: [float(u), float(v)] for p, (u, v) in zip(photo, moved) if p.id in xy})
            info["fit_point_xy"] = xy
        c.set_fitted(corrected_camera(c.fitted, drift.rotation), info)
    edit = None
    if photo:
        edit = Edit(tr("Follow the frame's turn"), before={p.id: p for p in photo},
                    after={p.id: replace(p, x=float(u), y=float(v)) for p, (u, v) in zip(photo, moved)})
        c.stack.push(edit)
    else:
        c.remeasure_checks()
    if edit is not None:
        _follower(c).watch(edit, before, camera_snapshot(c))
    c.message.emit(tr("This frame turned {0:.3f}° ({1:.1f} px) from the previous one ({2} matches): its {3} photo "
                      "points and the camera were turned with it (Undo turns them back).").format(
        drift.degrees, drift.pixels, drift.inliers, len(photo)), Qgis.MessageLevel.Info)


def _unchecked_here(controller, why: str) -> None:
    """The fitted camera kept on a frame that could not be matched to the previous one is not known to fit it: an
    "ok" becomes "uncertain", and its message says why first (a time-lapse trial's "ok" camera stayed a green "ok"
    on a frame of another view, 307 m and 20° off; a line drawn there was given ± 5 m, 900 m off). A fit on this
    frame's points, or check points measured on it, judge it again."""
    info = dict(controller.state.fit_info or {})
    note = tr("Uncertain: this frame could not be matched to the previous one ({0}), whose camera it keeps, so the "
              "camera is not known to fit it; fit again on this frame's points, or mark check points on it.").format(
        why)
    for key in ("status", "status_before_checks"):
        if info.get(key) == "ok":
            info[key] = "uncertain"
    for key in ("message", "message_before_checks"):
        if key == "message" or key in info:  # one note, the last frame's (a trial's doubled at each switch)
            info[key] = (note + " " + _without_note(info.get(key, ""), note)).strip()
    info.pop("checks_measured", None)  # measured again, on this frame, from the lowered status
    controller.set_fitted(controller.fitted, info)
    controller.remeasure_checks()


def _without_note(message: str, note: str) -> str:
    """``message`` without the unmatched-frame note an earlier frame put first (the same words as ``note``, up to
    its ``(``, and on to its last words)."""
    head, tail = note[:note.index("(")], note[note.rindex(";"):]
    start = message.find(head)
    end = message.find(tail, start) if start >= 0 else -1
    return message if end < 0 else (message[:start] + message[end + len(tail):]).strip()


def _follower(controller) -> CamerasFollowEdit:
    """The controller's one watch of "Follow the frame's turn": its Undo (Redo) turns the rough and fitted cameras
    back (again) with the points (a re-check trial's Undo left both cameras turned)."""
    follower = controller.__dict__.get("_turn_follower")
    if follower is None:
        follower = controller.__dict__["_turn_follower"] = CamerasFollowEdit(controller)
    return follower
