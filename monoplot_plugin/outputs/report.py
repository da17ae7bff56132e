"""One-page report of a georeferenced photo (PNG or PDF, A4 portrait) for papers and field notes.

Contents: the photo with the control points, their reprojections and residual vectors (exaggerated, scale given);
the DEM seen from the camera overlaid on the photo (elevation contours of the XYZ raster and the skyline); a map of
the footprint (hillshade, cells the camera sees, camera and view direction, control points); the camera parameters
with their standard deviations and the reprojection RMSE.

Drawn with matplotlib (Debian's python3-matplotlib, a dependency of python3-qgis, so present wherever QGIS is; this
module uses the object API with the Agg/PDF canvases, never pyplot, so it does not touch QGIS's Qt event loop).
"""

from __future__ import annotations

import datetime
import math
import os
from pathlib import Path
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..core.camera import azimuth
from ..core.dem import Dem
from ..core.fit.result import sigma_undetermined, verdict_first as judgement_first
from ._gdal import image_verifier
from .safe_write import atomic_output

__all__ = ["write_report", "parameter_sigmas", "ReportPoints"]

FIT_PARAMETERS = ("x", "y", "z", "heading", "pitch", "roll", "fov")
#: The longest side, in pixels or cells, of the photo, the overlay and the map drawn on the page (a page at 150 dpi is
#: 1,240 px wide): larger inputs are drawn from every k-th pixel.
PAGE_PIXELS = 1600
_UNITS = {"x": "m", "y": "m", "z": "m", "heading": "°", "pitch": "°", "roll": "°", "fov": "°", "cx": "px",
          "cy": "px", "k1": "", "k2": ""}
#: a dark backing under point names: magenta on snow could not be read (a re-check trial)
_LABEL_BOX = dict(facecolor="black", alpha=0.45, edgecolor="none", pad=0.6)
#: check points' names: a light magenta (the markers' pure magenta was hard to read on the dark box, a trial)
CHECK_LABEL_COLOUR = "#ff9cff"
#: Offsets (points) tried for a point's name, nearest first: beside it, then above and below, then further out.
_LABEL_OFFSETS = ((4, -4), (4, 4), (-4, -4), (-4, 4), (0, 8), (0, -8), (10, 0), (-10, 0), (6, -14), (6, 14),
                  (-6, -14), (-6, 14))


class _Labels:
    """Point names on a photo axes, each at the first of :data:`_LABEL_OFFSETS` where it covers no other name and no
    other point (the one covering least when none is free): the names of close points were drawn over each other (a
    re-check trial's report). Boxes are estimated from the font size, in display units after the axes' aspect."""

    def __init__(self, ax, points_uv, fontsize: float = 7.0):
        ax.apply_aspect()
        self.ax, self.fontsize, self.pt = ax, fontsize, ax.figure.dpi / 72.0
        self.markers = self._display(points_uv)
        self.boxes = []

    def _display(self, uv) -> np.ndarray:
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        return self.ax.transData.transform(uv) if len(uv) else np.zeros((0, 2))

    def _overlap(self, box, own) -> float:
        r = 3.5 * self.pt  # a marker's half size
        others = [(x - r, y - r, x + r, y + r) for x, y in self.markers if math.hypot(x - own[0], y - own[1]) > 0.5]
        x0, y0, x1, y1 = box
        return sum(max(0.0, min(x1, b[2]) - max(x0, b[0])) * max(0.0, min(y1, b[3]) - max(y0, b[1]))
                   for b in self.boxes + others)

    def add(self, name: str, u: float, v: float, colour: str, only_if_free: bool = False) -> bool:
        """Draw ``name`` beside (u, v); with ``only_if_free`` not at all when every place covers something
        (returns whether it was drawn)."""
        (x, y), = self._display([(u, v)])
        pad = _LABEL_BOX["pad"] * self.fontsize * self.pt  # the backing's margin around the text
        w, h = 0.6 * self.fontsize * len(name) * self.pt, 1.2 * self.fontsize * self.pt
        best = None
        for dx, dy in _LABEL_OFFSETS:
            left = x + dx * self.pt - (0.0 if dx > 0 else w if dx < 0 else 0.5 * w)
            bottom = y + dy * self.pt - (h if dy < 0 else 0.0 if dy > 0 else 0.5 * h)
            box = (left - pad, bottom - pad, left + w + pad, bottom + h + pad)
            cost = self._overlap(box, (x, y))
            if best is None or cost < best[0]:
                best = (cost, dx, dy, box)
            if cost == 0.0:
                break
        if only_if_free and best[0] > 0.0:
            return False
        _, dx, dy, box = best
        self.boxes.append(box)
        # a name moved off its first place gets a thin line to its point (a re-check trial gave two names of a
        # cluster to the point they had been moved beside)
        leader = None if (dx, dy) == _LABEL_OFFSETS[0] else dict(arrowstyle="-", color=colour, lw=0.6, shrinkA=0,
                                                                  shrinkB=0, alpha=0.8)
        self.ax.annotate(name, (u, v), xytext=(dx, dy), textcoords="offset points", color=colour,
                         fontsize=self.fontsize, bbox=_LABEL_BOX, arrowprops=leader, ha="left" if dx > 0 else
                         "right" if dx < 0 else "center", va="top" if dy < 0 else "bottom" if dy > 0 else "center")
        return True


