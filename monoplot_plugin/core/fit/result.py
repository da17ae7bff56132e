"""What a fit returns: :class:`FitResult`, and the two RMS helpers every stage uses."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np

from ..camera import Camera

__all__ = ["FitResult", "STATUSES", "rmse", "rms", "check_bound_px", "CHECK_CONFIDENCE", "worst_check",
           "worst_check_words", "sigma_undetermined", "sigma_pixels", "sigma_shifts", "sigma_cameras", "combine_moves",
           "verdict_first", "VERDICT_MARKERS", "LEAD_MARKER"]

#: Standard deviations beyond which a parameter is not determined at all (a poor fit's covariance gave "± 1300521642
#: m" and "± 6894594°" in a flood trial's dock): angles in degrees, positions in metres, the rest in their units.
UNDETERMINED_ABOVE = {"heading": 90.0, "pitch": 90.0, "roll": 90.0, "fov": 90.0, "x": 1e5, "y": 1e5, "z": 1e5}


def sigma_undetermined(name: str, value: float) -> bool:
    """True when the σ ``value`` of parameter ``name`` says the parameter is not determined (infinite, NaN or beyond
    :data:`UNDETERMINED_ABOVE`; 1e5 of its units for the others): show "undetermined", not the number.

    >>> sigma_undetermined("heading", 6894594.0), sigma_undetermined("x", 39.0), sigma_undetermined("k1", 1e9)
    (True, False, True)
    """
    return not value < UNDETERMINED_ABOVE.get(name, 1e5)


def sigma_pixels(camera: Camera, std: Dict[str, float], points: np.ndarray) -> float:
    """The camera's uncertainty as a pixel error: RMS over ``points`` ((N, 3) map coordinates, the terrain the fit
    used) of where each one moves in the picture when every parameter moves by its σ (``std``, by the names of
    :data:`~..camera.PARAMETER_NAMES`), added in quadrature. NaN without points or σ, or with a σ undetermined.

    The σ are taken as independent: parameters the points trade against each other (distance against field of
    view) are counted each in full, so the figure is an upper estimate. An unpaired fit's residuals measure how
    well its automatic pairs agree, not its accuracy (measured 2026-12-06: on Aletsch with the simulated curation
    11.1 px RMS over the 11 GCPs, which are 9.5 px off, the paired optimum itself 7.7 px, where the leave-one-out
    said 3.8 px; on the 148 "ok" fits of the synthetic suite the camera's error on the terrain was 0.16 of it at
    the median, 0.33 at the 90th percentile, within it in 98.6 % and within twice it in all).

    >>> cam = Camera((0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 60.0, (1000, 700))
    >>> round(sigma_pixels(cam, {"heading": 0.1}, np.array([[0.0, 4000.0, 0.0]])), 2)   # f tan(0.1°)
    1.51
    """
    shift = sigma_shifts(camera, std, points)
    finite = np.isfinite(shift)
    return float(np.sqrt(np.mean(shift[finite] ** 2))) if finite.any() else float("nan")


def sigma_shifts(camera: Camera, std: Dict[str, float], points: np.ndarray,
                 correlation: Optional[Dict[str, Dict[str, float]]] = None,
                 ground: Optional[Callable] = None) -> np.ndarray:
    """(N,) pixels each of ``points`` ((N, 3) map coordinates) moves in the picture when every parameter moves by
    its σ (``std``), added in quadrature (see :func:`sigma_pixels`); all NaN without σ or with one undetermined.

    With ``correlation`` (``{name: {other: r}}``, :attr:`FitResult.correlation`) the moves are combined as the
    covariance ``D R D`` says (``D`` the σ, ``R`` the correlations; a pair missing counts as uncorrelated): the
    point's σ in the picture. Far points that fixed the camera then move little, near ground a camera slid along its
    view moves a lot. ``ground``: a callable ``(x, y) -> z`` for a camera held on the ground (``z`` not fitted):
    its height then follows the terrain when x or y move (a camera slid 8.5 m back along a slope also rose 4 m,
    which moved the ground 30 m in front of it by 150 px).

    >>> cam = Camera((0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 60.0, (1000, 700))
    >>> sigma_shifts(cam, {"x": 10.0}, np.array([[0.0, 100.0, 0.0], [0.0, 1000.0, 0.0]])).round(1).tolist()
    [86.6, 8.7]
    >>> far_fixed = {"x": {"heading": -1.0}, "heading": {"x": -1.0}}   # moved right, turned left: 1 km stays put
    >>> std = {"x": 10.0, "heading": 0.573}
    >>> sigma_shifts(cam, std, np.array([[0.0, 100.0, 0.0], [0.0, 1000.0, 0.0]]), far_fixed).round(1).tolist()
    [77.9, 0.0]
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    moved = sigma_cameras(camera, std, ground)
    if not len(points) or not moved:
        return np.full(len(points), np.nan)
    base = camera.project(points)
    return combine_moves({name: cam.project(points) - base for name, cam in moved.items()}, correlation)


def sigma_cameras(camera: Camera, std: Dict[str, float], ground: Optional[Callable] = None) -> Dict[str, Camera]:
    """``{name: camera}``: ``camera`` with one parameter moved by its σ (``std``), for each parameter it has; with
    ``ground`` (``(x, y) -> z``, a camera held on the ground: ``z`` not in ``std``) its height follows the terrain
    when x or y move. {} without σ, with one undetermined (:func:`sigma_undetermined`, either way), or when a move
    by σ is no camera (a field of view beyond 0-180°).

    >>> cam = Camera((0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 60.0, (1000, 700))
    >>> moved = sigma_cameras(cam, {"x": 10.0, "heading": 0.5}, ground=lambda x, y: 0.1 * np.asarray(x))
    >>> [float(v) for v in moved["x"].position], moved["heading"].heading
    ([10.0, 0.0, 1.0], 0.5)
    >>> sigma_cameras(cam, {"fov": -475.0}), sigma_cameras(cam, {"fov": -70.0})
    ({}, {})
    """
    usable = {k: float(v) for k, v in (std or {}).items() if v}
    # by size: moved back by σ (negative) a field of view of 79.5° ± 475° is no camera (a trial's cursor raised at
    # every move of the mouse over the photo)
    if not usable or any(sigma_undetermined(k, abs(v)) for k, v in usable.items()):
        return {}
    values = camera.parameters()

    def height(x: float, y: float) -> float:
        return float(np.asarray(ground(np.array([x]), np.array([y]))).ravel()[0])

    def moved(name):
        change = {name: values[name] + usable[name]}
        if ground is not None and name in ("x", "y") and "z" not in usable:
            lift = height(change.get("x", values["x"]), change.get("y", values["y"])) - height(values["x"],
                                                                                               values["y"])
            if np.isfinite(lift):
                change["z"] = values["z"] + lift
        return camera.with_parameters(**change)

    try:
        return {name: moved(name) for name in usable if name in values}
    except ValueError:  # a move by σ leaves the cameras possible (a field of view of 60° ± 89° moved back): none
        return {}


def combine_moves(moves: Dict[str, np.ndarray], correlation: Optional[Dict[str, Dict[str, float]]] = None
                  ) -> np.ndarray:
    """(N,) length of the combined move of N things (pixels, ground points) when each parameter's σ moves them by
    ``moves[name]`` ((N, D) each): ``sqrt(sum_ab r_ab m_a . m_b)``, the ``D R D`` covariance with ``correlation``
    (``{a: {b: r}}``; a pair missing counts as uncorrelated).

    >>> m = {"x": np.array([[3.0, 0.0]]), "heading": np.array([[-3.0, 0.0]])}
    >>> combine_moves(m).round(2).tolist(), combine_moves(m, {"x": {"heading": 1.0}, "heading": {"x": 1.0}}).tolist()
    ([4.24], [0.0])
    """
    names = list(moves)
    n = len(next(iter(moves.values()))) if moves else 0
    shift2 = np.zeros(n)
    for i, a in enumerate(names):
        for j, b in enumerate(names):
            r = 1.0 if i == j else float((correlation or {}).get(a, {}).get(b, 0.0))
            if r:
                shift2 += r * np.sum(moves[a] * moves[b], axis=1)
    return np.sqrt(np.clip(shift2, 0.0, None))


#: Every status a fit can end with, from best to worst; only "ok" means the evidence supports the camera.
STATUSES = ("ok", "uncertain", "poor", "refused", "canceled")


@dataclass
class FitResult:
    """What :func:`fit_camera` found.

    Attributes:
        camera: the fitted camera (``initial`` unchanged when refused; the best so far when canceled).
        status: one of :data:`STATUSES`: "ok" (the evidence supports the camera), "uncertain" (fitted, but some
            evidence is weak: the message says which and what to add), "poor" (probably wrong), "refused"
            (degenerate or invalid input: nothing fitted), "canceled". See :mod:`~monoplot_plugin.core.fit.verdict`.
        message: human-readable sentences: the figures, then for a status other than "ok" why and what to do.
        mode: "paired" or "unpaired".
        free: names of the parameters that were fitted.
        rmse_px: RMSE (pixels) of the pairs used by the final fit (the user's pairs, or the automatic pairs of the
            unpaired mode); for an unpaired fit without enough pairs, the RMS nearest distance. NaN when refused.
        pairs: (K, 2) int array of (image index, world index) used by the final fit.
        residuals_px: (K, 2) projected minus observed pixel of each pair.
        inliers: (K,) bool, False for automatic pairs rejected as outliers (always True in paired mode).
        nearest_px: (N,) distance from each photo point to the nearest projected in-view DEM point (unpaired mode;
            in paired mode, the pair residual norm of each photo point, NaN for unpaired ones).
        std: standard deviation of each fitted parameter (its units: metres, degrees, pixels), from the Jacobian
            of the final least-squares fit; empty when it could not be computed.
        correlation: the fitted parameters' correlations ``{name: {other: r}}`` from the same covariance (empty
            when it could not be computed): with ``std`` the camera's covariance (:func:`sigma_shifts`).
        loo_rmse_px: leave-one-out RMSE over the pairs (each pair predicted by a fit without it), NaN if too few.
        loo_residuals_px: (K,) leave-one-out error of each pair (pixels).
        check_rmse_px / check_residuals_px: RMSE and (C, 2) residuals on the independent check points, if given.
        loss_history: the unpaired loss (pixels) after every L-BFGS round of every start, then the pairs' RMSE
            after every robust refinement; for plotting convergence.
        evidence: the figures the verdict judged (inliers, chance level, competing camera, spread, Jacobian
            condition, ...; see :func:`~monoplot_plugin.core.fit.verdict.judge`).
        photo_outliers: (N,) bool, accepted photo points the fitted camera explains by no DEM point (unpaired mode;
            shown red so that the person can reject them; none when the fit is "poor": a camera that is probably
            wrong cannot tell which points are).
        n_starts: how many starts the multi-start tried.
        elapsed_s: wall time of the fit.
    """

    camera: Camera
    status: str
    message: str
    mode: str
    free: Tuple[str, ...] = ()
    rmse_px: float = float("nan")
    pairs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    residuals_px: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    inliers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    nearest_px: np.ndarray = field(default_factory=lambda: np.zeros(0))
    std: Dict[str, float] = field(default_factory=dict)
    loo_rmse_px: float = float("nan")
    loo_residuals_px: np.ndarray = field(default_factory=lambda: np.zeros(0))
    check_rmse_px: float = float("nan")
    check_residuals_px: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    loss_history: List[float] = field(default_factory=list)
    evidence: Dict[str, object] = field(default_factory=dict)
    photo_outliers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    n_starts: int = 0
    elapsed_s: float = 0.0
    correlation: Dict[str, Dict[str, float]] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def summary(self) -> dict:
        """JSON-friendly digest (numbers rounded) for logs and reports."""
        def r(x, n=3):
            return None if x is None or not np.isfinite(x) else round(float(x), n)

        return {"status": self.status, "mode": self.mode, "message": self.message, "rmse_px": r(self.rmse_px),
                "loo_rmse_px": r(self.loo_rmse_px), "check_rmse_px": r(self.check_rmse_px),
                "pairs": int(len(self.pairs)), "inliers": int(self.inliers.sum()), "free": list(self.free),
                "std": {k: r(v, 4) for k, v in self.std.items()}, "n_starts": self.n_starts,
                "correlation": {a: {b: r(v, 4) for b, v in row.items()} for a, row in self.correlation.items()},
                "elapsed_s": r(self.elapsed_s), "photo_outliers": int(np.sum(self.photo_outliers)),
                "evidence": {k: (r(v) if isinstance(v, float) else v) for k, v in self.evidence.items()},
                "camera": self.camera.to_dict()}


def rmse(residuals: np.ndarray) -> float:
    residuals = np.asarray(residuals, dtype=np.float64).reshape(-1, 2)
    if len(residuals) == 0:
        return float("nan")
    return float(np.sqrt(np.mean(np.sum(residuals ** 2, axis=1))))


def rms(values) -> float:
    values = np.asarray(values, dtype=np.float64)
    values = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(values ** 2))) if len(values) else float("nan")


