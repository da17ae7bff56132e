"""The dock's rough camera (a mixin of :class:`~.dock.MonoplotDock`): drawn on the map by press and drag (a live
wedge while dragging), its field of view, heading and pitch from the spin boxes, its height and position typed
(:mod:`.prior_height`, :mod:`.prior_position`), or read from a KML or camera JSON."""

from __future__ import annotations

from qgis.core import Qgis
from qgis.PyQt.QtWidgets import QFileDialog

from .io_actions import IoActions
from .prior_height import PriorHeightBox
from .prior_position import PriorPositionBox

__all__ = ["RoughCameraMixin"]


class RoughCameraMixin:
    """Slots of the dock's rough-camera widgets (``drawCameraButton``, ``fovSpin``, ``headingSpin``, ``pitchSpin``,
    ``heightSpin``, ``positionEdit``, the KML button); the dock provides ``controller``, ``map_canvas``,
    ``camera_tool``, ``map_view``, ``io_actions`` and ``show_message``."""

    def _connect_camera_widgets(self, c) -> None:
        """Connect the camera tab's buttons and boxes to the controller ``c`` (from the dock's constructor)."""
        self.drawCameraButton.toggled.connect(self._toggle_camera_tool)
        self.camera_tool.cameraDrawn.connect(self._camera_drawn)
        self.camera_tool.dragging.connect(self._camera_dragging)
        self.kmlButton.clicked.connect(self._import_kml)
        self.exifButton.clicked.connect(lambda: c.prior_from_exif())
        self.clearPriorButton.clicked.connect(lambda: c.set_prior(None))
        # a new project starts from the boxes' defaults, not the closed project's camera (a trial: the next camera
        # drawn took its pitch -11.3 deg and +48 m, and a pitch other than 0 skipped the one from the terrain)
        self._camera_box_defaults = {spin: spin.value() for spin in (self.fovSpin, self.headingSpin, self.pitchSpin,
                                                                     self.heightSpin)}
        for spin in (self.fovSpin, self.headingSpin, self.pitchSpin):
            # typing "55" moves the camera once, on Enter: not to 5 deg first, which warned that the camera did not
            # look at the DEM (desktop trial)
            spin.setKeyboardTracking(False)
            spin.valueChanged.connect(self._prior_spin_changed)
        self.prior_height = PriorHeightBox(c, self.heightSpin, self.show_message)  # gui/prior_height.py
        self.prior_position = PriorPositionBox(c, self.positionEdit, self.show_message, lambda x, y: c.prior_from_map(
            x, y, self.headingSpin.value(), self.fovSpin.value(), self.pitchSpin.value(), self.heightSpin.value()))

    def _toggle_camera_tool(self, on: bool) -> None:
        if on:
            if self.controller.dem is None or self.controller.image is None:
                self.show_message(self.tr("Load a photo and choose a DEM first."), Qgis.MessageLevel.Warning)
                self.drawCameraButton.setChecked(False)
                return
            self.mapToolButton.setChecked(False)
            self.map_canvas.setMapTool(self.camera_tool)
            self.show_message(self.tr("Press on the map at the camera position and drag towards the view."))
        elif self.map_canvas.mapTool() is self.camera_tool:
            self.map_canvas.unsetMapTool(self.camera_tool)

    def _camera_dragging(self, x: float, y: float, heading: float) -> None:
        """Live wedge while the rough camera is being dragged (DEM CRS)."""
        from ..core.camera import Camera

        size = self.controller.photo_size or (4, 3)
        self.map_view.show_wedge(Camera((x, y, 0.0), heading, 0.0, 0.0, self.fovSpin.value(), size))

    def _camera_drawn(self, x: float, y: float, heading: float) -> None:
        self.controller.prior_from_map(x, y, heading, self.fovSpin.value(), self.pitchSpin.value(),
                                       self.heightSpin.value())
        self.drawCameraButton.setChecked(False)

    def _prior_spin_changed(self) -> None:
        """A box edited: the rough camera takes its field of view, pitch and heading, and keeps its position (a
        drone's heading had only "Draw on map", which also moved the camera off its GPS position, a trial)."""
        prior = self.controller.prior
        if prior is None:
            return
        heading = self.headingSpin.value()
        if abs((heading - prior.heading + 180.0) % 360.0 - 180.0) < 0.05:  # the box shows it to 0.1°: unchanged
            heading = prior.heading
        # the boxes not edited keep the camera's own value, not the one they show rounded (a trial's 35 mm lens,
        # 54.432°, became 54.4° when the heading was typed: 1.4 px RMS at 24 MP, held fixed by the fit)
        fov, pitch = _edited(self.fovSpin, prior.fov), _edited(self.pitchSpin, prior.pitch)
        if (prior.fov, prior.pitch, prior.heading) != (fov, pitch, heading):
            self.controller.set_prior(prior.with_parameters(fov=fov, pitch=pitch, heading=heading))
            # said in place of how the box's old value was set (a trial read "Pitch set to -15.0°" after typing -40)
            typed = [name for name, old, new in ((self.tr("heading"), prior.heading, heading),
                                                 (self.tr("pitch"), prior.pitch, pitch),
                                                 (self.tr("field of view"), prior.fov, fov)) if old != new]
            self._said(self.tr("Rough camera: {0} as typed (heading {1:.1f}°, pitch {2:.1f}°, field of view "
                               "{3:.1f}°).").format(", ".join(typed), heading, pitch, fov))

    def _import_kml(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, self.tr("Rough camera from KML or camera JSON"), "",
                                              self.tr(IoActions.OPEN_CAMERA_FILTER))
        if path:
            self.io_actions.open_camera(path)


def _edited(spin, value: float) -> float:
    """The box's value when it was edited (it differs from ``value`` by more than its rounding), else ``value``."""
    return spin.value() if abs(spin.value() - value) >= 0.5 * 10.0 ** -spin.decimals() else value
