"""Rough and fitted cameras of a :class:`~monoplot_plugin.gui.controller.MonoplotController` (a mixin).

Sources of a rough camera: drawn on the map (position + direction), a KML PhotoOverlay, the photo's EXIF GPS tags.
Its needs are :class:`PriorsHost`, checked by ``tests/gui/test_controller_interfaces.py``.
"""

from __future__ import annotations

import math
from typing import Callable, Optional, Protocol, Tuple

import numpy as np
from qgis.core import Qgis

from ..adapters.exif import exif_camera, heading_to_dem_centre, read_exif_prior
from ..core.camera import Camera, azimuth
from ..core.kml import lonlat_to_crs
from ..workflow.auto import GPS_POSITION_SIGMA_M
from ..workflow.products import centred_on_picture
from . import engine

__all__ = ["PriorsMixin", "PriorsHost", "terrain_pitch", "pitch_and_rule", "photo_sky_rows", "GPS_SOURCE",
           "GPS_POSITION_M", "HEADING_GUESSED"]

INFO, WARNING, CRITICAL = Qgis.MessageLevel.Info, Qgis.MessageLevel.Warning, Qgis.MessageLevel.Critical
#: ``state.settings["prior_source"]`` of a rough camera placed at the photo's EXIF GPS position
GPS_SOURCE = "exif-gps"
#: ``state.settings`` key: the rough camera's heading is a guess (EXIF gave a position, no direction), until one is
#: drawn or typed
HEADING_GUESSED = "prior_heading_guessed"
#: metres: a rough camera moved no further than this keeps the source of its position (the same one, retyped)
SAME_PLACE_M = 5.0
#: metres: how far a phone's or drone's GPS position usually is from where it stood (the fit's moved-camera note)
GPS_POSITION_M = GPS_POSITION_SIGMA_M


def terrain_pitch(camera: Camera, dem, rays: int = 9, samples: int = 160,
                  sky_rows: Optional[np.ndarray] = None) -> Optional[float]:
    """A pitch (degrees) for a camera whose pitch is unknown, from the terrain's skyline along ``rays`` horizontal
    rays across the field of view (the highest elevation angle of the DEM along each). With ``sky_rows``, the
    photo's detected skyline ((K,) full-size row at K columns evenly across the picture, NaN where none:
    :func:`photo_sky_rows`), each ray's pitch puts the DEM's skyline on the photo's, median over the rays; without
    it (or too few rays on the photo's skyline), the median skyline goes a fifth of the vertical field of view below
    the top of the frame. None when no ray crosses the DEM. (:func:`pitch_and_rule` also says which rule it took.)

    (A trial's drone photo, truly pitched -6 deg, got +1.4 deg from the fixed fifth: its skyline sat higher.)

    >>> from monoplot_plugin.core.dem import Dem
    >>> ramp = Dem.from_array(np.tile(np.arange(100.0) * 10.0, (100, 1)).T[::-1], (0, 10, 0, 1000, 0, -10))
    >>> cam = Camera((500.0, 100.0, 200.0), 0.0, 0.0, 0.0, 60.0, (400, 300))
    >>> -10.0 < terrain_pitch(cam, ramp) < 40.0   # looking up the slope: up, less than the slope's top angle
    True
    >>> high = cam.with_parameters(z=800.0)
    >>> level = terrain_pitch(high, ramp, sky_rows=np.full(40, 150.0))  # the photo's skyline on the centre row
    >>> top = float(np.degrees(np.arctan2(ramp.sample(500.0, 990.0) - 800.0, 890.0)))
    >>> abs(level - top) < 1.5  # the camera looks at the skyline (to the DEM sampling)
    True
    """
    return pitch_and_rule(camera, dem, rays, samples, sky_rows)[0]