class ReportPoints:
    """Control points: (N, 2) photo pixels and (N, 3) map coordinates, optional names."""

    def __init__(self, uv, xyz, names: Optional[Sequence[str]] = None):
        self.uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        self.xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        if len(self.uv) != len(self.xyz):
            raise ValueError("as many photo points as map points are needed")
        self.names = list(names) if names is not None else [str(i + 1) for i in range(len(self.uv))]
        self.named = names is not None  # names of their own (a GCP table's ids), not the numbers 1, 2, ...


def parameter_sigmas(camera, points: ReportPoints, names: Sequence[str] = FIT_PARAMETERS) -> Dict[str, float]:
    """Standard deviations of camera parameters from the paired points (Gauss-Newton covariance
    ``s² (JᵀJ)⁻¹``, with ``s²`` the residual variance per coordinate); NaN when under-determined.

    Args:
        camera: the fitted Camera. points: its control points. names: parameters that were fitted.
    Returns:
        {name: sigma} in the parameter's units (m, degrees).
    """
    base = np.array([camera.parameters()[n] for n in names])
    steps = np.array([0.1 if n in ("x", "y", "z") else 1e-3 for n in names])

    def residual(p):
        return (camera.with_parameters(**dict(zip(names, p))).project(points.xyz) - points.uv).ravel()

    r0 = residual(base)
    jac = np.empty((len(r0), len(base)))
    for j in range(len(base)):
        dp = np.zeros_like(base)
        dp[j] = steps[j]
        jac[:, j] = (residual(base + dp) - residual(base - dp)) / (2 * steps[j])
    dof = len(r0) - len(base)
    if dof <= 0 or not np.isfinite(jac).all():
        return {n: float("nan") for n in names}
    s2 = float(r0 @ r0) / dof
    try:
        cov = s2 * np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return {n: float("nan") for n in names}
    return {n: float(math.sqrt(max(cov[i, i], 0.0))) for i, n in enumerate(names)}


