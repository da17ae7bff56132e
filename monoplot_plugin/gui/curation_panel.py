"""The dock's curation bar: a few suggestions at a time, bulk actions, filters, the live refit, messages once.

Installed by :func:`install_curation_panel` (one line in ``dock.py``) into the points tab's button grid:

    [More suggestions] [Reject the rest] [Accept likely]
    [Reject outliers]  [Show: undecided, accepted ▾] [Options ▾ (per view 30, pairs within 8 px, refit while I click)]
    (under the counts) Showing 30 of 9,970 undecided photo and 30 of 9,970 DEM suggestions · camera: refit, 6.2 px

The logic lives in the controller (:mod:`.curation`) and :class:`~.shortlist.Shortlist`; the background refit in
:mod:`.refit`.
"""

from __future__ import annotations

import html
import time

from qgis.PyQt.QtCore import QTimer
from qgis.PyQt.QtWidgets import (QDoubleSpinBox, QFormLayout, QHeaderView, QMenu, QSizePolicy, QSpinBox,
                                 QToolButton, QWidget, QWidgetAction)

from ..core.fit import FitOptions
from ..state import ACCEPTED, CHECK, MAP, PHOTO, REJECTED, SUGGESTED
from . import engine
from .dock_layout import fit_text_height
from .fit_settings import fit_arguments
from .refit import Refitter, sigma_of

__all__ = ["CurationPanel", "install_curation_panel", "MessageOnce", "prior_sigma_px"]


def prior_sigma_px(c) -> float:
    """How far (px, one σ) the rough camera of controller ``c`` may put a point: the fit's prior uncertainty (what
    the user set in Fit settings, else the fit's defaults) through the camera's lens, at the distance of the
    terrain it looks at. (A fixed 30 px was below what rough guesses are off, 46-155 px on Aletsch and rendered
    scenes: their chance agreements ranked features the detectors put first further down.)"""
    _, options = fit_arguments(c.state.settings)
    distance = engine.typical_range(c.prior, c.dem) if c.dem is not None else None
    return (options or FitOptions()).prior_sigma_px(c.prior, distance or 1000.0)


#: how long (seconds) a warning stays on the bar under lesser messages pushed after it: a flood trial's warning on
#: switching the DEM was taken off at once by the information messages of the same switch
WARNING_HOLD_S = 10.0


def _severity(level) -> int:
    """Critical 2, Warning 1, anything else (Info, Success) 0."""
    from qgis.core import Qgis

    return {Qgis.MessageLevel.Critical: 2, Qgis.MessageLevel.Warning: 1}.get(level, 0)


class MessageOnce:
    """Push to QGIS's message bar so that each message shows once: the previous Monoplot message is taken off the
    bar first (a message bar keeps older messages under the newest and shows them again when it expires), and
    :meth:`clear` takes it off when the state it spoke of has changed (an edit, an undo: a desktop trial saw "2000
    photo and 1024 DEM suggestions" come back after QGIS's "Task complete" expired, while the dock's status line
    said "Undone: ..."). Covered by QGIS's own "Task complete", a task's result comes back when that one expires.
    A warning pushed less than :data:`WARNING_HOLD_S` ago stays under a lesser message (it shows again when that
    one expires): the step that warned often says more right after."""

    def __init__(self):
        self._items = []  # (bar item, pushed at, severity), oldest first
        self._pushed_at = 0.0

    def push(self, bar, title: str, text: str, level, duration: int) -> None:
        severity, now = _severity(level), time.monotonic()
        held = [entry for entry in self._items if entry[2] > severity and now - entry[1] < WARNING_HOLD_S]
        for entry in self._items:
            if entry not in held:
                self._pop(bar, entry[0])
        # the bar shows rich text: a message quoting "<leftFov>" (a KML element) lost it (a trial)
        bar.pushMessage(title, html.escape(text, quote=False), level, duration)
        self._pushed_at = now
        try:
            item = bar.currentItem()
        except AttributeError:
            item = None
        self._items = held + ([(item, now, severity)] if item is not None else [])

    @staticmethod
    def _pop(bar, item) -> None:
        try:
            bar.popWidget(item)
        except (RuntimeError, TypeError, AttributeError):  # already gone (expired, closed)
            pass

    def clear(self, bar, older_than_s: float = 0.0) -> None:
        """Take the Monoplot messages off ``bar``, if the last was pushed more than ``older_than_s`` ago (a task
        starting: the message of the step before is stale, one pushed as the task started is about it)."""
        if self._items and time.monotonic() - self._pushed_at >= older_than_s:
            for item, _, _ in self._items:
                self._pop(bar, item)
            self._items = []


