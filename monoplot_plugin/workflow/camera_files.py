"""Camera files, for the dock and Processing: the one reader of a Monoplot camera JSON or a KML PhotoOverlay.

Writers: :meth:`~monoplot_plugin.core.camera.Camera.to_json` (through ``outputs.safe_write.write_text``) and
:func:`~monoplot_plugin.outputs.camera_kml.write_camera_kml`.
"""

from __future__ import annotations

import json
import os
from dataclasses import replace
from typing import Optional, Tuple

import numpy as np

from ..core.camera import Camera, azimuth
from .inputs import InputError, _crs_name, check_camera, read_text

__all__ = ["load_camera", "save_camera", "camera_json", "written_fit", "written_verdict", "fitted_to_size",
           "photo_fingerprint", "fitted_photo", "fitted_on_photo", "verdict_on_photo", "fit_figures", "PIXEL_FIGURES"]

#: A fit's pixel figures a product's ``xy_error_m`` is worked out from (:func:`~.features.pixel_error`).
PIXEL_FIGURES = ("rmse_px", "loo_rmse_px", "sigma_px")


def load_camera(path: str, image_size: Optional[Tuple[int, int]] = None, crs_wkt: str = "",
                notes: Optional[list] = None, rough: bool = False, default_fov: Optional[float] = None) -> Camera:
    """A camera from a Monoplot JSON file (:meth:`Camera.save`) or a KML PhotoOverlay.

    Args:
        path: ``.json`` or ``.kml`` file.
        image_size: (width, height) in pixels of the photo; required for KML (which has no image size), and checked
            against the JSON camera's own size when both are known.
        crs_wkt: WKT (or "EPSG:n") of the DEM's CRS; required for KML (given in WGS84). A JSON camera in another
            projected CRS is transformed into it (:func:`~..core.kml.camera_to_crs`), and a note added to ``notes``.
        rough: the camera is a start for a fit (a prior), not the camera of the products: a JSON camera of a photo
            of another shape (a crop of the same picture, say) keeps its pose and field of view, with a note,
            instead of being refused. See :func:`fitted_to_size`.
        default_fov: the field of view (degrees) for a KML without one (a note says so); None: such a KML is
            refused.
    """
    if not path:
        raise InputError("no camera file given")
    if not os.path.isfile(path):
        raise InputError(f"camera file not found: {path}")
    if path.lower().endswith(".kml"):
        if image_size is None:
            raise InputError(f"{os.path.basename(path)}: a KML camera needs the photo (for its size)")
        if not crs_wkt:
            raise InputError(f"{os.path.basename(path)}: a KML camera needs the DEM (for its CRS)")
        try:
            return Camera.from_kml(path, image_size=image_size, dst_crs_wkt=crs_wkt, default_fov=default_fov,
                                   notes=notes)
        except Exception as exc:  # malformed KML: say which file
            raise InputError(f"cannot read the KML camera {os.path.basename(path)}: {exc}") from exc
    if os.path.getsize(path) == 0:
        raise InputError(f"the camera file {os.path.basename(path)} is empty (0 bytes)")
    try:
        camera = Camera.from_json(read_text(path))
    except (OSError, ValueError, TypeError, KeyError, AttributeError, json.JSONDecodeError) as exc:
        raise InputError(f"cannot read the camera file {os.path.basename(path)} "
                         f"(expected Monoplot camera JSON): {exc}") from exc
    check_camera(camera, f"the camera {os.path.basename(path)}")
    if image_size is not None and tuple(camera.image_size) != tuple(image_size):
        camera = fitted_to_size(camera, image_size, rough, os.path.basename(path), notes)
    if crs_wkt and camera.crs_wkt and not _same_crs(camera.crs_wkt, crs_wkt):
        return _moved_to(camera, crs_wkt, os.path.basename(path), notes)
    return camera


#: Two picture shapes (width / height) this close are the same picture at another resolution.
SAME_SHAPE = 0.005


