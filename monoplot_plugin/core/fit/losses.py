"""The losses and nearest-point helpers of the unpaired fit: the paper's loss, its smoothed version, mutual
nearest neighbours.

All distances are in pixels; photo points ``q`` are (N, 2), projected DEM points (M, 2).
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

__all__ = ["unpaired_loss", "soft_nearest_loss", "mutual_nearest_pairs", "nearest_distances", "nearest_index"]


def unpaired_loss(image_points, projected, usable, lam: float, eps: float = 1e-3, robust_px: Optional[float] = None):
    """Mean nearest distance from each photo point to the usable projected points + ``lam`` * squared centroid gap.

    Args:
        image_points: (N, 2) torch tensor, pixels.
        projected: (M, 2) torch tensor, projected world points (pixels).
        usable: (M,) bool tensor: points in front of the camera and inside the image (+ margin).
        lam: centroid weight (1 / pixel).
        eps: pixels; smooths the distance at zero so gradients stay finite.
        robust_px: None = the paper's loss. Else each distance ``d`` becomes ``c tanh(d / c)`` with ``c =
            robust_px``: unchanged for close points, saturating for far ones, so photo points without a DEM
            counterpart (a wrongly accepted suggestion) stop pulling once they are a few ``c`` away.
    Returns:
        (loss, nearest): 0-d tensor (pixels) and (N,) nearest distances (detached).
    """
    import torch

    candidates = projected[usable]
    if candidates.shape[0] == 0:
        raise ValueError("no DEM point projects into the picture")
    # The gradient of a minimum is that of its arg-minimum: find it without autograd (cheap), then differentiate
    # only the N chosen distances instead of the whole N x M matrix.
    index = nearest_index(image_points, candidates)
    delta = image_points - candidates[index]
    nearest = torch.sqrt(delta.square().sum(dim=1) + eps * eps)
    if robust_px is not None and math.isfinite(robust_px):
        per_point = robust_px * torch.tanh(nearest / robust_px)
    else:
        per_point = nearest
    centroid_gap = image_points.mean(dim=0) - candidates.mean(dim=0)
    loss = per_point.mean() + lam * centroid_gap.square().sum()
    return loss, nearest.detach()


def nearest_index(points, candidates):
    """(N,) torch long index of the nearest of the (M, 2) ``candidates`` to each of the (N, 2) ``points`` (torch
    tensors, no gradient): a k-d tree, so large sets cost (N + M) log M instead of an N x M distance matrix.

    >>> import torch
    >>> nearest_index(torch.tensor([[0.0, 0], [9, 9]]), torch.tensor([[10.0, 10], [1, 0]])).tolist()
    [1, 0]
    """
    import torch
    from scipy.spatial import cKDTree

    with torch.no_grad():
        _, index = cKDTree(candidates.detach().numpy()).query(points.detach().numpy())
    return torch.as_tensor(np.asarray(index, dtype=np.int64))


def soft_nearest_loss(image_points, candidates, sigma: float, neighbours: int = 32):
    """Smoothed mean nearest distance (pixels): ``-sigma * log(sum_j exp(-d_ij^2 / (2 sigma^2)))`` per photo point,
    a soft minimum of the squared distances at scale ``sigma`` (pixels), expressed as a distance, averaged.

    It tends to the paper's nearest distance as ``sigma -> 0`` and is smooth at larger scales (coarse-to-fine).
    With more than ``2 * neighbours`` candidates the sum runs over each photo point's ``neighbours`` nearest only
    (the others weigh nothing at these scales), which keeps large sets linear in size.
    """
    import torch

    if candidates.shape[0] > 2 * neighbours:
        from scipy.spatial import cKDTree

        with torch.no_grad():
            _, index = cKDTree(candidates.detach().numpy()).query(image_points.detach().numpy(), k=neighbours)
        near = candidates[torch.as_tensor(index, dtype=torch.int64)]  # (N, k, 2)
        d2 = (image_points[:, None, :] - near).square().sum(dim=2)
    else:
        d2 = torch.cdist(image_points, candidates).square()
    soft_d2 = -2.0 * sigma * sigma * torch.logsumexp(-d2 / (2.0 * sigma * sigma), dim=1)
    return torch.sqrt(soft_d2.clamp(min=0.0) + 1e-6).mean()


def mutual_nearest_pairs(image_points: np.ndarray, projected: np.ndarray, usable: np.ndarray,
                         gate_px: float) -> np.ndarray:
    """(K, 2) int pairs (image index, world index) that are each other's nearest neighbour within ``gate_px``.

    >>> mutual_nearest_pairs(np.array([[0.0, 0], [10, 0]]), np.array([[1.0, 0], [50, 0], [10, 1]]),
    ...                      np.array([True, True, True]), 3.0).tolist()
    [[0, 0], [1, 2]]
    """
    idx = np.flatnonzero(usable)
    if len(idx) == 0 or len(image_points) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    from scipy.spatial import cKDTree

    proj = projected[idx]
    d_iw, j = cKDTree(proj).query(image_points)
    _, i_back = cKDTree(image_points).query(proj)
    rows = np.arange(len(image_points))
    mutual = (i_back[j] == rows) & (d_iw <= gate_px)
    return np.stack([rows[mutual], idx[j[mutual]]], axis=1).astype(np.int64)


def nearest_distances(q: np.ndarray, uv: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """(N,) distance from each photo point to the nearest usable projected point (inf when none)."""
    if not usable.any():
        return np.full(len(q), np.inf)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(uv[usable]).query(q)
    return d
