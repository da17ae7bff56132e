"""σ of an automatic registration that covers what the automatic pairs alone do not see.

The final fit's σ (:mod:`~monoplot_plugin.core.fit`) comes from pairs drawn near the aligned camera: they agree
with it, right or wrong, and give a heading σ of a few hundredths of a degree on a camera degrees off. Three things
the registration knows widen it, each parameter to the largest:

- the edge alignment's own covariance: the robust Gauss-Newton normal matrix of its residuals
  (:meth:`~.align.Aligner.residuals`) scaled by their weighted variance, with the skyline's columns counted as
  :data:`INDEPENDENT_PER_1024` independent pieces per 1024 columns (neighbouring columns see the same ridge; counted
  one by one they would claim a precision the photo does not have);
- the difference between the aligned camera and the fitted one (two estimates from different evidence);
- the difference to every other refined hypothesis whose edge score is within :data:`RIVAL_RATIO` of the best (the
  photo's edges do not tell them apart).

>>> widen_std({"heading": 0.01}, {"heading": 0.0, "x": 5.0}, [{"heading": 0.5, "x": 0.0}], {"heading": 0.02})
{'heading': 0.5, 'x': 5.0}
"""

from __future__ import annotations

import math

import numpy as np

from .align import NAMES, Aligner

__all__ = ["edge_std", "widen_std", "carry_correlated", "camera_values", "RIVAL_RATIO", "INDEPENDENT_PER_1024"]

#: Independent pieces of skyline per 1024 working columns (the correlation length of the skyline residuals).
INDEPENDENT_PER_1024 = 32.0
#: A refined hypothesis whose edge score is at most this many times the best one's counts as a rival.
RIVAL_RATIO = 1.25
#: Offsets names (:data:`.align.NAMES`) to camera parameter names.
PARAM = {"heading": "heading", "pitch": "pitch", "roll": "roll", "fov": "fov", "x": "x", "y": "y", "z": "z"}


def camera_values(camera) -> dict:
    """The seven searched parameters of ``camera`` by name."""
    p = camera.parameters()
    return {name: float(p[PARAM[name]]) for name in NAMES}


def edge_std(al: Aligner, offset) -> dict:
    """σ of the seven parameters from the edge alignment ``al`` at ``offset`` (see the module's docstring); an
    empty dict when the residuals cannot give one."""
    x = np.asarray(offset, dtype=np.float64)
    h = np.array([0.01, 0.01, 0.01, 0.01, 0.5, 0.5, 0.5])
    r = al.residuals(np.vstack([x[None], x[None] + np.diag(h)]))
    if r.shape[1] <= 7:
        return {}
    J = (r[1:] - r[0][None, :]).T / h[None, :]
    w = 1.0 / (1.0 + (r[0] / al.tau) ** 2)
    dof = float(w.sum()) - 7.0
    if dof <= 0:
        return {}
    s2 = float(np.sum(w * r[0] ** 2)) / dof
    A = (J * w[:, None]).T @ J
    try:
        cov = np.linalg.pinv(A + 1e-12 * np.eye(7) * np.trace(A))
    except np.linalg.LinAlgError:
        return {}
    # residuals counted one per column: only about INDEPENDENT_PER_1024 per 1024 columns are independent
    pieces = INDEPENDENT_PER_1024 * al.photo.width / 1024.0
    inflate = max(1.0, float(r.shape[1]) / pieces)
    var = np.clip(np.diag(cov), 0.0, None) * s2 * inflate
    # a camera on the ground: its height follows the terrain, the edges do not measure it
    return {name: float(math.sqrt(v)) for name, v in zip(NAMES, var)
            if np.isfinite(v) and not (name == "z" and getattr(al, "ground", None) is not None)}


def widen_std(std: dict, found: dict, others: list, edge: dict) -> dict:
    """``std`` widened to the edge alignment's σ ``edge`` and to the distance from ``found`` (the parameters
    returned, :func:`camera_values`) to each of ``others`` (the aligned camera, rival hypotheses)."""
    out = dict(std)
    for name, value in edge.items():
        out[name] = max(out.get(name, 0.0), value)
    for other in others:
        for name, value in found.items():
            d = abs(other[name] - value)
            if name == "heading":
                d = abs((other[name] - value + 180.0) % 360.0 - 180.0)
            out[name] = max(out.get(name, 0.0), d)
    return out


def carry_correlated(before: dict, widened: dict, correlation: dict) -> dict:
    """``widened`` (σ by name, from ``before``) with the parameters correlated to a widened one widened along: the
    fit's Gaussian stretched along that parameter, the others following their regression on it, so a parameter of
    σ ``s`` and correlation ``r`` with a parameter widened ``k`` times gets ``s sqrt(1 + r² (k² - 1))``; the
    largest over the widened parameters, each taken alone (X and Y are often almost collinear, and a joint
    regression on both is then ill-posed). A position widened alone to the prior's σ left a camera 216 m aside
    with its heading ± 1.2°, 5.4° off (an archive trial's print): the heading the fit found belongs to where it put
    the camera, and moves with it.

    >>> out = carry_correlated({"x": 5.0, "heading": 0.1, "fov": 0.2}, {"x": 50.0, "heading": 0.1, "fov": 0.2},
    ...                        {"x": {"heading": -0.9, "fov": 0.0}})
    >>> {name: round(value, 2) for name, value in out.items()}
    {'x': 50.0, 'heading': 0.9, 'fov': 0.2}
    """
    out = dict(widened)
    for p, new in widened.items():
        old = float(before.get(p) or 0.0)
        if not (old > 0.0 and math.isfinite(new) and new > old):
            continue
        for q, r in ((correlation or {}).get(p) or {}).items():
            s = float(before.get(q) or 0.0)
            if q == p or q not in out or not (math.isfinite(float(r)) and s > 0.0):
                continue
            out[q] = max(out[q], s * math.sqrt(1.0 + float(r) ** 2 * ((new / old) ** 2 - 1.0)))
    return out