def write_report(path, photo: np.ndarray, camera, dem, points: Optional[ReportPoints] = None, *,
                 xyz: Optional[np.ndarray] = None, visible: Optional[np.ndarray] = None,
                 sigmas: Optional[Dict[str, float]] = None, title: str = "", overwrite: bool = False,
                 verdict: str = "", checks: Optional[ReportPoints] = None,
                 picture: Optional[np.ndarray] = None, accuracy: str = "", photo_taken: str = "") -> Path:
    """Write the one-page report.

    Args:
        path: ``.png`` (150 dpi) or ``.pdf``.
        photo: (H, W) or (H, W, 3) uint8 photo.
        camera: the fitted Camera. dem: core Dem in the camera's CRS.
        points: the paired control points to draw (a CSV table is read by ``workflow.points_csv``), or None.
        xyz: (H, W, 3) per-pixel map coordinates; computed with core's rasteriser when None.
        visible: (rows, cols) bool DEM cells the camera sees; computed with the XYZ raster when None.
        sigmas: parameter standard deviations by name; from the points (:func:`parameter_sigmas`) when None.
        title: heading (default: "Monoplot report").
        verdict: the fit's status and message (e.g. ``"uncertain: ... add check points."``), printed under the
            parameters so that a report of a doubtful camera says so.
        picture: (H, W) bool, where the photo shows the scene (not a print's border or caption): the contours and
            the share of ground seen keep to it (None: everywhere).
        checks: independent check points (kept out of the fit), drawn in magenta with their residuals; their RMSE
            is the camera's measured accuracy and is printed first.
        accuracy: what the camera is worth on the ground, in words (e.g. "check points 7.7 px: about 40 m on the
            ground ..."), printed as "Ground accuracy: ..." (a desktop trial: the report gave none in metres).
        photo_taken: when the photo was taken (its EXIF date, ISO 8601), printed beside the report's own date
            (a flood trial read the unlabelled date at the top, the day the report was made, as the photo's).
        overwrite: replace an existing file (default: refuse with OutputExistsError).
    Returns:
        the Path written.
    """
    from matplotlib.figure import Figure

    target = Path(os.fspath(path))
    fmt = target.suffix.lower().lstrip(".")
    if fmt not in ("png", "pdf"):
        raise ValueError(f"report format must be .png or .pdf, got {target.suffix!r}")
    if xyz is None or visible is None:
        from ..core.xyz import compute_xyz_full

        result = compute_xyz_full(camera, dem, visibility=visible is None)
        xyz = result.xyz if xyz is None else xyz
        visible = result.visible if visible is None else visible
    residual = rmse = None
    if points is not None and len(points.uv):
        residual = camera.project(points.xyz) - points.uv
        rmse = float(np.sqrt(np.nanmean(np.sum(residual ** 2, axis=1))))
        if sigmas is None:
            sigmas = parameter_sigmas(camera, points)
    photo = np.asarray(photo)

    fig = Figure(figsize=(8.27, 11.69))
    fig.text(0.06, 0.965, title or "Monoplot report", fontsize=15, weight="bold")
    taken = f"photo taken {photo_taken.replace('T', ' ')[:16]}  ·  " if photo_taken else ""
    fig.text(0.06, 0.948, f"report of {datetime.date.today().isoformat()}  ·  {taken}photo {camera.width} × "
             f"{camera.height} px  ·  {_crs_label(dem.crs_wkt)}", fontsize=8, color="0.3")
    ax_photo = fig.add_axes((0.06, 0.62, 0.88, 0.31))  # room under it for the badge (it covered a title, a trial)
    ax_overlay = fig.add_axes((0.06, 0.33, 0.43, 0.24))
    ax_map = fig.add_axes((0.54, 0.29, 0.40, 0.27))  # its title stays below the photo
    ax_text = fig.add_axes((0.06, 0.03, 0.88, 0.24))
    check_rmse = _checks_rmse(camera, checks)
    # the page shows at most PAGE_PIXELS a side: a 24 MP scan over a 25 M-cell DEM drawn whole took 2 GB more
    # memory (5.4 GB in all) and 25 s; the figures below are of the full arrays
    k = max(1, math.ceil(max(photo.shape[:2]) / PAGE_PIXELS))
    labels = _draw_points(ax_photo, photo[::k, ::k], points, residual, rmse, verdict_status(verdict), check_rmse,
                          size=(photo.shape[1], photo.shape[0]), others=None if checks is None else checks.uv)
    _draw_checks(ax_photo, camera, checks, labels)
    # the photo's frame: a residual arrow (×10) is cut at its edge, not given room beyond it (a trial's ran off)
    ax_photo.set_xlim(0, photo.shape[1])
    ax_photo.set_ylim(photo.shape[0], 0)
    picture = None if picture is None else np.asarray(picture, dtype=bool)
    ground_xyz = xyz if picture is None else np.where(picture[..., None], xyz, np.nan)
    _draw_overlay(ax_overlay, photo[::k, ::k], xyz[::k, ::k], None if picture is None else picture[::k, ::k],
                  size=(photo.shape[1], photo.shape[0]))
    _draw_footprint(ax_map, camera, dem, visible, points)
    _draw_parameters(ax_text, camera, sigmas, rmse, points, ground_xyz, verdict, check_rmse, checks, accuracy,
                     picture=picture)
    import io

    page = io.BytesIO()  # rendered in memory: matplotlib's own errors on a full disk hide the cause
    fig.savefig(page, format=fmt, dpi=150)
    with atomic_output(target, overwrite, verify=image_verifier(fmt)) as tmp:
        with open(tmp, "wb") as fh:  # OSError (disk full...) is said in words by atomic_output
            fh.write(page.getbuffer())
    return target


