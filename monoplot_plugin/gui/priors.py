"""Rough and fitted cameras of a :class:`~monoplot_plugin.gui.controller.MonoplotController` (a mixin).

Sources of a rough camera: drawn on the map (position + direction), a KML PhotoOverlay, the photo's EXIF GPS tags.
"""

from __future__ import annotations

import math
from typing import Optional

from qgis.core import Qgis

from ..adapters.exif import read_exif_prior
from ..core.camera import Camera, lonlat_to_crs
from . import engine

__all__ = ["PriorsMixin"]

INFO, WARNING, CRITICAL = Qgis.MessageLevel.Info, Qgis.MessageLevel.Warning, Qgis.MessageLevel.Critical


class PriorsMixin:
    """Needs the controller's ``state``, ``image``, ``dem``, ``photo_size``, ``message``, ``cameraChanged`` and
    ``_changed``."""

    @property
    def prior(self) -> Optional[Camera]:
        return Camera.from_dict(self.state.prior) if self.state.prior else None

    @property
    def fitted(self) -> Optional[Camera]:
        return Camera.from_dict(self.state.fitted) if self.state.fitted else None

    def camera(self) -> Optional[Camera]:
        """The best camera known: the fitted one, else the prior."""
        return self.fitted or self.prior

    def set_prior(self, camera: Optional[Camera]) -> None:
        self.state.prior = None if camera is None else camera.to_dict()
        self.cameraChanged.emit()
        self._changed()
        if camera is not None and self.dem is not None and not engine.camera_sees_dem(camera, self.dem):
            self.message.emit(self.tr("The rough camera does not look at the DEM: check position and heading."),
                              WARNING)

    def prior_from_map(self, x: float, y: float, heading: float, fov: float, pitch: float = 0.0,
                       height_above_ground: float = 2.0) -> Optional[Camera]:
        """A rough camera at map point (x, y) of the DEM CRS, looking towards ``heading`` (degrees from north)."""
        if self.image is None or self.dem is None:
            self.message.emit(self.tr("Load a photo and choose a DEM first."), WARNING)
            return None
        z = float(self.dem.sample(x, y))
        if not math.isfinite(z):
            self.message.emit(self.tr("The camera position is outside the DEM: its height is unknown."), WARNING)
            return None
        camera = Camera((x, y, z + height_above_ground), heading, pitch, 0.0, fov, self.photo_size,
                        crs_wkt=self.dem.crs_wkt)
        self.set_prior(camera)
        return camera

    def prior_from_exif(self, quiet: bool = False) -> bool:
        """A rough camera from the photo's EXIF GPS position, altitude, direction and 35 mm focal length.

        Missing altitude: 2 m above the DEM; missing direction: towards the DEM centre (redraw it if wrong)."""
        if self.image is None or self.dem is None:
            if not quiet:
                self.message.emit(self.tr("Load a photo and choose a DEM first."), WARNING)
            return False
        exif = read_exif_prior(self.state.photo_path, self.photo_size)
        if exif is None or not exif.has_position:
            if not quiet:
                self.message.emit(self.tr("The photo has no GPS position in its EXIF tags."), WARNING)
            return False
        x, y, convergence = lonlat_to_crs(exif.lon, exif.lat, self.dem.crs_wkt)
        ground = float(self.dem.sample(x, y))
        if not math.isfinite(ground):
            self.message.emit(self.tr("The photo's GPS position lies outside the DEM."), WARNING)
            return False
        z = exif.altitude if exif.altitude is not None else ground + 2.0
        if exif.heading is not None:
            heading, guessed = exif.heading - convergence, False
        else:
            x0, y0, x1, y1 = self.dem.bounds()
            heading, guessed = math.degrees(math.atan2((x0 + x1) / 2 - x, (y0 + y1) / 2 - y)), True
        camera = Camera((x, y, max(z, ground + 1.0)), heading, 0.0, 0.0, exif.fov or 60.0, self.photo_size,
                        crs_wkt=self.dem.crs_wkt)
        self.set_prior(camera)
        text = self.tr("Rough camera from the photo's EXIF GPS tags.")
        if guessed:
            text += " " + self.tr("No direction in EXIF: it looks at the DEM centre; draw it on the map if wrong.")
        self.message.emit(text, INFO)
        return True

    def exif_fov(self) -> Optional[float]:
        """Horizontal field of view from the photo's EXIF 35 mm focal length, or None."""
        if not self.state.photo_path or self.image is None:
            return None
        exif = read_exif_prior(self.state.photo_path, self.photo_size)
        return None if exif is None else exif.fov

    def _maybe_exif_prior(self) -> None:
        if not self._restoring and self.state.prior is None and self.image is not None and self.dem is not None:
            self.prior_from_exif(quiet=True)

    def import_kml(self, path: str) -> bool:
        """Read a KML PhotoOverlay as the prior."""
        if self.image is None or self.dem is None:
            self.message.emit(self.tr("Load a photo and choose a DEM before importing a KML camera."), WARNING)
            return False
        try:
            camera = Camera.from_kml(path, self.photo_size, self.dem.crs_wkt)
        except (OSError, ValueError, RuntimeError) as exc:
            self.message.emit(self.tr("Cannot read the KML camera: {0}").format(exc), CRITICAL)
            return False
        self.set_prior(camera)
        self.message.emit(self.tr("Rough camera imported from {0}").format(path), INFO)
        return True