#: Confidence of :func:`check_bound_px`: the share of cameras whose error its bound covers, were the check points
#: drawn at random over the terrain the camera sees.
CHECK_CONFIDENCE = 0.95


def check_bound_px(rmse_px: Optional[float], n_check: int) -> float:
    """What ``n_check`` check points whose RMSE is ``rmse_px`` (pixels) say the camera's pixel error is at most:
    the RMSE over the lower :data:`CHECK_CONFIDENCE` quantile of its spread for that many points (their 2 n
    residuals taken as normal: the mean square over chi-square with 2 n degrees of freedom). NaN without a finite
    RMSE or without check points.

    Few check points can say far less than the camera is off: a desktop trial's 3 said 2.4 px where the camera was
    5.3 px off; 3 points give 1.9 times their RMSE, 11 points 1.3 times. On the 147 "ok" fits of the synthetic
    suite, 3-11 check points drawn at random (with the scene's click noise): the camera's error within this bound in
    99-100 % over the true points, 98-99 % over the whole terrain seen (2026-12-07).

    >>> round(check_bound_px(10.0, 3), 1), round(check_bound_px(10.0, 11), 1), check_bound_px(None, 0)
    (19.2, 13.4, nan)
    """
    if rmse_px is None or not n_check or not np.isfinite(rmse_px):
        return float("nan")
    from scipy.stats import chi2

    dof = 2 * int(n_check)
    return float(rmse_px) * float(np.sqrt(dof / chi2.ppf(1.0 - CHECK_CONFIDENCE, dof)))