def _crs_label(crs_wkt: str) -> str:
    from ._gdal import crs_authid

    return crs_authid(crs_wkt) or "CRS without identifier"


#: badge colours of the fit's statuses (the dock's: green, amber, red)
STATUS_COLOURS = {"ok": "#1a7f37", "uncertain": "#b35900", "poor": "#c62828", "refused": "#c62828"}


def verdict_status(verdict: str) -> str:
    """The status word a verdict ``"status: message"`` starts with ("" when none).

    >>> verdict_status("uncertain: unpaired fit ..."), verdict_status("")
    ('uncertain', '')
    """
    head = verdict.split(":", 1)[0].strip()
    return head if head in STATUS_COLOURS else ""


def verdict_first(verdict: str) -> str:
    """The verdict with its judgement first ("Uncertain: ..." / "Probably wrong: ...", then the figures, as the dock
    shows it: :func:`~..core.fit.result.verdict_first`): cut to fit the page, it keeps why (a long automatic verdict
    lost its reason at the bottom of the page).

    >>> verdict_first("uncertain: paired fit on 9 pairs: RMSE 2.0 px. Uncertain: the pairs cover 1 %.")
    'Fit status uncertain. Uncertain: the pairs cover 1 %. Figures: paired fit on 9 pairs: RMSE 2.0 px.'
    """
    status = verdict_status(verdict)
    message = verdict.split(":", 1)[1].strip() if status else verdict
    judgement, figures = judgement_first(message)
    if figures:
        return f"Fit status {status}. {judgement} Figures: {figures}"
    return f"Fit status {status}: {message}" if status else f"Fit status {message}"


#: Up to this many control points every one is named on the report's photo; beyond it only those whose name has room.
ALL_LABELS_UP_TO = 40


def _draw_points(ax, photo, points, residual, rmse, status="", check_rmse=None, size=None, others=None):
    """The photo (maybe a shrunk copy of a picture of ``size`` (W, H) px: the points stay in its pixels) with the
    control points, their reprojections and residuals, and the status badge. Returns the :class:`_Labels` holding
    the names drawn (``others``: (K, 2) more points, e.g. check points, their names are not to cover)."""
    w, h = size or (photo.shape[1], photo.shape[0])
    ax.imshow(photo, cmap="gray" if photo.ndim == 2 else None, interpolation="antialiased", extent=(0, w, h, 0))
    has_points = points is not None and residual is not None
    ax.set_title("Control points: picked (○), reprojected (+), residuals ×10" if has_points else
                 "The photo (no control points given)", fontsize=9, loc="left")
    if has_points:
        uv = points.uv
        ax.scatter(uv[:, 0], uv[:, 1], s=40, facecolors="none", edgecolors="yellow", linewidths=1.2)
        proj = uv + residual
        ax.scatter(proj[:, 0], proj[:, 1], s=30, marker="+", color="red", linewidths=1.2)
        ax.quiver(uv[:, 0], uv[:, 1], residual[:, 0] * 10, residual[:, 1] * 10, angles="xy", scale_units="xy",
                  scale=1, color="red", width=0.003)
        if rmse is not None:  # the status first, in its colour: an "uncertain" camera must not read as fine
            # the check points' error leads when there are some, as in the dock: the fit's own RMSE is how well
            # its points agree (a trial's badge said "RMSE 5.25 px", the check points 17.2 px)
            figures = f"check points {check_rmse:.2f} px · fit RMSE {rmse:.2f} px" if check_rmse is not None \
                else f"RMSE {rmse:.2f} px"
            # under the photo, outside it: on it, it covered a print's caption (at the bottom, a re-check trial) or
            # its peaks and sky (at the top, a trial)
            ax.text(0.0, -0.015, (f"{status} · " if status else "") + figures, transform=ax.transAxes,
                    color="white", fontsize=9, va="top", weight="bold" if status else "normal",
                    bbox=dict(facecolor=STATUS_COLOURS.get(status, "black"), alpha=0.85 if status else 0.5,
                              edgecolor="none"))
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_aspect("equal", adjustable="box")  # the axes shrink to the photo: nothing drawn beyond its edges
    ax.axis("off")
    # names last, placed where the axes' final scale puts them
    shown = [points.uv] if has_points else []
    if others is not None:
        shown.append(np.asarray(others, dtype=np.float64).reshape(-1, 2))
    labels = _Labels(ax, np.vstack(shown) if shown else np.zeros((0, 2)))
    if has_points:
        crowded = len(points.uv) > ALL_LABELS_UP_TO
        # the largest residuals named first (the text lists them by name); past ALL_LABELS_UP_TO points a name
        # that would cover another is left out (a trial's automatic registration: 333 names over each other)
        order = np.argsort(-np.hypot(*np.nan_to_num(residual, nan=0.0).T), kind="stable") if crowded else \
            range(len(points.uv))
        for i in order:
            labels.add(str(points.names[i]), points.uv[i, 0], points.uv[i, 1], "yellow", only_if_free=crowded)
    return labels


