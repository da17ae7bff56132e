"""Cameras that follow an Undo (Redo) of the points edit that brought them.

An automatic registration pushes its matched points as one edit and shows the camera they made; a time-lapse frame's
turn moves the photo points as one edit and turns the cameras. The undo stack holds point edits only, so an Undo
put the points back and left the camera (trials: the fit tab still spoke of 134 automatic points after their Undo;
a turned frame's residuals of 6-8 px under a fit that still said "0.0 px (ok)"). :class:`CamerasFollowEdit`
watches one edit and, when it is undone (redone) while the cameras are still those it left, puts them back (again).
"""

from __future__ import annotations

from typing import Callable, Optional

from ..core.camera import Camera


def camera_snapshot(controller, prior: bool = True, settings=()) -> dict:
    """The controller's cameras as dicts, copied: ``"fitted"`` and ``"info"`` (the fit record), ``"prior"`` when
    ``prior``, and ``"settings"``: the values of the named settings (None: not set)."""
    state = controller.state
    snapshot = {"fitted": state.fitted, "info": dict(state.fit_info or {})}
    if prior:
        snapshot["prior"] = state.prior
    if settings:
        snapshot["settings"] = {k: state.settings.get(k) for k in settings}
    return snapshot


class CamerasFollowEdit:
    """Watches one points edit of ``controller.stack`` (:meth:`watch`); an Undo (Redo) of it restores the ``before``
    (``after``) snapshot of :func:`camera_snapshot`, when the cameras are still those of the other one. A camera of
    the person's since then (another fit, another rough camera) ends the watch: it stays.

    ``background``: the restored fit's products are rendered in a task; ``on_restored(camera or None)`` runs after a
    fitted camera was restored."""

    def __init__(self, controller, background: bool = False,
                 on_restored: Optional[Callable[[Optional[Camera]], None]] = None):
        self.controller, self.background, self.on_restored = controller, background, on_restored
        self.watched = None
        controller.stack.add_listener(self._follow)

    def watch(self, edit, before: dict, after: dict) -> None:
        self.watched = (edit, before, after)

    def forget(self) -> None:
        """No edit watched (the next push must not be taken for the watched one's)."""
        self.watched = None

    def _cameras(self, snapshot: dict) -> tuple:
        state = self.controller.state
        return tuple(getattr(state, key) for key in ("prior", "fitted") if key in snapshot)

    @staticmethod
    def _of(snapshot: dict) -> tuple:
        return tuple(snapshot[key] for key in ("prior", "fitted") if key in snapshot)

    def _follow(self, changed) -> None:
        if self.watched is None:
            return
        edit, before, after = self.watched
        c = self.controller
        if not c.stack.knows(edit):  # the history was reset (another project, or this one read back): not an Undo
            # (a trial reopened its project: the reset was taken for an Undo, the "uncertain" cap went, and the
            # same wrong camera was then fitted "ok")
            self.watched = None
            return
        current, target = (before, after) if c.stack.is_applied(edit) else (after, before)
        now = self._cameras(current)
        if now != self._of(current) or now == self._of(target):
            if now not in (self._of(before), self._of(after)):
                self.watched = None  # a camera of the person's since: the edit's cameras are history
            return
        for key, value in target.get("settings", {}).items():
            if value is None:
                c.state.settings.pop(key, None)
            else:
                c.state.settings[key] = value
        if "prior" in target and target["prior"] != c.state.prior:
            c.set_prior(None if target["prior"] is None else Camera.from_dict(target["prior"]))
        if target["fitted"] != c.state.fitted:
            camera = None if target["fitted"] is None else Camera.from_dict(target["fitted"])
            if self.background:
                c.set_fitted(camera, target["info"], background=True)
            else:
                c.set_fitted(camera, target["info"])
            if self.on_restored is not None:
                self.on_restored(camera)
