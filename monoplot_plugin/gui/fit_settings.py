"""What the user knows about the camera, in the dock: the lens (focal length and sensor, or a 35 mm equivalent ->
field of view, filled from EXIF where it can be), which parameters the fit may change, and how sure the rough camera
is (the core's ``FitOptions`` prior sigmas).

Stored with the project in ``state.settings["fit"]``::

    {"free": ["x", "y", "z", "heading", "pitch", "roll", "fov"], "position_sigma_m": 50.0, "angle_sigma_deg": null,
     "fov_sigma_deg": null, "focal_mm": 30.0, "sensor_width_mm": 22.2, "focal_35mm": null,
     "on_ground": null, "eye_height_m": null}

:func:`fit_arguments` turns it into what ``engine.fit_and_render`` passes to the fit, :func:`height_arguments` into
the camera height mode of :func:`workflow.fit.fit` (``on_ground`` None automatic / True / False, ``eye_height``).

>>> fit_arguments({})
(None, None)
>>> free, options = fit_arguments({"fit": {"free": ["heading", "pitch", "roll", "fov"], "position_sigma_m": 20}})
>>> free, options.position_sigma_m, options.angle_sigma_deg
(('heading', 'pitch', 'roll', 'fov'), 20.0, None)
>>> height_arguments({}), height_arguments({"fit": {"on_ground": True, "eye_height_m": 1.5}})
({'on_ground': None, 'eye_height': None}, {'on_ground': True, 'eye_height': 1.5})
"""

from __future__ import annotations

from typing import Dict, Optional, Sequence, Tuple

from qgis.gui import QgsCollapsibleGroupBox
from qgis.PyQt.QtCore import QCoreApplication, Qt
from qgis.PyQt.QtWidgets import (QCheckBox, QComboBox, QDoubleSpinBox, QGridLayout, QHBoxLayout, QLabel, QPushButton,
                                 QVBoxLayout, QWidget)

from ..adapters.exif import lens_fov
from ..core.fit import DEFAULT_FREE, FitOptions

__all__ = ["SETTINGS_KEY", "FREE_GROUPS", "HEIGHT_MODES", "fit_arguments", "height_arguments", "FitSettingsPanel",
           "LensPanel", "WrappingRow"]

SETTINGS_KEY = "fit"
#: The toggles of the dock (label, camera parameter names): checked = the fit may change them.
FREE_GROUPS: Tuple[Tuple[str, Tuple[str, ...]], ...] = (
    ("position", ("x", "y")), ("height", ("z",)), ("heading", ("heading",)), ("pitch", ("pitch",)),
    ("roll", ("roll",)), ("field of view", ("fov",)), ("principal point", ("cx", "cy")), ("k1", ("k1",)))
_SIGMAS = (("position_sigma_m", "Position ±", " m", 0.0, 100000.0, 10.0),
           ("angle_sigma_deg", "Angles ±", "°", 0.0, 90.0, 0.5),
           ("fov_sigma_deg", "Field of view ±", "°", 0.0, 90.0, 0.5))
#: The camera height modes (label, tooltip, ``on_ground`` of :func:`workflow.fit.fit`), as Processing's ON_GROUND.
HEIGHT_MODES = (("Automatic", "On the ground when the rough camera is within 20 m of the terrain, else in the air",
                 None),
                ("On the ground", "A hand-held or tripod photo: the camera stays at the given height above the DEM",
                 True),
                ("In the air", "A drone, aircraft or tower: the fit finds the camera's height", False))


def tr(text: str) -> str:
    return QCoreApplication.translate("MonoplotFitSettings", text)


def fit_arguments(settings: Dict) -> Tuple[Optional[Tuple[str, ...]], Optional[FitOptions]]:
    """(free parameter names or None for the core's default, FitOptions or None) from the dock's settings."""
    fit = (settings or {}).get(SETTINGS_KEY) or {}
    free = tuple(fit["free"]) if fit.get("free") is not None else None
    sigmas = {name: float(fit[name]) for name, *_ in _SIGMAS if fit.get(name)}
    return free, (FitOptions(**sigmas) if sigmas else None)


def height_arguments(settings: Dict) -> Dict[str, Optional[object]]:
    """``on_ground`` and ``eye_height`` of :func:`workflow.fit.fit` from the dock's settings (None: automatic)."""
    fit = (settings or {}).get(SETTINGS_KEY) or {}
    on_ground = fit.get("on_ground")
    eye = fit.get("eye_height_m")
    return {"on_ground": None if on_ground is None else bool(on_ground),
            "eye_height": None if eye is None else float(eye)}


