"""Options of one camera fit, in one place: :class:`FitOptions`.

>>> FitOptions().consensus, FitOptions(robust=False).robust_px(1000.0)
(True, None)
>>> round(FitOptions().robust_px(1000.0), 1)   # 6 % of the image diagonal
60.0
>>> opts = FitOptions(angle_sigma_deg=2.0)
>>> opts.prior_sigmas(fov=50.0, typical_range=4000.0)
{'position_m': 200.0, 'angle_deg': 2.0, 'fov_deg': 5.0}
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Dict, Optional, Union

__all__ = ["FitOptions"]


@dataclass
class FitOptions:
    """Every tuning knob of :func:`~monoplot_plugin.core.fit.fit_camera` (its keyword arguments of the same names).

    The prior's uncertainty (what the user states about the rough camera; ``None`` = the default):
        position_sigma_m: metres, one σ of the rough position (default 100 m or 5 % of the distance to the
            points, whichever is more).
        angle_sigma_deg: degrees, one σ of heading and pitch (default 5°; roll gets half of it).
        fov_sigma_deg: degrees, one σ of the horizontal field of view (default 10 % of it).

    Unpaired mode, the paper's descent (a stage of the search, not the judge):
        n_starts, n_escapes: most starts and basin escapes of the multi-start descent.
        view_margin: fraction of the image size around it within which projected DEM points still count.
        gate_px: pairing gate in pixels (None: adaptive).
        refine: two-sided refinement, automatic pairing and robust least squares after the descent.
        coarse: a coarse-to-fine pass on a smoothed nearest distance before the paper's loss.
        robust: True = saturating distances at 6 % of the diagonal; a number = that scale in pixels; False/None =
            the paper's loss exactly.
        centroid_weight: factor on the paper's adaptive centroid weight in the first descent.
        time_budget_s: no new start begins after this many seconds of CPU time (the process's, so that the result
            does not depend on the machine's load).
        switch_ratio: another start replaces the initial camera's descent only below this ratio of its score.
        consensus: also search camera hypotheses drawn from the prior's uncertainty (minimal two-point solves
            verified by their mutual-nearest inliers) and keep whichever camera the consensus score prefers.
        consensus_hypotheses: most minimal-set hypotheses scored by the consensus search.
        consensus_starts: how many starts are aligned and optimised: the stated camera and the best hypotheses.
        bootstrap: resamplings of the inlier pairs for the σ of an unpaired fit (0 = Jacobian only).
        seed: random seed (results are deterministic for a given seed).
    """

    n_starts: int = 2
    n_escapes: int = 1
    view_margin: float = 0.1
    gate_px: Optional[float] = None
    refine: bool = True
    coarse: bool = True
    robust: Union[bool, float, None] = True
    centroid_weight: float = 1.0
    time_budget_s: float = 8.0
    switch_ratio: float = 0.8
    consensus: bool = True
    consensus_hypotheses: int = 4000
    consensus_starts: int = 8
    bootstrap: int = 20
    position_sigma_m: Optional[float] = None
    angle_sigma_deg: Optional[float] = None
    fov_sigma_deg: Optional[float] = None
    seed: int = 0

    @classmethod
    def names(cls):
        return tuple(f.name for f in fields(cls))

    def robust_px(self, diag: float) -> Optional[float]:
        """Saturation scale of the paper's distances in pixels, or None for the paper's loss exactly."""
        if self.robust is None or self.robust is False:
            return None
        return 0.06 * diag if self.robust is True else float(self.robust)

    def prior_sigmas(self, fov: float, typical_range: float) -> Dict[str, float]:
        """The prior's one-σ uncertainty with the defaults filled in (metres and degrees)."""
        position = max(100.0, 0.05 * typical_range) if self.position_sigma_m is None else self.position_sigma_m
        return {"position_m": float(position),
                "angle_deg": float(5.0 if self.angle_sigma_deg is None else self.angle_sigma_deg),
                "fov_deg": float(0.1 * fov if self.fov_sigma_deg is None else self.fov_sigma_deg)}

    def held_sigmas(self, free) -> Dict[str, float]:
        """One σ (metres, degrees) of the camera parameters not in ``free`` whose accuracy the user stated (a
        position fixed at its surveyed value, ± 1 m): their error goes into the free parameters' σ
        (:func:`~.lsq.parameter_uncertainty`); a parameter whose σ is the default is held exactly.

        >>> FitOptions(position_sigma_m=1.0, angle_sigma_deg=2.0).held_sigmas(("heading", "pitch", "roll", "fov"))
        {'x': 1.0, 'y': 1.0, 'z': 1.0}
        >>> FitOptions(angle_sigma_deg=2.0).held_sigmas(("x", "y", "z", "fov"))
        {'heading': 2.0, 'pitch': 2.0, 'roll': 1.0}
        """
        stated = {"x": self.position_sigma_m, "y": self.position_sigma_m, "z": self.position_sigma_m,
                  "heading": self.angle_sigma_deg, "pitch": self.angle_sigma_deg,
                  "roll": None if self.angle_sigma_deg is None else 0.5 * self.angle_sigma_deg,
                  "fov": self.fov_sigma_deg}
        return {n: float(v) for n, v in stated.items() if n not in set(free) and v is not None and v > 0}

    def prior_sigma_px(self, camera, typical_range: float) -> float:
        """One σ (pixels, along each image axis) of where the rough ``camera`` puts a point ``typical_range``
        metres away: the prior's angle, position and field-of-view uncertainty (:meth:`prior_sigmas`) through its
        lens (the field of view's at a quarter of the width from the centre).

        >>> from monoplot_plugin.core.camera import Camera
        >>> cam = Camera((0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 60.0, (1000, 700))
        >>> round(FitOptions().prior_sigma_px(cam, 4000.0)), round(FitOptions(angle_sigma_deg=1.0,
        ...     position_sigma_m=10.0, fov_sigma_deg=0.5).prior_sigma_px(cam, 4000.0))
        (92, 15)
        """
        s = self.prior_sigmas(camera.fov, typical_range)
        f = camera.focal_px
        angle = f * math.radians(s["angle_deg"])
        position = f * s["position_m"] / max(float(typical_range), 1.0)
        fov = 0.25 * camera.width * math.radians(s["fov_deg"]) / math.sin(math.radians(min(camera.fov, 179.0)))
        return math.sqrt(angle ** 2 + position ** 2 + fov ** 2)