class CurationPanel(QWidget):
    def __init__(self, dock):
        super().__init__(dock)
        self.dock = dock
        self.c = c = dock.controller
        self.refitter = Refitter(c, parent=self)
        c.running_refit = self.refitter.running_fit  # the Fit button waits for a refit of the same inputs
        self.refit_info = ""
        self._refit_shown = False
        #: status of the camera the likely pairs come from ("ok", "uncertain", "rough" for the prior, "" for none)
        self.ranking_status = ""

        def button(text, tip, slot):
            b = QToolButton(self)
            b.setText(text)
            b.setToolTip(tip)
            b.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
            b.clicked.connect(slot)
            return b

        self.moreButton = button(self.tr("More suggestions"), self.tr("Show the next few undecided suggestions"),
                                 self.more)
        self.rejectRestButton = button(self.tr("Reject the rest"),
                                       self.tr("Reject the undecided suggestions on show; the next few come"),
                                       self.reject_rest)
        self.acceptLikelyButton = button(self.tr("Accept likely"),
                                         self.tr("Accept both ends of every linked pair (a photo suggestion and a "
                                                 "DEM suggestion the current camera puts close together)"),
                                         self.accept_likely)
        self.rejectOutliersButton = button(self.tr("Reject outliers"),
                                           self.tr("Reject the accepted photo points the current fit explains by "
                                                   "no DEM point (red rings)"), self.reject_outliers)
        # "Show ▾": the filters; "Options ▾": per view, pairs within, the live refit (menus: two rows in all, so
        # the point table keeps its rows)
        self.showButton = button(self.tr("Show"), self.tr("Which points the photo, the map and the table show"),
                                 lambda: None)
        self.showButton.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        show_menu = QMenu(self.showButton)
        self.filter_checks = {}
        for status, text in ((SUGGESTED, self.tr("Undecided (the few on show)")), (ACCEPTED, self.tr("Accepted")),
                             (REJECTED, self.tr("Rejected"))):
            action = show_menu.addAction(text)
            action.setCheckable(True)
            action.setChecked(c.shortlist.filters[status])
            action.toggled.connect(lambda on, s=status: self.set_filter(s, on))
            self.filter_checks[status] = action
        self.showButton.setMenu(show_menu)

        self.optionsButton = button(self.tr("Options"), self.tr("How many at a time, when a pair is likely, the "
                                                                "background refit"), lambda: None)
        self.optionsButton.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        options_menu = QMenu(self.optionsButton)
        form_widget = QWidget(options_menu)
        form = QFormLayout(form_widget)
        self.perPageSpin = QSpinBox(form_widget)
        self.perPageSpin.setRange(5, 500)
        self.perPageSpin.setValue(c.shortlist.per_page)
        self.perPageSpin.setToolTip(self.tr("How many undecided suggestions each view shows at a time"))
        self.perPageSpin.valueChanged.connect(self._per_page)
        form.addRow(self.tr("Suggestions on show per view:"), self.perPageSpin)
        self.thresholdSpin = QDoubleSpinBox(form_widget)
        self.thresholdSpin.setRange(1.0, 100.0)
        self.thresholdSpin.setDecimals(0)
        self.thresholdSpin.setSuffix(" px")
        self.thresholdSpin.setValue(c.shortlist.threshold)
        self.thresholdSpin.setToolTip(self.tr("A photo and a DEM suggestion this close under the current camera "
                                              "are a likely pair (linked in cyan)"))
        self.thresholdSpin.valueChanged.connect(self._threshold)
        form.addRow(self.tr("Likely pair within:"), self.thresholdSpin)
        holder = QWidgetAction(options_menu)
        holder.setDefaultWidget(form_widget)
        options_menu.addAction(holder)
        self.refitCheck = options_menu.addAction(self.tr("Refit while I click"))
        self.refitCheck.setToolTip(self.tr("Fit the camera in the background after every change of the accepted "
                                           "points; the suggestions are re-ranked by it"))
        self.refitCheck.setCheckable(True)
        self.refitCheck.setChecked(True)
        self.refitCheck.toggled.connect(self._refit_toggled)
        self.optionsButton.setMenu(options_menu)
        self._show_text()

        # into the point buttons' grid (ui/dock.ui, three columns): two rows
        grid = dock.pointButtons
        row = grid.rowCount()
        for i, b in enumerate((self.moreButton, self.rejectRestButton, self.acceptLikelyButton,
                               self.rejectOutliersButton, self.showButton, self.optionsButton)):
            grid.addWidget(b, row + i // 3, i % 3)
        self.hide()  # the widgets live in the grid; this object only owns them

        c.pointsChanged.connect(self._on_points)
        c.cameraChanged.connect(self._on_camera)
        # check points measured after the fit change its verdict: the counts line and the actions that trust an
        # "ok" camera follow (a drone trial's line said "camera: fit, 7.7 px (ok)" under "camera status uncertain")
        c.fitInfoChanged.connect(self._on_camera)
        self.refitter.refitted.connect(self._on_refit)
        self.refitter.unavailable.connect(self._refit_stale)
        c.busyChanged.connect(self._on_busy)
        self.refitter.running.connect(lambda on: self._update_info())
        self._on_camera()

    # --- actions ----------------------------------------------------------------------------------------------
    def _redraw(self) -> None:
        self.dock._on_points(set())
        self._update_info()

    def more(self) -> int:
        n = self.c.more_suggestions()
        if not n:
            self.dock.show_message(self.tr("No more undecided suggestions: run Suggest points again for others."))
        return n

    def reject_rest(self) -> int:
        return self.c.reject_rest()

    def accept_likely(self) -> int:
        linking = bool(self.c.state.valid_pairs())
        n = self.c.accept_likely()
        if not n:
            self.dock.show_message(self.tr("No likely pairs under the current camera: accept a few points you "
                                           "recognise, the refit links the rest."))
        elif linking:  # said, not a blank status line (a trial)
            self.dock.show_message(self.tr("{0} likely pairs linked: the next Fit uses them (Undo takes them "
                                           "back).").format(n))
        else:
            self.dock.show_message(self.tr("{0} likely pairs accepted (Undo takes them back).").format(n))
        return n

    def reject_outliers(self) -> int:
        n = self.c.reject_outliers()
        self.dock.photo_view.redraw_recommendations()
        left = self.c.state.counts()[PHOTO][ACCEPTED]
        if n and left < self.c.MIN_POINTS:
            self.dock.show_message(self.tr("{0} outliers rejected; {1} accepted photo points are left, too few to "
                                           "fit: accept at least {2} more you recognise.").format(
                n, left, self.c.MIN_POINTS - left))
        return n

    def set_filter(self, status: str, on: bool) -> None:
        self.c.shortlist.set_filter(status, on)
        self._show_text()
        self._redraw()

    def _show_text(self) -> None:
        names = {SUGGESTED: self.tr("undecided"), ACCEPTED: self.tr("accepted"), REJECTED: self.tr("rejected")}
        on = [names[s] for s, a in self.filter_checks.items() if a.isChecked()]
        text = self.tr("all") if len(on) == len(names) else ", ".join(on) if on else self.tr("nothing")
        # the button is a third of the dock wide: the full list goes in the tooltip, the text stays short
        short = text if len(on) in (0, 1, len(names)) else self.tr("{0} of {1}").format(len(on), len(names))
        self.showButton.setText(self.tr("Show: {0}").format(short))
        self.showButton.setToolTip(self.tr("Points on show: {0}. Click to choose.").format(text))

    def _per_page(self, n: int) -> None:
        sl = self.c.shortlist
        sl.per_page = int(n)
        for space in (PHOTO, MAP):
            sl._rerank(space, keep=0)
        self._redraw()

    def _threshold(self, px: float) -> None:
        self.c.shortlist.set_threshold(px)
        self._redraw()

    def _refit_toggled(self, on: bool) -> None:
        self.refitter.enabled = on
        if on:
            self.refitter.schedule(force=True)
        else:
            self.refitter.cancel()

    # --- following the controller -----------------------------------------------------------------------------
    def _on_points(self, changed) -> None:
        self.dock.message_is_stale()  # a message about the state before this edit is stale now
        self.refitter.schedule()
        self._update_info()

    def _on_camera(self) -> None:
        """A new prior or Fit-button camera: re-rank by it (a later refit re-ranks again)."""
        self._refit_shown = False
        c = self.c
        info = c.state.fit_info or {}
        # a fit its verdict calls poor does not rank the suggestions (a poor refit does not either): the rough
        # camera goes on doing it
        trusted_fit = c.fitted is not None and (info.get("status") != "poor" or c.prior is None)
        if trusted_fit:
            camera, sigma = c.fitted, sigma_of(*(float(info.get(k) or float("nan"))
                                                 for k in ("rmse_px", "loo_rmse_px", "check_rmse_px")),
                                               n_check=int(info.get("n_check") or 0))
            self.ranking_status = str(info.get("status", ""))
            # the verdict with it, as the background refit's line says it (a trial read "fit, 5.2 px" as good)
            verdict = self.tr(self.ranking_status) if self.ranking_status else ""
            self.refit_info = (self.tr("fit, {0:.1f} px").format(info["rmse_px"]) if info.get("rmse_px") else
                               self.tr("fit")) + (" ({0})".format(verdict) if verdict else "")
        elif c.prior is not None:
            camera, sigma, self.refit_info = c.prior, prior_sigma_px(c), self.tr("rough")
            if c.fitted is not None:
                self.refit_info = self.tr("fit poor, ranking by the rough camera")
            self.ranking_status = "rough"
        else:
            camera, sigma, self.refit_info = None, sigma_of(float("nan")), ""
            self.ranking_status = ""
        key = (c.state.fitted, c.state.prior)
        if key != getattr(self, "_camera_key", None):  # cameraChanged also fires for the overlay, the photo...
            self._camera_key = key
            c.shortlist.set_camera(camera, sigma)
            if c.fitted is not None and "outliers" in info:  # the Fit button's own verdict on these points
                c.shortlist.set_outliers(list(info["outliers"]))
                self.refitter.adopt_fit(self.refitter.accepted_key())
            else:
                self.refitter.schedule(force=camera is not None)
            self._redraw()
        self._update_info()

    def _on_busy(self, description: str) -> None:
        """The Fit button's fit gets the cores: no background refit beside it (its result re-ranks), unless the
        Fit waits for that refit (same inputs, see ``controller.fit``)."""
        if self.c.task_kind == "fit" and self.c.awaited_refit is None:
            self.refitter.cancel()

    def _on_refit(self, outcome) -> None:
        self._refit_shown = True  # the counts line speaks of this refit until the prior or a Fit takes over
        sl = self.c.shortlist
        sl.set_outliers(outcome.outlier_ids)
        if outcome.rec is not None:
            sl.set_camera(outcome.camera, outcome.sigma, outcome.rec)
            self.ranking_status = outcome.status
            self.refit_info = self.tr("refit, {0:.1f} px ({1})").format(outcome.rmse_px, self.tr(outcome.status))
        else:
            # no camera to rank by yet: say what to do next rather than how the ranking was computed
            self.refit_info = self.tr("refit {0}, ranking unchanged: accept a few more points you recognise on "
                                      "the photo and on the map").format(self.tr(outcome.status))
        self._redraw()

    def _refit_stale(self) -> None:
        """Too few accepted points for a refit (an Undo took them back): an earlier refit's camera no longer ranks
        nor labels the view ("camera: refit, 2.2 px" stayed with no point accepted); the prior or the Fit button's
        camera takes over."""
        if self._refit_shown:
            self._camera_key = None
            self.c.shortlist.set_outliers([])
            self._on_camera()
            self._redraw()

    def _update_info(self) -> None:
        sl = self.c.shortlist
        n_out = len(sl.current_outliers())
        n_likely = sl.n_likely()
        if self.c.state.valid_pairs():  # the accepted points a paired fit leaves out are linked too
            n_likely += len(sl.accepted_unpartnered())
        # The machine accepts points only on the word of a camera its verdict calls ok: pairs that agree with a
        # doubtful camera confirm it (the scripted Aletsch user ended "ok" 1.9x the paired optimum that way).
        trusted = self.ranking_status == "ok"
        self.acceptLikelyButton.setEnabled(n_likely > 0 and trusted)
        if n_likely and not trusted:
            tip = self.tr("The current camera is not yet ok ({0}): its links are shown, but judge a few more points "
                          "yourself before accepting them all").format(self.tr(self.ranking_status or "none"))
        elif not n_likely and sl.camera is not None:  # greyed out: say why (the desktop trial could not tell)
            from ..core.recommend import chance

            if sl.clutter and chance(sl.sigma, max(sl.clutter.values())) >= 1.0:
                # the real reason on a real print: its camera's error (a trial's "ok" fit, 10 px on the GCPs)
                # against 2,000 suggestions a view; "within 8 px" sent it looking at the wrong setting
                # "Thin them (Reject the rest)" led a trial nowhere on a print (300 a view still too dense for
                # ± 35 px): what shrinks the camera's uncertainty is pairs a person judges
                tip = self.tr("No linked pairs: the suggestions are too dense for the current camera's uncertainty "
                              "(± {0:.0f} px): a partner that near would as likely be there by chance. Pair a few "
                              "more points yourself (Shift+click) and fit: the links come as the camera's "
                              "uncertainty shrinks").format(sl.sigma)
            else:
                tip = self.tr("No linked pairs: under the current camera no undecided suggestion has a partner in "
                              "the other view within {0:.0f} px (Options: pairs within), nearer than "
                              "chance").format(sl.threshold)
        else:
            tip = self.tr("Accept both ends of every linked pair (a photo suggestion and a DEM suggestion the "
                          "current camera puts close together)")
            if self.c.state.valid_pairs():  # a trial accepted 183 this way, then a Fit used its 10 pairs only
                tip += self.tr(". With pairs of your own the Fit is paired: these are linked as pairs too")
        self.acceptLikelyButton.setToolTip(tip)
        self.acceptLikelyButton.setText(self.tr("Accept likely ({0})").format(n_likely) if n_likely
                                        else self.tr("Accept likely"))
        # ... and rejects them only on the word of such a camera: under a doubtful one the red points may be right
        # and the camera wrong; rejecting them locks the camera in (a careless Aletsch set, "uncertain" 70 px off:
        # rejecting its 389 flagged points, 24 of them correct, made the next fit "ok" 70 px off).
        self.rejectOutliersButton.setEnabled(n_out > 0 and trusted)
        self.rejectOutliersButton.setToolTip(
            self.tr("Reject the accepted photo points the current fit explains by no DEM point (red rings)")
            if trusted or not n_out else
            self.tr("The current camera is not yet ok ({0}): the red points may be right and the camera wrong. "
                    "Judge them one by one (R rejects the selected point), or accept more points you recognise "
                    "first").format(self.tr(self.ranking_status or "none")))
        self.rejectOutliersButton.setText(self.tr("Reject outliers ({0})").format(n_out) if n_out
                                          else self.tr("Reject outliers"))
        # one line a view, how many are on show folded in (it was a line of its own: four lines at 560 px, above
        # the point table, which was left one row in sight at 1600 x 1000)
        counts = self.c.state.counts()
        lines = [self.tr("{0}: {1} accepted, {2} to decide ({3} on show), {4} rejected").format(
            name, counts[space][ACCEPTED], counts[space][SUGGESTED], len(sl.shown[space]), counts[space][REJECTED])
            + (self.tr(", {0}\u00a0check").format(counts[space][CHECK]) if counts[space][CHECK] else "")
            for space, name in ((PHOTO, self.tr("Photo")), (MAP, self.tr("Map")))]  # check points too (a trial)
        if self.refit_info:
            lines[-1] += " · " + self.tr("camera: {0}").format(self.refit_info)
        if self.refitter.task is not None:
            lines[-1] += " · " + self.tr("refitting…")
        label = self.dock.countsLabel
        label.setText("\n".join(lines))
        fit_text_height(label)  # all its lines (a layout reserves one)

    def unload(self) -> None:
        self.refitter.enabled = False
        self.refitter.abandon()  # a refit still running ends touching nothing of the dock (gui/tasks.py)


def install_curation_panel(dock) -> CurationPanel:
    """Put the curation actions under the point buttons and make the table list the points on show."""
    panel = CurationPanel(dock)
    dock.table_model.ids = dock.controller.visible_ids
    # column widths follow the contents after a change, not during it: ResizeToContents measured every row on
    # every click (and on every scrollTo of the selection)
    header = dock.pointTable.horizontalHeader()
    header.setSectionResizeMode(QHeaderView.ResizeMode.Interactive)
    timer = QTimer(panel)
    timer.setSingleShot(True)
    timer.setInterval(300)
    timer.timeout.connect(dock.pointTable.resizeColumnsToContents)
    dock.table_model.modelReset.connect(timer.start)
    panel.column_timer = timer
    return panel