def pitch_and_rule(camera: Camera, dem, rays: int = 9, samples: int = 160, sky_rows: Optional[np.ndarray] = None,
                   sky_above: bool = False) -> Tuple[Optional[float], str]:
    """(:func:`terrain_pitch`, the rule that set it: "photo" (the photo's skyline), "fifth" (the fixed fifth) or
    "above"). ``sky_above``: the photo shows no sky and the camera is in the air, looking down: without the photo's
    skyline the DEM's goes just above the top of the frame, the least downward pitch that hides it (a drone trial's
    photo, pitched -30 deg with no sky in it, got -13 deg from the fixed fifth).

    >>> from monoplot_plugin.core.dem import Dem
    >>> flat = Dem.from_array(np.zeros((100, 100)), (0, 10, 0, 1000, 0, -10))
    >>> drone = Camera((500.0, 100.0, 120.0), 0.0, 0.0, 0.0, 60.0, (400, 300))
    >>> pitch, rule = pitch_and_rule(drone, flat, sky_above=True)
    >>> rule, round(pitch - terrain_pitch(drone, flat) + 0.3 * drone.vertical_fov, 6)
    ('above', 0.0)
    """
    x0, y0, z0 = (float(v) for v in camera.position)
    bx0, by0, bx1, by1 = dem.bounds()
    reach = math.hypot(bx1 - bx0, by1 - by0)
    distances = np.geomspace(max(20.0, reach / 2000.0), reach, samples)
    width = camera.width
    focal = camera.focal_px
    best, on_photo = [], []
    for k in range(rays):
        offset = -camera.fov / 2.0 + camera.fov * (k + 0.5) / rays  # ray centres, inside the frame
        a = math.radians(camera.heading + offset)
        xs, ys = x0 + distances * math.sin(a), y0 + distances * math.cos(a)
        z = np.asarray(dem.sample(xs, ys), dtype=float)
        ok = np.isfinite(z)
        if not ok.any():
            continue
        elevation = float(np.degrees(np.arctan2(z[ok] - z0, distances[ok])).max())
        best.append(elevation)
        if sky_rows is not None:
            u = camera.cx + focal * math.tan(math.radians(offset))  # a print's picture centre, not the scan's
            column = int(np.clip(u * len(sky_rows) / width, 0, len(sky_rows) - 1))
            v = float(sky_rows[column])
            if math.isfinite(v):
                # the ray's vertical angle in the camera: along the off-axis column the focal length is longer
                along = math.hypot(focal, u - camera.cx)
                on_photo.append(elevation - math.degrees(math.atan2(camera.cy - v, along)))
    if not best:
        return None, "fifth"
    if len(on_photo) >= max(3, rays // 3):
        return float(np.clip(np.median(on_photo), -60.0, 30.0)), "photo"
    if sky_above:
        return float(np.clip(np.median(best) - 0.5 * camera.vertical_fov, -60.0, 30.0)), "above"
    return float(np.clip(np.median(best) - 0.2 * camera.vertical_fov, -60.0, 30.0)), "fifth"


def photo_sky_rows(image: np.ndarray, mask: Optional[np.ndarray] = None) -> Optional[np.ndarray]:
    """The skyline :func:`terrain_pitch` aligns on: (K,) full-size rows at K columns evenly across the (H, W, 3)
    photo, NaN where no clear skyline; None when the photo has no usable skyline (fog, terrain to the top)."""
    from ..core.auto.photo_edges import detect_photo_edges

    edges = detect_photo_edges(image, mask=mask)
    if not edges.usable:
        return None
    return np.where(edges.sky_valid, (edges.sky_row + 0.5) / edges.scale - 0.5, np.nan)


class PriorsHost(Protocol):
    """What :class:`PriorsMixin` uses of the controller."""

    state: object  # ProjectState: prior and fitted camera dicts
    image: object  # QImage of the photo or None
    dem: object  # core Dem or None
    photo_size: Optional[Tuple[int, int]]
    _restoring: bool  # a project is being restored: no EXIF prior over the stored one
    message: object  # pyqtSignal(str, Qgis.MessageLevel)
    cameraChanged: object  # pyqtSignal()
    _changed: Callable[[], None]
    _picture_area: Callable[[], object]  # (H, W) bool of a print's picture, or None (ResultsMixin)
    _sky_rows_of: Optional[tuple]  # ((photo path, image key), the photo's skyline rows or None): set here
    tr: Callable[[str], str]


class PriorsMixin:
    """The rough camera (from the map, a KML, EXIF) and the fitted one; needs a :class:`PriorsHost`."""

    @property
    def prior(self) -> Optional[Camera]:
        return Camera.from_dict(self.state.prior) if self.state.prior else None

    @property
    def fitted(self) -> Optional[Camera]:
        return Camera.from_dict(self.state.fitted) if self.state.fitted else None

    def camera(self) -> Optional[Camera]:
        """The best camera known (Suggest renders the DEM from it): the fitted one, else the prior; the prior first
        when the fit was judged "poor" (a flood trial's Suggest rendered the DEM from a poor automatic camera 31 m
        under the terrain: 77 DEM suggestions against 159-340 from the rough camera)."""
        fitted, prior = self.fitted, self.prior
        if fitted is not None and prior is not None and (self.state.fit_info or {}).get("status") == "poor":
            return prior
        return fitted or prior

    def set_prior(self, camera: Optional[Camera], source: str = "") -> None:
        """Use ``camera`` as the rough camera; ``source``: where its position comes from (:data:`GPS_SOURCE`), kept
        while the position stays (a height or angle edited), forgotten when it moves."""
        old = self.prior
        if camera is not None and self.image is not None:  # a print's optical axis: its picture's centre
            centred = centred_on_picture(camera, self._picture_area())
            if centred is not camera and (old is None or old.principal_point != centred.principal_point):
                # said, as Processing says it (a re-check trial looked for it in the dock)
                self.message.emit(self.tr("Principal point at the picture's centre ({0:.0f}, {1:.0f}), not the "
                                          "file's: the photo has a print's border.").format(centred.cx, centred.cy),
                                  INFO)
            camera = centred
        # within a few metres: the same position typed again, rounded (a flood trial typed its EXIF GPS position to
        # the metre, and the search then took the default 200 m, not the GPS's 30 m: 144 m off instead of 25 m)
        same_place = old is not None and camera is not None and \
            math.dist(old.position[:2], camera.position[:2]) <= SAME_PLACE_M
        if source:
            self.state.settings["prior_source"] = source
        elif not same_place:
            self.state.settings.pop("prior_source", None)
        if camera is None or (old is not None and abs(old.heading - camera.heading) > 1e-6):
            self.state.settings.pop(HEADING_GUESSED, None)  # a heading given since, drawn or typed
        self.state.prior = None if camera is None else camera.to_dict()
        self.cameraChanged.emit()
        self._changed()
        if camera is not None and self.dem is not None and not engine.camera_sees_dem(camera, self.dem):
            self.message.emit(self.tr("The rough camera does not look at the DEM: check position and heading."),
                              WARNING)

    def under_terrain_note(self, camera: Camera) -> str:
        """A sentence (with a leading space) saying that ``camera``'s height is wrong when it stands deeper under the
        DEM than a coarse DEM explains, and what the fit does with it (:func:`~..workflow.fit.on_ground_rule`: on
        the ground); else ""."""
        from ..workflow.fit import ON_GROUND_MAX_M, ground_clearance

        clearance = ground_clearance(camera, self.dem) if self.dem is not None else math.nan
        if not (math.isfinite(clearance) and clearance < -ON_GROUND_MAX_M):
            return ""
        return " " + self.tr("It stands {0:.0f} m under the DEM at its position: its height is wrong, and the fit "
                             "will hold the camera on the ground, unless 5 or more pairs place it higher. Set "
                             "\"Above ground\" (Camera tab) if you know its height.").format(-clearance)

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
        if pitch == 0.0:  # unknown (the box's default): aim at the terrain's skyline
            camera, _ = self._with_terrain_pitch(camera)
        self.set_prior(camera)
        return camera

    def _with_terrain_pitch(self, camera: Camera, say: bool = True) -> Tuple[Camera, str]:
        """(``camera`` pitched at the terrain, the sentence that says how; "" when it stays as it is); ``say``:
        also show the sentence (the EXIF camera puts it in its own message, which would replace it)."""
        from ..workflow.fit import ON_GROUND_MAX_M, ground_clearance

        rows = self._photo_sky_rows()
        in_air = ground_clearance(camera, self.dem) > ON_GROUND_MAX_M  # (NaN off the DEM: not in the air)
        pitch, rule = pitch_and_rule(camera, self.dem, sky_rows=rows, sky_above=rows is None and in_air)
        if pitch is None:
            return camera, ""
        if rule == "photo":
            # measured once on 40 generated scenes, rough position ± 20 m: median pitch error 0.6° (3.5° before)
            text = self.tr("Pitch set to {0:.1f}°, so that the DEM's skyline lies on the photo's; edit it if "
                           "wrong.")
        elif rule == "above":
            # a bound, not an estimate: a quarry trial's drone looked down -40°, the bound said -15° and nothing
            # asked for the real one; suggestions and fits from it failed ("poor")
            text = self.tr("Pitch set to {0:.1f}°: the photo shows no sky, so the camera, in the air, looks down at "
                           "least this much (the DEM's skyline just above the picture). Drone photos often look "
                           "down much more: type the gimbal pitch if you know it (the flight app or log), else try "
                           "a steeper pitch if the suggestions do not match.")
        else:
            text = self.tr("Pitch set to {0:.1f}° from the terrain (its skyline in the upper part of the picture); "
                           "edit it if wrong.")
        text = text.format(pitch)
        if say:
            self.message.emit(text, INFO)
        return camera.with_parameters(pitch=pitch), text

    def _photo_sky_rows(self) -> Optional[np.ndarray]:
        """The photo's skyline for :func:`terrain_pitch` (once per photo), None without a clear one."""
        from ..adapters.photo import qimage_to_array

        if self.image is None:
            return None
        key = (self.state.photo_path, self.image.cacheKey())
        cached = self._sky_rows_of
        if cached is None or cached[0] != key:
            rows = photo_sky_rows(qimage_to_array(self.image), self._picture_area())
            self._sky_rows_of = cached = (key, rows)
        return cached[1]

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
        x, y, _ = lonlat_to_crs(exif.lon, exif.lat, self.dem.crs_wkt)
        ground = float(self.dem.sample(x, y))
        if not math.isfinite(ground):
            self.message.emit(self.tr("The photo's GPS position lies outside the DEM."), WARNING)
            return False
        guessed = exif.heading is None  # then it looks at the DEM's centre
        camera = exif_camera(exif, self.photo_size, self.dem, heading=heading_to_dem_centre(x, y, self.dem))
        if exif.pitch is None:
            camera, pitched = self._with_terrain_pitch(camera, say=False)
        else:  # a drone's gimbal: looking down at -45° it sees no skyline, and the terrain's pitch would be level
            # the heading as the Camera tab's box shows it: from the DEM's grid north, not the tag's true north
            pitched = self.tr("Pitch {0:.1f}° and heading {1:.0f}° from the drone's gimbal (XMP tags).").format(
                exif.pitch, azimuth(camera.heading)) if exif.heading_from_gimbal else \
                self.tr("Pitch {0:.1f}° from the drone's gimbal (XMP tags).").format(exif.pitch)
        self.set_prior(camera, source=GPS_SOURCE)
        if guessed:  # Find camera searches a few degrees around it: it should say so (trials B and C)
            self.state.settings[HEADING_GUESSED] = True
        else:
            self.state.settings.pop(HEADING_GUESSED, None)
        text = self.tr("Rough camera from the photo's EXIF GPS tags.")
        if guessed:  # first: the message bar and the status line show two or three lines (a re-check trial)
            text += " " + self.tr("No direction in EXIF: it looks at the DEM centre for now; Find camera automatically "
                                  "searches every direction (three to four times as long), or draw it on the map.")
        text += (" " + pitched) if pitched else ""
        if exif.altitude is not None:  # a trial's phone said 11 m above the ground for a hand-held 1.6 m
            above = float(camera.position[2]) - ground
            text += " " + (self.tr("Its GPS altitude puts it {0:.0f} m above the DEM; a GPS height is often 10-30 m "
                                   "off: set \"Above ground\" (Camera tab) if you know it, e.g. 1.7 m held in the "
                                   "hand.") if above < 50.0 else
                           self.tr("Its GPS altitude puts it {0:.0f} m above the DEM; a GPS height is often 10-30 m "
                                   "off: set \"Above ground\" (Camera tab) if you know the flight height.")
                           ).format(above)
            low, high = _ground_range(self.dem, x, y, GPS_POSITION_M)
            if high - low > 10.0:  # a slope: where the GPS put it is not where it stood (a phone trial: "31 m above
                # the DEM" at a GPS fix 22 m downslope, 12.6 m above the ground where it stood)
                text += " " + self.tr("The ground within {0:.0f} m of the GPS position (its usual error) lies "
                                      "{1:.0f} to {2:.0f} m below that altitude: on a slope the height above the DEM "
                                      "depends on where the camera really stood; the fit finds it.").format(
                    GPS_POSITION_M, float(camera.position[2]) - high, float(camera.position[2]) - low)
            if exif.relative_altitude is not None:  # barometric, from the take-off point: a check of the GPS's
                text += " " + self.tr("The drone logged {0:.0f} m above its take-off point.").format(
                    exif.relative_altitude)
        if exif.heading_magnetic and not guessed:  # a phone compass: the declination is unknown (up to 20° and more)
            text += " " + self.tr("Its direction is from magnetic north: it is off by the local magnetic "
                                  "declination; correct the heading if you know it.")
        if exif.fov is None:
            text += " " + (self.tr("EXIF gives a {0:g} mm focal length but no sensor size and no 35 mm equivalent: "
                                   "field of view 60° until you enter the lens (camera tab).").format(exif.focal_mm)
                           if exif.focal_mm else self.tr("No focal length in EXIF: field of view 60°."))
        self.message.emit(text, INFO)
        return True

    def exif_fov(self) -> Optional[float]:
        """Horizontal field of view from the photo's EXIF 35 mm focal length, or None."""
        exif = self.exif_lens()
        return None if exif is None else exif.fov

    def exif_lens(self):
        """The photo's EXIF (:class:`~..adapters.exif.ExifPrior`: focal length, sensor, field of view), or None."""
        if not self.state.photo_path or self.image is None:
            return None
        return read_exif_prior(self.state.photo_path, self.photo_size)

    def _maybe_exif_prior(self, fresh: bool = False) -> bool:
        """The photo's EXIF GPS camera as the rough camera when there is none, or when the one there was carried
        from another photo (``fresh``: a new photo whose work was not put aside earlier): a trial's second phone
        photo kept the first one's GPS camera, taken elsewhere, and saved it as its own prior. A photo without
        GPS tags keeps the carried one (the next frame of the same view). Returns whether the EXIF camera was set."""
        if self._restoring or self.image is None or self.dem is None:
            return False
        return bool((self.state.prior is None or fresh) and self.prior_from_exif(quiet=True))

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
        note = self.under_terrain_note(camera)
        self.message.emit(self.tr("Rough camera imported from {0}.").format(path) + note, WARNING if note else INFO)
        return True


def _ground_range(dem, x: float, y: float, radius: float) -> "tuple[float, float]":
    """(lowest, highest) DEM height (m) within ``radius`` metres of (x, y), sampled on three rings of 12 points and
    the centre; (NaN, NaN) off the DEM."""
    angles = np.radians(np.arange(0.0, 360.0, 30.0))
    rings = [(0.0, 0.0)] + [(r * np.cos(a), r * np.sin(a)) for r in (radius / 3, 2 * radius / 3, radius)
                            for a in angles]
    heights = np.array([float(dem.sample(x + dx, y + dy)) for dx, dy in rings])
    heights = heights[np.isfinite(heights)]
    return (float(heights.min()), float(heights.max())) if len(heights) else (math.nan, math.nan)
