"""The dock's widget geometry (no behaviour): the point table's sizing, size policies, stretches, minimum widths,
and the Points tab's scroll area. Split from :mod:`.dock`, which wires the widgets to the controller."""

from __future__ import annotations

from qgis.PyQt.QtCore import QEvent, QObject, Qt
from qgis.PyQt.QtWidgets import (QFrame, QGridLayout, QHeaderView, QScrollArea, QSizePolicy, QVBoxLayout,
                                 QWidget)

from ..workflow.text import cut_at_word

__all__ = ["lay_out", "fit_minimum_width", "scroll_points_tab", "scroll_camera_tab", "narrow_tabs",
           "split_photo_and_tabs", "fit_text_height", "TextHeight", "show_status", "status_line"]

#: rows of the point table in sight under the Points tab's buttons and counts at the first show
TABLE_ROWS = 4
#: share of the splitter the tabs get at least and at most at the first show (the photo keeps the rest)
TABS_SHARE = (0.38, 0.5)


#: The point table model's residual column (:mod:`.point_table`).
RESIDUAL_COLUMN = 6


def lay_out(dock) -> None:
    """Sizes of the widgets of ``ui/dock.ui`` that the designer file cannot express."""
    dock.pointTable.verticalHeader().setVisible(False)
    # Tab leaves the table (arrows walk its cells): a keyboard trial's 24 Tabs stayed inside it
    dock.pointTable.setTabKeyNavigation(False)
    # rows as tall as their text needs: the style's default (30 px in the QGIS desktop) left room for three rows
    dock.pointTable.verticalHeader().setDefaultSectionSize(dock.pointTable.fontMetrics().height() + 8)
    rows = dock.pointTable.verticalHeader().defaultSectionSize()  # the header and three rows, never one
    dock.pointTable.setMinimumHeight(4 * rows + dock.pointTable.horizontalScrollBar().sizeHint().height())
    dock.pointTable.horizontalHeader().setStretchLastSection(True)
    header = dock.pointTable.horizontalHeader()
    header.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
    header.setSortIndicator(-1, Qt.SortOrder.AscendingOrder)  # detector order until a header is clicked
    # the residual next to the status and the name (shown fourth; the model's column stays 6): at 1600 px it was
    # past the table's right edge, behind a horizontal scroll
    header.moveSection(header.visualIndex(RESIDUAL_COLUMN), 3)
    dock.table_proxy.sort(-1)
    for button in (dock.suggestButton, dock.mapToolButton, dock.acceptViewButton, dock.resetButton,
                   dock.undoButton, dock.redoButton):  # two even rows (ui/dock.ui): one row was clipped
        button.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
    dock.splitter.setStretchFactor(0, 3)
    dock.splitter.setStretchFactor(1, 2)
    dock.overlaySlider.setMinimumWidth(90)
    dock.dockContents.setMinimumWidth(440)  # narrower squeezes the photo bar
    for label in (dock.cameraSummary, dock.resultLabel, dock.countsLabel):
        label.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
    dock.cameraTabLayout.setStretch(dock.cameraTabLayout.count() - 1, 1)
    dock.fitTabLayout.setStretch(dock.fitTabLayout.count() - 1, 1)


def fit_minimum_width(dock) -> None:
    """At least 440 px (narrower squeezes the photo bar), and never narrower than the button rows and the photo
    tool bar need: a fixed minimum below that clipped the button texts ("uggest poin") with wide fonts."""
    need = dock.dockContents.minimumSizeHint().width()
    if dock._photo_toolbar is not None:
        margins = dock.photoPaneLayout.contentsMargins()
        need = max(need, dock._photo_toolbar.sizeHint().width() + margins.left() + margins.right() + 12)
    dock.dockContents.setMinimumWidth(max(440, need))
    # the Points tab's wrapped labels get the height they take at this width: a layout reserves one line for
    # them (the tab widget and the splitter pass no height-for-width up) and squashed the buttons to fit them
    dock.helpLabel.setMinimumHeight(dock.helpLabel.heightForWidth(max(440, need) - 40))
    dock.countsLabel.monoplot_floor_width = max(440, need) - 40
    dock.countsLabel.monoplot_text_height = TextHeight(dock.countsLabel)  # its lines as its width changes