def fitted_to_size(camera: Camera, image_size: Tuple[int, int], rough: bool = False, name: str = "",
                   notes: Optional[list] = None) -> Camera:
    """``camera``, made for a picture of another size, for a photo of ``image_size`` (width, height):

    * the same shape (aspect ratios within :data:`SAME_SHAPE`): the same picture at another resolution (a scan
      saved smaller, a resampled copy): the camera scaled (:meth:`~..core.camera.Camera.scaled`), exact;
    * another shape and ``rough``: a crop or another print of the view: position, angles and field of view kept
      as a start for a fit (the principal point back at the centre);
    * else an :class:`InputError` that says what to do.

    A note in ``notes`` says which.

    >>> cam = Camera((0.0, 0.0, 100.0), 10.0, -5.0, 0.0, 50.0, (2000, 1500), principal_point=(1010.0, 750.0))
    >>> notes = []
    >>> small = fitted_to_size(cam, (1000, 750), notes=notes)
    >>> small.image_size, small.principal_point, small.fov
    ((1000, 750), (505.0, 375.0), 50.0)
    >>> notes[0][:62]
    "the camera is for a 2000x1500 picture: scaled to the photo's 1"
    >>> fitted_to_size(cam, (1000, 900), rough=True).image_size
    (1000, 900)
    >>> try:
    ...     fitted_to_size(cam, (1000, 900))
    ... except InputError as exc:
    ...     print(str(exc)[:76])
    the camera is for a 2000x1500 picture but the photo is 1000x900, another sha
    """
    w, h = int(image_size[0]), int(image_size[1])
    was = f"{camera.width}x{camera.height}"
    name = f"camera {name}" if name else "the camera"
    if abs((w / h) / (camera.width / camera.height) - 1.0) <= SAME_SHAPE:
        scaled = replace(camera.scaled(w / camera.width), image_size=(w, h))  # the height rounded as the photo's
        if notes is not None:
            notes.append(f"{name} is for a {was} picture: scaled to the photo's {w}x{h} (the same shape, so the "
                         f"same picture at another resolution)")
        return scaled
    if not rough:
        raise InputError(f"{name} is for a {was} picture but the photo is {w}x{h}, another shape (a crop?): fit "
                         f"this photo's camera from it as a rough one (the dock's rough camera, or Fit camera's "
                         f"prior camera)")
    if notes is not None:
        notes.append(f"{name} is for a {was} picture and the photo is {w}x{h}, another shape (a crop?): its "
                     f"position, angles and field of view are kept as a rough start; the fit finds this photo's")
    return replace(camera, image_size=(w, h), principal_point=None)


def _moved_to(camera: Camera, crs_wkt: str, name: str, notes: Optional[list]) -> Camera:
    """``camera`` transformed into the DEM's CRS when both are projected (a note says so); else refused: its
    position would be read in the wrong coordinates, the camera would see no DEM and every product be empty."""
    from ..core.kml import camera_to_crs

    a, b = _srs(camera.crs_wkt), _srs(crs_wkt)
    if a is None or b is None or not (a.IsProjected() and b.IsProjected()):
        raise InputError(f"camera {name} is in {_crs_name(camera.crs_wkt)} but the DEM is in "
                         f"{_crs_name(crs_wkt)}: use a DEM in the camera's CRS, or fit the camera on this DEM")
    try:
        moved, turned = camera_to_crs(camera, crs_wkt)
    except Exception as exc:  # PROJ cannot transform between them
        raise InputError(f"camera {name} is in {_crs_name(camera.crs_wkt)} and cannot be transformed into the "
                         f"DEM's {_crs_name(crs_wkt)}: {exc}") from exc
    if notes is not None:
        notes.append(f"camera {name} transformed from {_crs_name(camera.crs_wkt)} into the DEM's "
                     f"{_crs_name(crs_wkt)} (heading turned by {turned:+.2f} deg to the DEM's grid north)")
    return moved


def _srs(wkt: str):
    from osgeo import osr

    srs = osr.SpatialReference()
    if srs.SetFromUserInput(wkt) != 0:
        return None
    return srs


def _same_crs(a: str, b: str) -> bool:
    """Whether two CRS definitions (WKT, "EPSG:n") are the same; True when either cannot be parsed."""
    sa, sb = _srs(a), _srs(b)
    if sa is None or sb is None:
        return True
    return bool(sa.IsSame(sb, ["IGNORE_DATA_AXIS_TO_SRS_AXIS_MAPPING=YES",
                               "CRITERION=EQUIVALENT_EXCEPT_AXIS_ORDER_GEOGCRS"]))