class WrappingRow(QWidget):
    """Two groups of widgets on one line when the width allows, else the second group on a line of its own (the
    lens row of a ~580 px dock: "Set field of view" was drawn over the "35 mm equiv." box)."""

    def __init__(self, first: Sequence[QWidget], second: Sequence[QWidget], parent=None):
        super().__init__(parent)
        self._first, self._second = list(first), list(second)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        self._rows = (QHBoxLayout(), QHBoxLayout())
        for row in self._rows:
            layout.addLayout(row)
            row.addStretch(1)
        for w in self._first:
            self._rows[0].insertWidget(self._rows[0].count() - 1, w)
        self.one_line = None
        self._place(True)

    def _width(self, widgets) -> int:
        spacing = max(0, self._rows[0].spacing())
        return sum(w.sizeHint().width() for w in widgets) + spacing * max(0, len(widgets) - 1)

    def _place(self, one_line: bool) -> None:
        if one_line == self.one_line:
            return
        self.one_line = one_line
        row = self._rows[0 if one_line else 1]
        for w in self._second:
            for r in self._rows:
                r.removeWidget(w)
            row.insertWidget(row.count() - 1, w)
        self.updateGeometry()

    def minimumSizeHint(self):  # noqa: N802 (Qt's name)
        """As narrow as the wider of the two groups: the row wraps rather than making the dock wider."""
        hint = super().minimumSizeHint()
        hint.setWidth(max(self._width(self._first), self._width(self._second)))
        return hint

    def resizeEvent(self, event):  # noqa: N802 (Qt's name)
        self._place(event.size().width() >= self._width(self._first + self._second) + 8)
        super().resizeEvent(event)


class _Panel:
    """Reads and writes ``state.settings["fit"]`` of the dock's controller."""

    def _fit(self) -> Dict:
        return dict(self.controller.state.settings.get(SETTINGS_KEY) or {})

    def _store(self, **values) -> None:
        fit = self._fit()
        fit.update(values)
        self.controller.set_setting(SETTINGS_KEY, fit)