#: A check point whose error is this many times the others' RMS (at least 3 others) is named by the verdict.
CHECK_STANDS_OUT = 5.0


def worst_check(residuals_px: np.ndarray, uv: np.ndarray, world: np.ndarray, position) -> dict:
    """Evidence on the check point that stands out: ``check_worst_uv`` (its pixel), ``check_worst_px`` (its error),
    ``check_others_px`` (the others' RMSE) and ``check_worst_m`` (its distance from the camera), when its error is
    :data:`CHECK_STANDS_OUT` times the others' RMS or more, with 3 others at least; {} otherwise. A flood trial's
    one check point 24 m from the camera, its map position 0.7 m off (114 px even under the true camera), made a
    camera 1.6 m from the truth "poor", and nothing said which point.

    >>> r = np.array([[0.5, 0.0], [3.0, 0.0], [0.0, 5.7], [169.0, 0.0]])
    >>> uv, world = np.zeros((4, 2)) + [[10, 20]], np.array([[0, 300.0, 0]] * 3 + [[0, 24.0, 0]])
    >>> {k: round(v, 1) if isinstance(v, float) else v for k, v in worst_check(r, uv, world, (0, 0, 0)).items()}
    {'check_worst_uv': (10.0, 20.0), 'check_worst_px': 169.0, 'check_others_px': 3.7, 'check_worst_m': 24.0}
    >>> worst_check(r[:3], uv[:3], world[:3], (0, 0, 0))
    {}
    """
    errors = np.hypot(*np.asarray(residuals_px, dtype=np.float64).reshape(-1, 2).T)
    if len(errors) < 4 or not np.isfinite(errors).all():
        return {}
    i = int(np.argmax(errors))
    others = float(np.sqrt(np.mean(np.delete(errors, i) ** 2)))
    if errors[i] < CHECK_STANDS_OUT * max(others, 1.0):
        return {}
    return {"check_worst_uv": (float(uv[i][0]), float(uv[i][1])), "check_worst_px": float(errors[i]),
            "check_others_px": others,
            "check_worst_m": float(np.linalg.norm(np.asarray(world[i], dtype=np.float64) - np.asarray(position)))}


