"""Messages cut to fit where they are shown (the dock's status line, a row of the batch log)."""

from __future__ import annotations

import re
from typing import Iterable, Tuple

__all__ = ["cut_at_word", "name_photo_pixels"]


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
