"""Camera fit: find the camera that projects DEM points onto photo points, with or without known pairs.

Two modes, one entry point, :func:`fit_camera`:

Unpaired (the paper's method, the default when ``pairs`` is None). Photo points ``q_i`` (N of them) and DEM points
``P_j`` (M of them, N and M may differ, no correspondence known). With ``p_j`` the projection of ``P_j``, the loss is::

    L = mean_i min_j |q_i - p_j|  +  lambda * |mean_i q_i - mean_j p_j|^2

minimised with PyTorch autograd (L-BFGS). ``lambda`` is adaptive: ``lambda = rho / diag`` with ``diag`` the image
diagonal in pixels and ``rho = D / (D + 0.02 diag)`` where ``D`` is the current mean nearest distance, so the
centroid term dominates while the projection is far from the points and vanishes near convergence (where the
centroids of two unequal point sets need not coincide). DEM points behind the camera or projecting outside the
image (plus a margin) take part in neither term: out-of-view points must not attract the fit.

With ``robust=False, coarse=False, n_starts=1, n_escapes=0, refine=False`` :func:`fit_camera` is exactly that.
The defaults differ where measurements said so (eval/aletsch.py): each distance saturates (``robust``,
:func:`unpaired_loss`), and when the first descent leaves many photo points unmatched, the initial camera is tried
again *without* the centroid term (with a few wrongly accepted points the centroids of the two sets differ and the
term pulls the camera away: 1 % of the rejected Aletsch suggestions added moved the fit 200 px off with it, 12 px
without), then the other starts.

Then, beyond the paper (the package's modules):

1. multi-start and basin escape: when the first descent leaves many photo points without a close DEM point, other
   starts around the initial camera (heading, pitch, field of view, position) are tried and the best kept (judged by
   a truncated nearest-distance score, robust to unmatched points);
2. automatic pairing: mutual nearest neighbours within a gate, refined by robust least squares (``soft_l1`` loss)
   with outlier rejection, re-paired until the pairs stop changing; in unpaired mode the camera then converges on
   every mutual-nearest pair within the consensus inlier radius (Cauchy loss at that scale,
   :func:`~.pairing.converge_on_pairs`): cutting the pairs at a few σ biased it where a coarse DEM gives true pairs
   a long tail of residuals;
3. paired mode (``pairs`` given): PnP / DLT starts, then Levenberg-Marquardt;
4. any subset of parameters free (``free``), others kept from ``initial``;
5. camera on the ground (``ground`` callable or :class:`~monoplot_plugin.core.dem.Dem`): ``z`` is the terrain
   height under the camera plus ``eye_height``, one unknown less;
6. under-determined and degenerate problems (duplicated or collinear points) are refused with a message saying
   what to add (:mod:`.checks`, :mod:`.verdict`);
7. consensus registration (:mod:`.consensus`, :mod:`.unpaired`): camera hypotheses drawn from the prior's
   uncertainty (``position_sigma_m``, ``angle_sigma_deg``, ``fov_sigma_deg``), solved from two correspondences,
   verified by how many photo points they explain; the paper's loss is a stage, not the judge;
8. an honest verdict (:mod:`.verdict`): "ok", "uncertain", "poor" or "refused" from the inliers against chance,
   competing cameras, spread, the Jacobian and check points; σ from the covariance and a bootstrap.

Modules: :mod:`.options` (:class:`FitOptions`), :mod:`.context` (one fit's state), :mod:`.params` (parameter
vectors), :mod:`.losses`, :mod:`.starts`, :mod:`.descent`, :mod:`.consensus`, :mod:`.pairing`, :mod:`.paired`,
:mod:`.lsq`, :mod:`.verdict`, :mod:`.result`.

Accuracy is reported on points not used by the fit when given (``check_image_points``/``check_world_points``)
and always as leave-one-out over the pairs (a fit to few points can look perfect and be far off elsewhere).

Coordinates: everything is computed centred on the initial camera's position (float64), see
:mod:`monoplot_plugin.core.fit.params`.
"""

from .api import fit_camera
from .context import FitCanceled
from .losses import mutual_nearest_pairs, soft_nearest_loss, unpaired_loss
from .options import FitOptions
from .params import DEFAULT_FREE, ParameterSpace
from .result import (STATUSES, FitResult, check_bound_px, combine_moves, sigma_cameras, sigma_pixels, sigma_shifts,
                     sigma_undetermined)

__all__ = ["FitResult", "FitOptions", "FitCanceled", "STATUSES", "fit_camera", "unpaired_loss",
           "soft_nearest_loss", "mutual_nearest_pairs", "DEFAULT_FREE", "ParameterSpace", "sigma_undetermined",
           "sigma_pixels", "sigma_shifts", "check_bound_px", "sigma_cameras", "combine_moves"]