def worst_check_words(e: dict) -> str:
    """" (one of them, at pixel (u, v) and D m from the camera, is off by X px, the others Y px: ...)" for the check
    point that stands out (evidence of :func:`worst_check`), said by the verdict with what it says of the check
    points (a flood trial's one near check point made a right camera "poor" and nothing said which); "" without.

    >>> worst_check_words({"check_worst_uv": (10.0, 20.0), "check_worst_px": 169.0, "check_others_px": 3.7,
    ...                    "check_worst_m": 24.0})[:66]
    ' (one of them, at pixel (10, 20) and 24 m from the camera, is off '
    >>> worst_check_words({})
    ''
    """
    if "check_worst_px" not in e:
        return ""
    u, v = e["check_worst_uv"]
    return (f" (one of them, at pixel ({u:.0f}, {v:.0f}) and {e['check_worst_m']:.0f} m from the camera, is off by "
            f"{e['check_worst_px']:.0f} px, the others {e['check_others_px']:.1f} px: check its map position, which "
            f"near the camera moves it by many pixels a metre, or unmark it)")


#: Where a verdict's own words start in a fit's message (core.fit.verdict and core.auto.register write them after
#: the fit's figures: "unpaired fit: 76 of 153 ... Uncertain: the photo shows no clear skyline ...").
VERDICT_MARKERS = ("Probably wrong: ", "Uncertain: ")