def _checks_rmse(camera, checks: Optional[ReportPoints]) -> Optional[float]:
    """RMSE (px) of the check points under ``camera`` (those it can project), None without any."""
    if checks is None or not len(checks.uv):
        return None
    residual = camera.project(checks.xyz) - checks.uv
    residual = residual[np.isfinite(residual).all(axis=1)]
    return float(np.sqrt(np.mean(np.sum(residual ** 2, axis=1)))) if len(residual) else None


def _draw_checks(ax, camera, checks: Optional[ReportPoints], labels: Optional[_Labels] = None) -> None:
    """Check points on the photo (magenta squares, their reprojections and residuals ×10); their names kept clear
    of those in ``labels`` (:func:`_draw_points`'; None: of these alone)."""
    if checks is None or not len(checks.uv):
        return
    residual = camera.project(checks.xyz) - checks.uv
    ok = np.isfinite(residual).all(axis=1)
    uv, residual = checks.uv[ok], residual[ok]
    if not len(uv):
        return
    ax.set_title(ax.get_title(loc="left") + "; check points (□, magenta)", fontsize=9, loc="left")
    ax.scatter(uv[:, 0], uv[:, 1], s=40, marker="s", facecolors="none", edgecolors="magenta", linewidths=1.2)
    ax.quiver(uv[:, 0], uv[:, 1], residual[:, 0] * 10, residual[:, 1] * 10, angles="xy", scale_units="xy", scale=1,
              color="magenta", width=0.003)
    if checks.named:  # their own names (numbers would repeat the control points'); a re-check trial's had none
        labels = _Labels(ax, uv) if labels is None else labels
        for name, (u, v) in zip(np.asarray(checks.names, dtype=object)[ok], uv):
            # a GCP table's numbers would repeat the control points' (a trial read two "3"s): C3
            text = f"C{name}" if str(name).isdigit() else str(name)
            labels.add(text, u, v, CHECK_LABEL_COLOUR)


def _draw_overlay(ax, photo, xyz, picture=None, size=None):
    """Contours and skyline of ``xyz`` over the photo, inside ``picture`` ((H, W) bool, None: everywhere): a print's
    border and caption get neither (left out of the ground, they are no sky either). All three may be a shrunk copy
    (every k-th pixel) of a picture of ``size`` (W, H) px."""
    w, h = size or (photo.shape[1], photo.shape[0])
    k = w / photo.shape[1]
    ax.imshow(photo, cmap="gray" if photo.ndim == 2 else None, alpha=0.8, extent=(0, w, h, 0))
    outside = np.zeros(xyz.shape[:2], dtype=bool) if picture is None else ~picture
    ground = np.ma.masked_where(outside, np.isfinite(xyz[..., 2]).astype(float))
    z = np.where(outside, np.nan, xyz[..., 2])
    ax.set_title("DEM seen from the camera: contours and skyline", fontsize=9, loc="left")
    if np.isfinite(z).any():
        lo, hi = np.nanpercentile(z, [1, 99])
        step = _nice_step((hi - lo) / 12.0)
        levels = np.arange(math.floor(lo / step) * step, hi + step, step)
        centres = (np.arange(z.shape[1]) + 0.5) * k, (np.arange(z.shape[0]) + 0.5) * k
        contours = ax.contour(*centres, np.ma.masked_invalid(z), levels=levels, cmap="terrain", linewidths=0.6)
        ax.clabel(contours, levels[::3], fontsize=5, fmt="%d")
        ax.contour(*centres, ground, levels=[0.5], colors="red", linewidths=1.0)  # skyline
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_aspect("equal", adjustable="box")  # the axes shrink to the photo: nothing drawn beyond its edges
    ax.axis("off")