def save_camera(path: str, camera: Camera, name: str = "Monoplot camera", verdict: Optional[dict] = None,
                photo_path: str = "") -> None:
    """Write ``camera`` to ``path``: a KML PhotoOverlay for ``.kml`` (position, angles, field of view only), else
    Monoplot's camera JSON (everything, and ``verdict``, the fit's {"status", "message"}, when given: see
    :func:`written_verdict`; ``photo_path``: the photo it was fitted on, see :func:`camera_json`). Through a
    temporary file; an existing file is replaced."""
    from ..outputs.safe_write import write_text

    if str(path).lower().endswith(".kml"):
        from ..outputs.camera_kml import write_camera_kml

        write_camera_kml(path, camera, name=name, overwrite=True)
    else:
        write_text(path, camera_json(camera, verdict, photo_path), overwrite=True)


def camera_json(camera: Camera, verdict: Optional[dict] = None, photo_path: str = "") -> str:
    """Monoplot camera JSON with the fit's verdict ({"status", "message"}, and its σ per parameter from
    ``"sigma"`` or the fit summary's ``"std"``) under ``"fit"`` (readers of the camera ignore it:
    :meth:`~..core.camera.Camera.from_dict`). With ``photo_path``, the photo the verdict is about: its file name
    and :func:`photo_fingerprint` (see :func:`fitted_on_photo`).

    >>> cam = Camera((1.0, 2.0, 3.0), 0.0, 0.0, 0.0, 50.0, (10, 8))
    >>> text = camera_json(cam, {"status": "uncertain", "message": "few points", "sigma": {"x": 2.5}})
    >>> Camera.from_json(text) == cam, json.loads(text)["fit"]["status"], json.loads(text)["fit"]["sigma"]
    (True, 'uncertain', {'x': 2.5})

    The heading is written as an azimuth, as the dock and the report show it (a fit may end at -135: the file
    says 225, the same camera):

    >>> json.loads(camera_json(cam.with_parameters(heading=-135.0)))["heading"]
    225.0
    """
    d = camera.to_dict()
    d["heading"] = azimuth(camera.heading)
    if not verdict:
        return json.dumps(d, indent=2)
    d["fit"] = {"status": str(verdict.get("status") or ""), "message": str(verdict.get("message") or ""),
                **fit_figures(verdict)}
    d["fit"].update(fitted_photo(photo_path))
    return json.dumps(d, indent=2)


def fitted_photo(photo_path: str) -> dict:
    """``{"photo": name, "photo_sha256": fingerprint}`` of the photo a camera was fitted on, as its camera file
    records it (:func:`camera_json`); {} when there is none or it cannot be read."""
    fingerprint = photo_fingerprint(photo_path)
    return {"photo": os.path.basename(photo_path), "photo_sha256": fingerprint} if fingerprint else {}


def fit_figures(verdict: dict) -> dict:
    """What a camera file keeps of a fit besides its status and message: ``sigma`` per parameter (from ``"sigma"``
    or the fit summary's ``"std"``) and their ``correlation``, ``mode``, ``on_ground`` (with ``eye_height_m``, its
    height above the terrain: a reloaded camera read "ground + 0 m" for one held 1.6 m up, a trial) and the
    :data:`PIXEL_FIGURES` a product's ``xy_error_m`` is worked out from (:func:`~.features.pixel_error`,
    :func:`~.spread.camera_spread`), ``check_rmse_px`` with ``n_check`` (the check points' RMSE, when there are
    any); finite values only. ``fitted_parameters``: the parameters the fit changed (from
    ``"free"``), so that one held at a known value (a surveyed position, a lens's field of view) reads as held, not
    as fitted with no σ.

    >>> fit_figures({"status": "ok", "summary": {"std": {"x": 2.0, "y": None}, "rmse_px": 1.5}, "mode": "paired"})
    {'sigma': {'x': 2.0}, 'mode': 'paired', 'rmse_px': 1.5}
    >>> fit_figures({"summary": {"free": ["heading", "pitch", "roll"]}})
    {'fitted_parameters': ['heading', 'pitch', 'roll']}
    >>> fit_figures({"sigma": {"x": 2.0}, "correlation": {"x": {"y": 0.5, "z": None}}, "on_ground": True,
    ...              "eye_height_m": 1.6})
    {'sigma': {'x': 2.0}, 'correlation': {'x': {'y': 0.5}}, 'on_ground': True, 'eye_height_m': 1.6}
    """
    out = {}
    summary = verdict.get("summary") or {}
    sigma = verdict.get("sigma") or summary.get("std") or {}
    sigma = {str(k): float(v) for k, v in sigma.items() if v is not None and np.isfinite(float(v))}
    if sigma:
        out["sigma"] = sigma
    from .spread import plain_correlation

    correlation = plain_correlation(verdict.get("correlation") or summary.get("correlation"))
    if any(correlation.values()):
        out["correlation"] = correlation
    if isinstance(verdict.get("on_ground"), bool):
        out["on_ground"] = verdict["on_ground"]
        eye = verdict.get("eye_height_m")
        if verdict["on_ground"] and eye is not None and np.isfinite(float(eye)):
            out["eye_height_m"] = float(eye)
    free = verdict.get("free", summary.get("free"))
    if free:
        out["fitted_parameters"] = [str(name) for name in free]
    for key in ("mode",) + PIXEL_FIGURES + ("check_rmse_px",):
        value = verdict.get(key, summary.get(key))
        if isinstance(value, str) or (value is not None and np.isfinite(float(value))):
            out[key] = value if isinstance(value, str) else float(value)
    if "check_rmse_px" in out and verdict.get("n_check"):
        out["n_check"] = int(verdict["n_check"])
    return out