#: the start of a message whose first sentence goes before the verdict (:func:`verdict_first`; the workflow's
#: ``auto._every_direction`` writes it)
LEAD_MARKER = "Every direction searched:"


def verdict_first(message: str) -> tuple:
    """(the verdict's reasons and what follows them, the figures before them) of a fit's message; the dock shows the
    first part first: a desktop trial's "uncertain" registration said why only after 600 characters of figures.

    >>> verdict_first("unpaired fit: 76 of 153 matched. Automatic: skyline on 9 %. Uncertain: no clear skyline.")
    ('Uncertain: no clear skyline.', 'unpaired fit: 76 of 153 matched. Automatic: skyline on 9 %.')
    >>> verdict_first("Probably wrong: only 12 % of the skyline lies on the DEM's. Also: few points.")
    ("Probably wrong: only 12 % of the skyline lies on the DEM's. Also: few points.", '')
    >>> verdict_first("The automatic registration did not improve on the prior camera.")
    ('The automatic registration did not improve on the prior camera.', '')

    A registration that searched every direction says so first (a re-check trial's dock showed it last, under a
    paragraph of reasons, for a camera now looking 177° from the rough one):

    >>> verdict_first("Every direction searched: this view fits better (0.13). unpaired fit: 9 matched. Uncertain: x.")
    ('Every direction searched: this view fits better (0.13). Uncertain: x.', 'unpaired fit: 9 matched.')
    """
    if message.startswith(LEAD_MARKER) and ". " in message:
        lead, rest = message.split(". ", 1)
        verdict, details = verdict_first(rest)
        return f"{lead}. {verdict}".strip(), details
    found = [i for i in (message.find(m) for m in VERDICT_MARKERS) if i >= 0]
    if not found or min(found) == 0:
        return message.strip(), ""
    i = min(found)
    return message[i:].strip(), message[:i].strip()