class FitSettingsPanel(QgsCollapsibleGroupBox, _Panel):
    """"Fit settings" in the fit tab: a fix / free toggle per parameter and the rough camera's uncertainty."""

    def __init__(self, controller, parent=None):
        super().__init__(tr("Fit settings"), parent)  # a long title made the Fit tab scroll sideways at ~450 px
        self.controller = controller
        self.setObjectName("MonoplotFitSettings")
        layout = QVBoxLayout(self)
        grid = QGridLayout()
        self.free_checks: Dict[str, QCheckBox] = {}
        for i, (label, _) in enumerate(FREE_GROUPS):
            # "k1" alone said nothing to a trial's new user told to free "a lens's barrel distortion"
            box = QCheckBox(tr("lens distortion k1") if label == "k1" else tr(label))
            box.setToolTip(tr("Checked: the fit adjusts it; unchecked: it keeps the rough camera's value.") + (
                " " + tr("Free it for a wide lens or a phone, or when the fit says its residuals grow towards the "
                         "picture's edges.") if label == "k1" else ""))
            box.toggled.connect(self._free_toggled)
            self.free_checks[label] = box
            grid.addWidget(box, i // 3, i % 3)
        intro = QLabel(tr("What the fit may change, how sure the rough camera is, where the camera is. Free "
                          "parameters (unchecked = fixed at the rough camera's value):"))
        intro.setWordWrap(True)
        layout.addWidget(intro)
        layout.addLayout(grid)
        row = QGridLayout()  # two boxes a row: three were wider than a dock opened from the tool bar
        self.sigma_spins: Dict[str, QDoubleSpinBox] = {}
        for i, (name, label, suffix, low, high, step) in enumerate(_SIGMAS):
            spin = QDoubleSpinBox()
            spin.setRange(low, high)
            spin.setSingleStep(step)
            spin.setDecimals(1)
            spin.setSuffix(suffix)
            spin.setSpecialValueText(tr("auto"))  # 0 = the fit's default
            # a trial's "± 400 m" was how far off the viewpoint could be at most: one σ is about half of that
            spin.setToolTip(tr("One standard deviation of the rough camera: about half of the most you think it "
                               "could be off (off by up to 400 m: 200 m); auto = the fit's default. With the "
                               "parameter unticked, the fit holds it and counts this in the others' ±."))
            spin.valueChanged.connect(self._sigma_changed)
            self.sigma_spins[name] = spin
            row.addWidget(QLabel(tr(label)), i // 2, 2 * (i % 2))
            row.addWidget(spin, i // 2, 2 * (i % 2) + 1)
        layout.addWidget(QLabel(tr("Rough camera's uncertainty:")))
        layout.addLayout(row)
        self.height_combo = QComboBox()
        for label, tip, _ in HEIGHT_MODES:
            self.height_combo.addItem(tr(label))
            self.height_combo.setItemData(self.height_combo.count() - 1, tr(tip), Qt.ItemDataRole.ToolTipRole)
        self.height_combo.setToolTip(tr("Is the camera on the ground (hand-held, tripod) or in the air (drone, "
                                        "aircraft)? Automatic: on the ground when the rough camera is within 20 m "
                                        "of the terrain."))
        self.eye_spin = QDoubleSpinBox()
        self.eye_spin.setRange(0.0, 1000.0)
        self.eye_spin.setDecimals(1)
        self.eye_spin.setSuffix(" m")
        self.eye_spin.setSpecialValueText(tr("auto"))
        self.eye_spin.setToolTip(tr("Height above the ground of a camera on the ground; auto = the rough camera's "
                                    "own height when automatic (1.7 m when it is under the DEM), 1.7 m on the "
                                    "ground."))
        self.height_combo.currentIndexChanged.connect(self._height_changed)
        self.eye_spin.valueChanged.connect(self._height_changed)
        self.height_row = WrappingRow([QLabel(tr("Camera height")), self.height_combo],
                                      [QLabel(tr("above ground")), self.eye_spin])
        layout.addWidget(self.height_row)
        self.setCollapsed(True)
        self._updating = False
        controller.photoChanged.connect(self.refresh)
        controller.demChanged.connect(self.refresh)
        controller.cameraChanged.connect(self._show_auto_height)
        self.refresh()

    def _show_auto_height(self) -> None:
        """"auto" says the height it stands for with this rough camera and DEM (:func:`workflow.fit.on_ground_rule`):
        a flood trial read "Above ground 12.0 m" in the camera tab and "auto" here, and could not tell which the fit
        would use."""
        text = tr("auto")
        c = self.controller
        start = c.fit_start() if c.dem is not None else None
        if start is not None:
            from ..workflow.fit import on_ground_rule

            on_ground = HEIGHT_MODES[self.height_combo.currentIndex()][2]
            grounded, eye = on_ground_rule(start, c.dem, on_ground, None)
            text = tr("auto ({0:.1f} m)").format(eye) if grounded else tr("auto (in the air)")
        if text != self.eye_spin.specialValueText():
            self.eye_spin.setSpecialValueText(text)
            self.eye_spin.update()

    def free(self) -> Tuple[str, ...]:
        names = {n for label, names in FREE_GROUPS if self.free_checks[label].isChecked() for n in names}
        from ..core.camera import PARAMETER_NAMES

        return tuple(n for n in PARAMETER_NAMES if n in names)

    def set_free(self, names: Sequence[str]) -> None:
        for label, group in FREE_GROUPS:
            self.free_checks[label].setChecked(all(n in names for n in group))

    def refresh(self) -> None:
        """Show the settings stored in the project (defaults when it has none)."""
        self._updating = True
        try:
            fit = self._fit()
            free = fit.get("free")
            self.set_free(DEFAULT_FREE if free is None else free)
            for name, spin in self.sigma_spins.items():
                spin.setValue(float(fit.get(name) or 0.0))
            height = height_arguments({SETTINGS_KEY: fit})
            self.height_combo.setCurrentIndex([m[2] for m in HEIGHT_MODES].index(height["on_ground"]))
            self.eye_spin.setValue(height["eye_height"] or 0.0)
            self.eye_spin.setEnabled(height["on_ground"] is not False)
        finally:
            self._updating = False
        self._show_auto_height()

    def _free_toggled(self) -> None:
        if not self._updating:
            free = self.free()
            self._store(free=None if set(free) == set(DEFAULT_FREE) else list(free))

    def _height_changed(self) -> None:
        on_ground = HEIGHT_MODES[self.height_combo.currentIndex()][2]
        self.eye_spin.setEnabled(on_ground is not False)  # a camera in the air has no eye height
        self._show_auto_height()
        if not self._updating:
            self._store(on_ground=on_ground, eye_height_m=self.eye_spin.value() or None)

    def _sigma_changed(self) -> None:
        if not self._updating:
            self._store(**{name: (spin.value() or None) for name, spin in self.sigma_spins.items()})


class LensPanel(QWidget, _Panel):
    """Lens row of the camera tab: focal length and sensor width (or a 35 mm equivalent) -> the field of view box.

    Filled from the photo's EXIF tags when it has them; when EXIF has a focal length it cannot use (no sensor size,
    no 35 mm equivalent), the note says so and asks for the sensor width."""

    def __init__(self, controller, fov_spin, parent=None):
        super().__init__(parent)
        self.controller = controller
        self.fov_spin = fov_spin
        self.setObjectName("MonoplotLens")
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        self.focal_spin = self._spin(0.0, 5000.0, " mm", tr("Focal length of the lens (as printed on it, or EXIF); "
                                                            "unknown: leave it, the fit finds the field of view"))
        self.sensor_spin = self._spin(0.0, 500.0, " mm", tr("Width of the sensor or film (e.g. 22.2 mm APS-C, "
                                                            "36 mm full frame)"))
        self.equivalent_check = QCheckBox(tr("35 mm equiv."))
        self.equivalent_check.setToolTip(tr("The focal length is a 35 mm equivalent (no sensor width needed)"))
        self.apply_button = QPushButton(tr("Set field of view"))
        self.row = WrappingRow([QLabel(tr("Lens")), self.focal_spin, QLabel(tr("on sensor")), self.sensor_spin],
                               [self.equivalent_check, self.apply_button])
        layout.addWidget(self.row)
        self.note = QLabel("")
        self.note.setWordWrap(True)
        self.note.setObjectName("MonoplotLensNote")
        layout.addWidget(self.note)
        self.equivalent_check.toggled.connect(lambda on: self.sensor_spin.setEnabled(not on))
        self.apply_button.clicked.connect(self.apply)
        controller.photoChanged.connect(self.from_exif)
        self.from_exif()

    @staticmethod
    def _spin(low, high, suffix, tip) -> QDoubleSpinBox:
        spin = QDoubleSpinBox()
        spin.setRange(low, high)
        spin.setDecimals(1)
        spin.setSuffix(suffix)
        spin.setSpecialValueText("—")
        spin.setToolTip(tip)
        return spin

    def fov(self) -> Optional[float]:
        """Horizontal field of view from the boxes, or None when they are not enough."""
        focal = self.focal_spin.value()
        size = self.controller.photo_size
        landscape = size is None or size[0] >= size[1]
        try:
            if self.equivalent_check.isChecked():
                return lens_fov(0.0, focal_35mm=focal, landscape=landscape, size=size) if focal > 0 else None
            return lens_fov(focal, self.sensor_spin.value())
        except ValueError:
            return None

    def apply(self) -> Optional[float]:
        """Put the lens's field of view into the camera tab's box (which updates the rough camera)."""
        fov = self.fov()
        if fov is None:
            self.note.setText(tr("Enter the focal length and the sensor width (or tick 35 mm equiv.)."))
            return None
        prior = self.controller.prior
        if prior is not None and abs(prior.fov - fov) > 1e-9:
            # the exact value, not the box's rounded one (a trial's 54.432° became 54.4°: 1.4 px RMS at 24 MP)
            self.controller.set_prior(prior.with_parameters(fov=fov))  # the box follows the camera
        else:
            self.fov_spin.setValue(fov)
        self._store(focal_mm=self.focal_spin.value(), sensor_width_mm=self.sensor_spin.value() or None,
                    focal_35mm=self.focal_spin.value() if self.equivalent_check.isChecked() else None)
        self.note.setText(tr("Field of view {0:.1f}° from the lens.").format(fov))
        return fov

    def from_exif(self) -> None:
        """Fill the boxes from the project's stored lens, else from the photo's EXIF, and say what EXIF lacks."""
        fit = self._fit()
        self.note.setText("")
        if fit.get("focal_mm"):
            self.focal_spin.setValue(float(fit["focal_mm"]))
            self.sensor_spin.setValue(float(fit.get("sensor_width_mm") or 0.0))
            self.equivalent_check.setChecked(bool(fit.get("focal_35mm")))
            return
        exif = self.controller.exif_lens()
        if exif is None:
            self.focal_spin.setValue(0.0)
            self.sensor_spin.setValue(0.0)
            self.equivalent_check.setChecked(False)
            if self.controller.image is not None:  # a scanned print has no EXIF: say what to do (a trial asked)
                self.note.setText(tr("No lens in the photo's file. Unknown? Leave it: the fit finds the field of "
                                     "view, starting from the Field of view box (Camera tab)."))
            return
        if exif.focal_35mm:
            self.focal_spin.setValue(exif.focal_35mm)
            self.equivalent_check.setChecked(True)
            self.note.setText(tr("EXIF: {0:g} mm (35 mm equivalent) → field of view {1:.1f}°.").format(
                exif.focal_35mm, exif.fov))
        elif exif.focal_mm:
            self.focal_spin.setValue(exif.focal_mm)
            self.equivalent_check.setChecked(False)
            self.sensor_spin.setValue(exif.sensor_width_mm or 0.0)
            if exif.fov is not None:
                self.note.setText(tr("EXIF: {0:g} mm on a {1:.1f} mm wide sensor → field of view {2:.1f}°.").format(
                    exif.focal_mm, exif.sensor_width_mm, exif.fov))
            else:
                self.note.setText(tr("EXIF gives a {0:g} mm focal length but no sensor size and no 35 mm "
                                     "equivalent: enter the sensor width, then Set field of view.").format(
                                         exif.focal_mm))