def photo_fingerprint(path: str) -> str:
    """SHA-256 (hex) of a photo file's bytes, "" when it cannot be read: which photo a camera was fitted on, whatever
    its name (a time-lapse's frames share names and sizes, and differ by a turn of the mount)."""
    import hashlib

    if not path:
        return ""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return ""
    return digest.hexdigest()


def fitted_on_photo(fit: dict, photo_path: str) -> Optional[bool]:
    """Whether the verdict ``fit`` (:func:`written_fit`) is about the photo at ``photo_path``: True (the same bytes),
    False (another photo), None (the file does not say: written without a photo, e.g. a fit on points alone).

    A trial loaded frame 1's "ok" camera onto frame 5 of the same station, after a 4 degree remount: the dock said
    "ok", and a front drawn on it was 168 m off where its error figure said 6.9 m.

    >>> fitted_on_photo({}, "a.jpg") is None, fitted_on_photo({"photo_sha256": "0" * 64}, "/no/such/photo.jpg")
    (True, False)
    """
    recorded = str(fit.get("photo_sha256") or "")
    if not recorded:
        return None
    return photo_fingerprint(photo_path) == recorded


def written_fit(path: str) -> dict:
    """The ``"fit"`` a camera JSON was written with (:func:`camera_json`: status, message, sigma); {} for a KML, a
    camera written without it, or a file that cannot be read."""
    if not path or str(path).lower().endswith(".kml"):
        return {}
    try:
        fit = json.loads(read_text(path)).get("fit") or {}
    except (OSError, ValueError, AttributeError):
        return {}
    return fit if isinstance(fit, dict) else {}


def written_verdict(path: str) -> Tuple[str, str]:
    """(status, message) of the fit a camera JSON was written with (:func:`written_fit`); ("", "") without one. A
    camera from a registration that was "uncertain" or "poor" is written all the same (the prior, or the best
    found), and the products made from it inherit that: a trial chained autoregister on a photo of fog into an XYZ
    raster, and nothing said so."""
    fit = written_fit(path)
    return str(fit.get("status") or ""), str(fit.get("message") or "")


def verdict_on_photo(path: str, photo_path: str) -> Tuple[str, str]:
    """:func:`written_verdict` of the camera file ``path`` for products of the photo ``photo_path``: an "ok" its fit
    gave on another photo (:func:`fitted_on_photo`) is "uncertain" here, the message saying so first."""
    fit = written_fit(path)
    status, message = str(fit.get("status") or ""), str(fit.get("message") or "")
    if status == "ok" and photo_path and fitted_on_photo(fit, photo_path) is False:
        return "uncertain", (f"fitted on another photo ({fit.get('photo') or 'unknown'}), not on "
                             f"{os.path.basename(photo_path)}: its \"ok\" does not carry over (a camera turned by a "
                             f"few degrees looks the same in the file). Its fit's message: {message}")
    return status, message