def _nice_step(raw: float) -> float:
    """A 1-2-5 step of at least ``raw``.

    >>> _nice_step(130.0), _nice_step(7.0)
    (200.0, 10.0)
    """
    if not raw > 0:
        return 1.0
    power = 10 ** math.floor(math.log10(raw))
    for m in (1, 2, 5, 10):
        if m * power >= raw:
            return float(m * power)
    return float(10 * power)


def _draw_footprint(ax, camera, dem, visible, points):
    xmin, ymin, xmax, ymax = dem.bounds()
    extent = (xmin, xmax, ymin, ymax)
    north_up = dem.geotransform[2] == 0 and dem.geotransform[4] == 0
    ax.set_title("Footprint: cells the camera sees", fontsize=9, loc="left")
    if north_up:
        k = max(1, math.ceil(max(dem.shape) / PAGE_PIXELS))  # a 25 M-cell DEM shaded whole: GBs for a small map
        gt = dem.geotransform
        shade = dem if k == 1 else Dem.from_array(dem.elevation[::k, ::k],
                                                  (gt[0], gt[1] * k, 0.0, gt[3], 0.0, gt[5] * k), dem.crs_wkt)
        ax.imshow(shade.hillshade(), cmap="gray", extent=extent, interpolation="nearest")
        if visible is not None and visible.any():
            seen = visible[::k, ::k] if k > 1 else visible
            ax.imshow(np.ma.masked_where(~seen, seen.astype(float)), cmap="autumn", alpha=0.45,
                      extent=extent, interpolation="nearest", vmin=0, vmax=1)
    cx, cy, _ = camera.position
    ax.plot([cx], [cy], marker="^", color="blue", markersize=7)
    reach = 0.35 * max(xmax - xmin, ymax - ymin)
    for angle in (camera.heading - camera.fov / 2, camera.heading + camera.fov / 2):
        a = math.radians(angle)
        ax.plot([cx, cx + reach * math.sin(a)], [cy, cy + reach * math.cos(a)], color="blue", lw=0.8)
    if points is not None:
        ax.scatter(points.xyz[:, 0], points.xyz[:, 1], s=12, color="yellow", edgecolors="black", linewidths=0.4)
    ax.set_xlim(min(xmin, cx), max(xmax, cx))
    ax.set_ylim(min(ymin, cy), max(ymax, cy))
    ax.set_aspect("equal")
    ax.tick_params(labelsize=6)
    ax.ticklabel_format(useOffset=False, style="plain")
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(4))  # seven-digit eastings: more labels would run into each other


def parameter_lines(camera, sigmas, status: str = "") -> List[str]:
    """The camera block of the report, one parameter a line. The heading is an azimuth in [0, 360), as the dock
    shows it (a fit may return -63.6 for 296.4). Under a fit ``status`` "uncertain" or "poor" each ± is starred and
    a line says they may understate the error, as the dock's (a trial's report: "heading 245.71 ± 0.51°", 15° off)."""
    doubt, sigmas, params = status in ("uncertain", "poor"), sigmas or {}, camera.parameters()
    star = "*" if doubt else ""
    lines = ["Camera (pinhole; angles in degrees: heading clockwise from grid north, pitch above horizontal)", ""]
    for name in ("x", "y", "z", "heading", "pitch", "roll", "fov", "cx", "cy", "k1", "k2"):
        value = params[name]
        if name == "heading":
            value = azimuth(value)
        if name in ("k1", "k2") and value == 0.0:
            continue
        sigma = sigmas.get(name)
        fmt = "{:.2f}" if name in ("x", "y", "z") else "{:.1f}" if name in ("cx", "cy") else "{:.4f}"
        if sigma is not None and not np.isnan(sigma) and sigma_undetermined(name, sigma):  # the unit with the value
            lines.append(f"  {name:<8} {fmt.format(value):>14} {_UNITS[name]} (± undetermined)")
            continue
        if sigma is None or np.isnan(sigma) or sigma <= 0:
            lines.append(f"  {name:<8} {fmt.format(value):>14} {_UNITS[name]}")
            continue
        # to the σ's second significant digit, no further: "x 650130.09 ± 627 m" and "heading 296.4389 ± 2.94°"
        # claimed a precision the σ denies (a trial)
        decimals = min(max(0, 1 - math.floor(math.log10(sigma))), 2 if name in ("x", "y", "z") else 4)
        lines.append(f"  {name:<8} {value:>14.{decimals}f} ± {round(sigma, decimals):.{decimals}f}{star} "
                     f"{_UNITS[name]}")
    lines.append(f"  focal    {camera.focal_px:>14.2f} px")
    if doubt and any("±" in line and "undetermined" not in line for line in lines):
        lines.append(f"  * The ± assume the fit's pairs are right: this {status} camera may be off by far more.")
    return lines