def fit_text_height(label) -> None:
    """A wrapped label's minimum height: the height of its text at its width, at least the dock's narrowest
    (``label.monoplot_floor_width``: a label not laid out yet is 100 px wide). A layout in a tab reserves one line
    for it and clipped the rest; a fixed four lines left the point table one row in sight at 1600 x 1000 when the
    text takes two."""
    width = max(label.width(), getattr(label, "monoplot_floor_width", 400))
    label.setMinimumHeight(max(label.heightForWidth(width), label.fontMetrics().lineSpacing()))


class TextHeight(QObject):
    """Keeps :func:`fit_text_height` of a label as its width changes (the dock widened, floated)."""

    def __init__(self, label):
        super().__init__(label)
        self._width = -1
        label.installEventFilter(self)
        fit_text_height(label)

    def eventFilter(self, watched, event) -> bool:  # noqa: N802
        if event.type() == QEvent.Type.Resize and watched.width() != self._width:
            self._width = watched.width()
            fit_text_height(watched)
        return False


def _scrolled_page(tab: QWidget, layout) -> QScrollArea:
    """Move everything of ``tab``'s ``layout`` onto a page in a vertical scroll area that ``layout`` then holds; the
    page keeps the margins and spacing."""
    page = QWidget()
    page_layout = QVBoxLayout(page)
    page_layout.setContentsMargins(layout.contentsMargins())
    page_layout.setSpacing(layout.spacing())
    layout.setContentsMargins(0, 0, 0, 0)
    while layout.count():
        item = layout.takeAt(0)
        if item.widget() is not None:
            page_layout.addWidget(item.widget())
        elif item.layout() is not None:
            item.layout().setParent(None)
            page_layout.addLayout(item.layout())
        elif item.spacerItem() is not None:
            page_layout.addItem(item.spacerItem())
    scroll = QScrollArea(tab)
    scroll.setWidgetResizable(True)
    scroll.setFrameShape(QFrame.Shape.NoFrame)
    scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
    scroll.setWidget(page)
    layout.addWidget(scroll)
    # no horizontal scrolling: the page is as wide as the view (its rows share the width as before the
    # scroll area), never wider (else the right column, "Accept likely (15)", was cut off under the scroll bar)
    page.setMinimumWidth(1)
    return scroll


def scroll_points_tab(dock) -> None:
    """The Points tab scrolls when the splitter gives it less than it needs, as the Fit tab does: on a laptop
    (a dock of ~800 px) its five button rows were squashed to half their height and the table to one row.
    """
    dock.pointsScroll = _scrolled_page(dock.pointsTab, dock.pointsTabLayout)
    page_layout = dock.pointsScroll.widget().layout()
    # the help text under the table: above it, at 760 px the table began below the tab's visible part
    page_layout.removeWidget(dock.helpLabel)
    page_layout.addWidget(dock.helpLabel)
    page_layout.setStretchFactor(dock.pointTable, 1)  # a taller tab shows more rows, not more space between


def scroll_camera_tab(dock) -> None:
    """The Camera tab scrolls too: its buttons, form and lens panel made the dock 777 px tall at least, taller
    than a 1366 x 768 laptop screen (a trial: the products and the status bar below the screen's edge)."""
    dock.cameraScroll = _scrolled_page(dock.cameraTab, dock.cameraTabLayout)
    dock.cameraTabLayout = dock.cameraScroll.widget().layout()  # where the camera tab's widgets now are
    dock.cameraTabLayout.setStretch(dock.cameraTabLayout.count() - 1, 1)  # the rows at the top, as before


