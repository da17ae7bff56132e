"""What the dock says about drawn features on the map: the parts over the sky, the paper or off the DEM left out
(:func:`sky_text`), and how far a feature's ground position can be trusted along it (:func:`spread_note`): where
one photo pixel spans much more ground than elsewhere on the feature (far or grazing terrain), a click a pixel off
moves it that far. A flood analyst's line drawn from 8 m above a floodplain was 5 m off near the camera and 910 m
off 1.3 km away, under a camera 9 m from the truth, and nothing said so."""

from __future__ import annotations

from typing import Callable, Iterable, Optional, Sequence, Set, Tuple

__all__ = ["spread_note", "sky_text", "kind_names", "doubt_note", "SPREAD_RATIO"]

#: A feature is reported when one photo pixel spans this many times more ground at its worst place than along it
#: (median): a part of it lies on far or grazing terrain.
SPREAD_RATIO = 5.0


def _metres(value: float) -> str:
    """Metres to two significant digits at most (a flood trial read "8.6 m of ground (0.0 m along most of it)").

    >>> [_metres(v) for v in (910.0, 8.63, 0.043, 0.002)]
    ['910 m', '8.6 m', '0.043 m', 'under 0.01 m']
    """
    if value >= 10:
        return f"{value:.0f} m"
    if value >= 1:
        return f"{value:.1f} m"
    return f"{value:.2g} m" if value >= 0.01 else "under 0.01 m"


def spread_note(kind_name: str, spans: Iterable[Tuple[int, Optional[float], Optional[float]]], told: Set[tuple],
                tr: Callable[[str], str] = str) -> str:
    """One sentence about the drawn feature with the widest ground per pixel that is not told yet ("" if none).

    Args:
        kind_name: "Drawn lines"... for the sentence.
        spans: (photo fid, median, largest) ground metres per photo pixel of each feature
            (:func:`~..workflow.features.ground_per_pixel`).
        told: (fid, largest rounded) already told; updated.

    >>> told = set()
    >>> spread_note("Drawn lines", [(1, 0.4, 2.0), (2, 3.0, 910.0)], told)[:62]
    'Drawn lines: part of one lies where a photo pixel spans 910 m '
    >>> spread_note("Drawn lines", [(1, 0.4, 2.0), (2, 3.0, 910.0)], told)
    ''
    """
    wide = [(fid, med, big) for fid, med, big in spans
            if med is not None and big is not None and big >= SPREAD_RATIO * max(med, 1e-6)
            and (fid, round(big)) not in told]
    if not wide:
        return ""
    told.update((fid, round(big)) for fid, _, big in wide)
    _, med, big = max(wide, key=lambda s: s[2])
    return tr("{0}: part of one lies where a photo pixel spans {1} of ground ({2} along most of it): far or "
              "grazing terrain, where a click one pixel off moves it that far. Fields m_per_px and m_px_max "
              "keep both for every feature.").format(kind_name, _metres(big), _metres(med))


def doubt_note(told: dict, kind: str, camera, count: int, status: str, tr: Callable[[str], str] = str) -> str:
    """" Drawn on a camera whose fit is "poor": ..." the first time a feature is drawn under a camera its fit does
    not call ok (a trial's polygon on a "poor" camera 481 m off got an area and no word; the orthophoto and report
    warn, drawing did not); "" else.

    Args:
        told: kind -> (camera, features drawn when it was first seen, told); updated.
        camera: the fitted camera (any comparable value). count: features of ``kind`` drawn now.
        status: the fit's verdict.

    >>> told = {}
    >>> doubt_note(told, "line", "cam", 0, "poor"), doubt_note(told, "line", "cam", 1, "poor")[:38]
    ('', ' Drawn on a camera whose fit is "poor"')
    >>> doubt_note(told, "polygon", "cam", 1, "poor")  # once per camera, whatever is drawn next
    ''
    """
    told_camera, base, done = told.get(kind, (None, 0, False))
    if told_camera != camera:  # another camera: its drawings are news again
        base, done = 0, False
    told[kind] = (camera, base, done or (count > base and status in ("uncertain", "poor")))
    if done or count <= base or status not in ("uncertain", "poor"):
        return ""
    # once per camera, whatever is drawn next (a trial got it for its polygon, then again for its line)
    if any(c == camera and t for k, (c, _, t) in told.items() if k != kind):
        return ""
    return " " + tr("Drawn on a camera whose fit is \"{0}\": its map positions inherit the camera's errors (no "
                    "xy_error_m, z_error_m). Check the fit (pairs, check points) before using them."
                    ).format(tr(status))


def kind_names(tr: Callable[[str], str] = str) -> dict:
    return {"point": tr("Drawn points"), "line": tr("Drawn lines"), "polygon": tr("Drawn polygons")}


def sky_text(kind: str, sky: int, dropped: int, crossings: int = 0, paper: bool = False,
             dropped_at: Sequence[Tuple[float, float]] = (), tr: Callable[[str], str] = str) -> str:
    """What the user is told when drawn features (partly) see the sky, or polygons cross a silhouette (a desktop
    trial: a polygon drawn across ridges enclosed 11.3 km² of which 1.6 km² were seen, and nothing said so):
    only the counts that are not zero (a point has no "pieces"). ``paper``: the photo is a scanned print (its
    paper is no ground); ``dropped_at``: photo pixels where the features left off start.

    >>> sky_text("line", 2, 0)
    'Drawn lines: 2 part(s) over the sky, a DEM void or off the DEM left out of the map layer.'
    """
    parts = []
    if sky:
        # "or off the DEM": a trial's water line touched no sky, its part past the DEM's edge was the one
        parts.append((tr("{0} part(s) over the sky, the print's paper, a DEM void or off the DEM left out of the map "
                         "layer") if paper
                      else tr("{0} part(s) over the sky, a DEM void or off the DEM left out of the map layer"))
                     .format(sky))
    if dropped:
        parts.append((tr("{0} entirely over the sky, the paper, a DEM void or off the DEM, not on the map layer")
                      if paper else tr("{0} entirely over the sky, a DEM void or off the DEM, not on the map layer"))
                     .format(dropped) + _where_dropped(dropped_at, tr))
    if crossings:
        parts.append(tr("the outlines cross a ridge's silhouette {0} time(s): there they enclose ground the photo "
                        "does not show, and the area counts it (field silhouette)").format(crossings))
    return tr("{0}: {1}.").format(kind_names(tr).get(kind, kind), "; ".join(parts))


def _where_dropped(where: Sequence[Tuple[float, float]], tr: Callable[[str], str]) -> str:
    """" (at photo pixel (300, 40))": where the features left off start (a trial could not tell which of 9 points
    had no place on the map); "" when unknown."""
    if not where:
        return ""
    shown = ", ".join(f"({u:.0f}, {v:.0f})" for u, v in where[:3]) + (", …" if len(where) > 3 else "")
    return " " + tr("(at photo pixel {0})").format(shown) if len(where) == 1 else \
        " " + tr("(starting at photo pixels {0})").format(shown)