#: The last line of a verdict cut to fit the page, saying where the rest is (a trial: lost)
CUT_NOTE = "… (cut to fit the page: the whole text is in the camera's JSON file and the dock's fit tab)"
#: Lines of 8 pt text the page's bottom block holds (0.24 of an A4 page's height).
REPORT_TEXT_LINES = 24


def largest_residuals(camera, points: ReportPoints, n: int = 5) -> str:
    """The points the camera misses most, by the names on the photo (a reader could not tell which point had
    the 13 px residual from the arrows alone).

    >>> from monoplot_plugin.core.camera import Camera
    >>> cam = Camera((0, 0, 0), 0, 0, 0, 90, (200, 100))
    >>> xyz = np.array([[0.0, 10.0, 0.0], [1.0, 10.0, 0.0], [-2.0, 10.0, 1.0]])
    >>> largest_residuals(cam, ReportPoints(cam.project(xyz) + [[0, 3], [0, 0], [4, 0]], xyz, ["a", "b", "c"]))
    'Largest residuals: c (4.0 px), a (3.0 px), b (0.0 px)'
    """
    size = np.hypot(*(camera.project(points.xyz) - points.uv).T)
    order = [i for i in np.argsort(-np.nan_to_num(size, nan=-1.0)) if np.isfinite(size[i])][:n]
    return "Largest residuals: " + ", ".join(f"{points.names[i]} ({size[i]:.1f} px)" for i in order)


def _draw_parameters(ax, camera, sigmas, rmse, points, xyz, verdict="", check_rmse=None, checks=None, accuracy="",
                     picture=None):
    import textwrap

    ax.axis("off")
    lines = parameter_lines(camera, sigmas, verdict_status(verdict))
    lines.append("")
    if check_rmse is not None:  # the measured accuracy first: independent of the fit
        lines.append(f"Check points (magenta, kept out of the fit): RMSE {check_rmse:.2f} px on {len(checks.uv)}")
    if rmse is not None:
        lines.append(f"Reprojection RMSE {rmse:.2f} px on {len(points.uv)} points "
                     f"(σ: 1 standard deviation from the fit's covariance)")
        lines.append(largest_residuals(camera, points))
    ground = np.isfinite(xyz[..., 2])
    if ground.any():
        dist = np.linalg.norm(xyz[ground] - np.asarray(camera.position), axis=1)
        # a print's share is of its picture, not of the scan with its paper (63 % for the picture's 84 %: a trial)
        share = ground[picture].mean() if picture is not None and picture.shape == ground.shape and picture.any() \
            else ground.mean()
        lines.append(f"Ground seen in {100 * share:.0f} % of the {'picture' if picture is not None else 'pixels'}, "
                     f"{dist.min() / 1000:.1f} to {dist.max() / 1000:.1f} km from the camera")
    if accuracy:
        lines += textwrap.wrap(f"Ground accuracy: {accuracy}", 110)
    if verdict:
        lines.append("")
        wrapped = textwrap.wrap(verdict_first(verdict), 110)
        room = REPORT_TEXT_LINES - len(lines)  # a long automatic verdict ran off the bottom of the page
        if len(wrapped) > room:
            wrapped = wrapped[:max(1, room - 1)] + [CUT_NOTE]
        lines += wrapped
    ax.text(0.0, 1.0, "\n".join(lines), va="top", ha="left", family="monospace", fontsize=8,
            transform=ax.transAxes)