def narrow_tabs(dock) -> None:
    """The Camera and Fit tabs at the width QGIS gives a dock opened from the tool bar (~450 px): the camera buttons
    in rows of three (one row of five made the dock wider than its window: "35 mm e", "t field of vie" cut off),
    and the Fit tab scrolls up and down only (it scrolled sideways, its verdict text cut off at the right)."""
    old = dock.cameraButtons
    grid = QGridLayout()
    grid.setSpacing(old.spacing())
    buttons = []
    while old.count():
        item = old.takeAt(0)
        if item.widget() is not None:
            buttons.append(item.widget())
    for i, button in enumerate(buttons):
        button.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
        grid.addWidget(button, i // 3, i % 3)
    index = dock.cameraTabLayout.indexOf(old)
    dock.cameraTabLayout.removeItem(old)
    old.setParent(None)
    dock.cameraTabLayout.insertLayout(index, grid)
    dock.cameraButtons = grid
    dock.fitScroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
    dock.fitScrollContents.setMinimumWidth(1)  # as wide as the view, never wider (the labels wrap instead)


def split_photo_and_tabs(dock, total: int) -> None:
    """The splitter's sizes at the first show: the tabs get what the Points tab needs to show its buttons, its counts
    and :data:`TABLE_ROWS` rows of the point table without scrolling, within :data:`TABS_SHARE` of ``total``; the
    photo the rest. A fixed 62 / 38 split left the table one row in sight at 1600 x 1000 (the page's rows above
    the table took the whole tab, the table was a scroll away)."""
    page = dock.pointsScroll.widget()
    layout = page.layout()
    margins = layout.contentsMargins()
    width = max(dock.dockContents.width(), dock.dockContents.minimumWidth()) - 24 - margins.left() - margins.right()
    need = margins.top() + margins.bottom()
    for i in range(layout.indexOf(dock.pointTable)):
        item = layout.itemAt(i)
        height = item.heightForWidth(width) if item.hasHeightForWidth() else -1
        need += max(height, item.sizeHint().height(), item.minimumSize().height()) + layout.spacing()
    table = dock.pointTable
    need += (table.horizontalHeader().sizeHint().height() + TABLE_ROWS * table.verticalHeader().defaultSectionSize()
             + 2 * table.frameWidth())
    need += dock.stepTabs.tabBar().sizeHint().height() + 8  # the tab bar and the tab's frame
    low, high = TABS_SHARE
    tabs = int(min(max(need, low * total), high * total))
    dock.splitter.setSizes([total - tabs, tabs])


#: Characters of a message the status line under the dock shows (about three lines at the dock's usual width): a
#: featureless photo's Suggest message took eight lines there, pushing the tabs up.
STATUS_CHARS = 300


#: Lines of the dock's width a status message may take: a 300-character one took five on a 1366 x 768 laptop and
#: pushed the Camera tab's fields out of sight while it was shown.
STATUS_LINES = 3


def show_status(label, text: str, lines: int = STATUS_LINES) -> None:
    """``text`` on the status ``label``, cut at a word to about ``lines`` lines of the label's width (the whole
    text in its tool tip when cut)."""
    metrics = label.fontMetrics()
    per_line = max(20, int(max(label.width(), 200) / max(1, metrics.averageCharWidth())))
    # 0.85: word wrapping leaves the end of each line empty
    shown = status_line(text, min(STATUS_CHARS, int(lines * per_line * 0.85)))
    label.setText(shown)
    label.setToolTip(text if shown != text else "")


def status_line(text: str, limit: int = STATUS_CHARS) -> str:
    """``text`` cut at a word before ``limit`` characters, with an ellipsis.

    >>> status_line("short"), status_line("one two three four", 12)
    ('short', 'one two …')
    """
    return cut_at_word(text, limit)


def place_floating(dock) -> None:
    """The floating dock window on the screen, centred (it stayed where the dock had been: half off a 1600 px
    screen), as tall as the screen allows, and the photo given most of that height, the reason to float it."""
    from qgis.PyQt.QtGui import QGuiApplication

    screen = dock.screen() or QGuiApplication.primaryScreen()
    area = screen.availableGeometry()
    dock.resize(min(1100, area.width() - 40), area.height() - 40)
    w, h = dock.width(), dock.height()  # no smaller than the dock's minimum (a small screen)
    dock.move(area.x() + max(0, (area.width() - w) // 2), area.y() + max(0, (area.height() - h) // 2))
    dock.splitter.setSizes([int(0.65 * h), int(0.35 * h)])
