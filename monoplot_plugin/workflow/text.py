"""Messages: cut to fit where they are shown (the dock's status line, a row of the batch log), points named, a
fit's figures in a line."""

from __future__ import annotations

import math
import re
from typing import Iterable, Optional, Tuple

__all__ = ["cut_at_word", "name_photo_pixels", "fit_figures_text", "lens_advice"]

#: Share of the lens's field of view a doubtful fit may move it before :func:`lens_advice` speaks (the EXIF lens
#: is searched within 4 % by Find camera).
LENS_FOV_MOVED = 0.03


def cut_at_word(text: str, limit: int) -> str:
    """``text`` cut at a word before ``limit`` characters, with an ellipsis.

    >>> cut_at_word("short", 12), cut_at_word("one two three four", 12)
    ('short', 'one two …')
    """
    if len(text) <= limit:
        return text
    cut = text.rfind(" ", 0, limit - 1)
    return text[:cut if cut > 0 else limit - 1].rstrip() + " …"


def name_photo_pixels(message: str, named: Iterable[Tuple[float, float, str]], tolerance_px: float = 1.0) -> str:
    """``message`` with each "photo pixel (u, v)" it quotes followed by the name of the point there (``named``:
    (u, v, name) of the person's named points, e.g. a GCP table's ids), within ``tolerance_px``: a trial's message
    said "check the pair at photo pixel (1100, 650)" where her table called that point GCP4.

    >>> name_photo_pixels("first check the pair at photo pixel (1100, 650): left out", [(1100.2, 649.6, "GCP4")])
    'first check the pair at photo pixel (1100, 650), GCP4: left out'
    >>> name_photo_pixels("at photo pixel (10, 20)", [(400.0, 20.0, "GCP1")])
    'at photo pixel (10, 20)'
    """
    named = [(float(u), float(v), str(name)) for u, v, name in named if name]

    def with_name(match):
        u, v = float(match.group(1)), float(match.group(2))
        near = [(abs(nu - u) + abs(nv - v), name) for nu, nv, name in named
                if abs(nu - u) <= tolerance_px and abs(nv - v) <= tolerance_px]
        return match.group(0) + (f", {min(near)[1]}" if near else "")

    return re.sub(r"photo pixel \((-?\d+(?:\.\d+)?), (-?\d+(?:\.\d+)?)\)", with_name, message)


def fit_figures_text(verdict: dict) -> str:
    """How sure an "ok" row's camera is, for its batch log line: the leave-one-out RMSE and the check points' (a
    trial's "ok" rows read only "fit RMSE 0.99 px", their 3 check points' 1.83 px in no column or file).

    >>> fit_figures_text({"summary": {"loo_rmse_px": 1.234}, "check_rmse_px": 1.83, "n_check": 3})
    ', leave-one-out 1.23 px, 3 check points 1.83 px'
    >>> fit_figures_text({"check_rmse_px": float("nan"), "n_check": 0})
    ', no check points'
    """
    loo = (verdict.get("summary") or {}).get("loo_rmse_px")
    text = f", leave-one-out {loo:.2f} px" if loo is not None and math.isfinite(loo) else ""
    check, n = verdict.get("check_rmse_px"), int(verdict.get("n_check") or 0)
    if n and check is not None and math.isfinite(check):
        return text + f", {n} check point{'s' if n > 1 else ''} {check:.2f} px"
    return text + ", no check points"


def lens_advice(fitted_fov: float, lens_fov: Optional[float], status: str, free: Iterable[str]) -> str:
    """What to do when a doubtful fit moved the field of view away from the photo's lens (EXIF): hold it there. A
    flood trial's fits traded the field of view against the distance along the view (+3.5°, the camera 184 m
    forward); held at the lens's, the camera was 26 m off, and nothing had said so. "" when there is nothing to say.

    >>> lens_advice(69.0, 65.3, "uncertain", ["x", "fov"])[:52]
    ' The field of view moved from the lens (65.3°, from '
    >>> lens_advice(65.5, 65.3, "uncertain", ["fov"]), lens_advice(69.0, 65.3, "ok", ["fov"])
    ('', '')
    """
    if status == "ok" or "fov" not in set(free) or lens_fov is None or not math.isfinite(lens_fov):
        return ""
    if abs(fitted_fov - lens_fov) <= max(1.0, LENS_FOV_MOVED * lens_fov):
        return ""
    return (f" The field of view moved from the lens ({lens_fov:.1f}°, from the photo's EXIF) to {fitted_fov:.1f}°: "
            f"when the points cannot tell the field of view from the distance, hold it at the lens's (untick field "
            f"of view in the fit settings) and fit again, unless the photo was cropped or zoomed digitally.")
