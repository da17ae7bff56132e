"""What independent check points say of a camera: the rule that their RMSE beyond the fit's own residuals lowers it,
and the verdict of a camera nobody fitted here (loaded from a file, or the automatic registration's) from them."""

from __future__ import annotations

from typing import Tuple

import numpy as np

__all__ = ["CHECK_OVER_RESIDUALS", "PAIRED_CHECK_FLOOR_SHARE", "CHECK_FLOOR_PX", "POOR_SHARE", "WEAK_SHARE",
           "MIN_CHECKS", "checks_beyond_residuals", "judge_by_checks"]

#: check points more than this many times the fit's own RMSE off (and over 0.5 % of the picture) make it uncertain:
#: a person's clicks on check points err by about as much as on the fitted points, not several times more
CHECK_OVER_RESIDUALS = 3.0
#: ... over 0.2 % of the picture and 5 px for a paired fit, whose residuals are every pair's, not only those of the
#: matches within an inlier radius (a drone trial: one near GCP's surveyed height 2 m off, check points 20.3 px on a
#: 1.8 px fit, under 0.5 % of its 5000 px diagonal: "ok" with the camera 15.7 m off and its near ground 16.5 m)
PAIRED_CHECK_FLOOR_SHARE, CHECK_FLOOR_PX = 0.002, 5.0
#: shares of the picture's diagonal: residuals or check points beyond POOR_SHARE make a fit poor; check points beyond
#: WEAK_SHARE make it uncertain (and within it, with at least MIN_CHECKS of them, they verify it)
POOR_SHARE, WEAK_SHARE, MIN_CHECKS = 0.03, 0.015, 4


def checks_beyond_residuals(check_rmse_px: float, rmse_px: float, diag: float, paired: bool = False) -> bool:
    """True when check points are off by more than :data:`CHECK_OVER_RESIDUALS` times the camera's own residuals
    ``rmse_px`` (at least 1 px) and by more than 0.5 % of the diagonal ``diag`` (``paired``: 0.2 % and 5 px,
    :data:`PAIRED_CHECK_FLOOR_SHARE`): the residuals flatter the camera.

    >>> checks_beyond_residuals(50.3, 7.7, 5000.0), checks_beyond_residuals(20.0, 7.7, 5000.0)
    (True, False)
    >>> checks_beyond_residuals(20.3, 1.8, 5000.0), checks_beyond_residuals(20.3, 1.8, 5000.0, paired=True)
    (False, True)
    >>> checks_beyond_residuals(6.4, 0.9, 5000.0, paired=True), checks_beyond_residuals(4.5, 1.2, 1000.0, True)
    (False, False)
    >>> checks_beyond_residuals(50.3, float("nan"), 5000.0)
    False
    """
    floor = max(PAIRED_CHECK_FLOOR_SHARE * diag, CHECK_FLOOR_PX) if paired else 0.005 * diag
    return bool(np.isfinite(check_rmse_px) and np.isfinite(rmse_px)
                and check_rmse_px > CHECK_OVER_RESIDUALS * max(rmse_px, 1.0) and check_rmse_px > floor)


def judge_by_checks(check_rmse_px: float, n_check: int, diag: float,
                    rmse_px: float = float("nan"), paired: bool = False) -> Tuple[str, str]:
    """(status, message) of a camera nobody fitted here (loaded from a file) or the automatic registration's, from
    its independent check points: "ok" only when at least :data:`MIN_CHECKS` of them agree as a fit's would;
    without them it is unverified. With the camera's own residuals ``rmse_px`` (the automatic registration's
    matched pairs), check points beyond 1.5 % of the picture and :data:`CHECK_OVER_RESIDUALS` times them make it
    "poor", as they make a fit (a desktop trial: Find camera said "uncertain" with check points at 28.6 px, 13
    times its residuals; Fit on the same points at once said "poor").

    >>> judge_by_checks(float("nan"), 0, 1000.0)[0], judge_by_checks(4.0, 6, 1000.0)[0]
    ('uncertain', 'ok')
    >>> judge_by_checks(40.0, 6, 1000.0)[0], judge_by_checks(4.0, 2, 1000.0)[0]
    ('poor', 'uncertain')
    >>> judge_by_checks(20.0, 6, 1000.0)[0], judge_by_checks(20.0, 6, 1000.0, rmse_px=2.0)[0]
    ('uncertain', 'poor')
    >>> judge_by_checks(10.0, 6, 1000.0)[0], judge_by_checks(10.0, 6, 1000.0, rmse_px=2.0)[0]  # under 1.5 %
    ('ok', 'uncertain')
    """
    if not n_check or not np.isfinite(check_rmse_px):
        return "uncertain", ("Not checked: this camera was not fitted here and no check points measure it. Mark "
                             f"{MIN_CHECKS} or more pairs as check points (key C), or fit it again.")
    text = f"Check points: {check_rmse_px:.1f} px on {n_check}."
    if check_rmse_px > POOR_SHARE * diag:
        return "poor", text + " Probably wrong: the independent check points disagree with the camera."
    far = checks_beyond_residuals(check_rmse_px, rmse_px, diag, paired)
    if check_rmse_px > WEAK_SHARE * diag:
        if far:
            return "poor", text + (f" Probably wrong: the independent check points are off by {check_rmse_px:.1f} "
                                   f"px, {check_rmse_px / max(rmse_px, 1.0):.0f} times the camera's residuals.")
        return "uncertain", text + " Uncertain: the check points are off by more than 1.5 % of the picture."
    if far:  # as a fit judges them: a drone trial's 8 surveyed check points at 50 px, a 7.7 px fit, stayed "ok"
        return "uncertain", text + (f" Uncertain: the check points are off by {check_rmse_px:.1f} px, "
                                    f"{check_rmse_px / max(rmse_px, 1.0):.0f} times the camera's residuals: the "
                                    f"camera is less accurate than its residuals say; add points near the check "
                                    f"points or pair a few.")
    if n_check < MIN_CHECKS:
        return "uncertain", text + f" Uncertain: too few check points to verify it ({MIN_CHECKS} at least)."
    return "ok", text
