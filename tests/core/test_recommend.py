"""core/recommend.py: the spread ranking, the bucketed nearest search against brute force, the likely pairs."""

from __future__ import annotations

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.recommend import agreement, likely_pairs, nearest, priority, spread_order


def brute_nearest(q, r, radius):
    d = np.linalg.norm(q[:, None, :] - r[None, :, :], axis=2)
    d[~np.isfinite(d)] = np.inf
    j, dm = d.argmin(axis=1), d.min(axis=1)
    return np.where(dm <= radius, j, -1), np.where(dm <= radius, dm, np.inf)


@pytest.mark.parametrize("radius", [3.0, 40.0, 500.0])
@pytest.mark.parametrize("n, m", [(800, 900), (50, 3000), (2000, 20)])
def test_nearest_matches_brute_force(radius, n, m):
    rng = np.random.default_rng(int(radius) + n)
    q = rng.uniform(0, 1000, (n, 2))
    r = rng.uniform(-50, 1050, (m, 2))
    r[::11] = np.nan  # points the camera does not see
    i, d = nearest(q, r, radius)
    bi, bd = brute_nearest(q, r, radius)
    assert np.array_equal(i >= 0, bi >= 0)
    np.testing.assert_allclose(d[i >= 0], bd[bi >= 0])
    assert np.all(np.isfinite(r[i[i >= 0]]).all(axis=1))


def test_spread_order_puts_every_first_page_point_in_its_own_region():
    rng = np.random.default_rng(1)
    # strong points crowd one corner: a plain strength ranking would show only that corner
    crowd = rng.uniform(0, 100, (500, 2))
    rest = rng.uniform(0, 1000, (500, 2))
    xy = np.vstack([crowd, rest])
    score = np.r_[rng.uniform(10, 11, 500), rng.uniform(0, 1, 500)]
    order = spread_order(xy, score, per_page=25)
    assert sorted(order.tolist()) == list(range(1000))
    first = xy[order[:25]]
    assert (first < 100).all(axis=1).sum() <= 2  # the crowded corner gets about its share, not the page
    cells = {(int(x // 200), int(y // 200)) for x, y in first}
    assert len(cells) >= 20  # 25 cells of 200 x 200: the page covers the view
    # within the crowded corner, the strongest comes first
    corner = [k for k in order if k < 500]
    assert score[corner[0]] == score[:500].max()


def test_priority_prefers_agreement_then_strength():
    score = np.array([5.0, 1.0, 3.0, 2.0])
    dist = np.array([np.inf, 1.0, np.inf, 6.0])
    key = priority(score, dist, sigma=5.0)
    assert np.argsort(-key).tolist() == [1, 3, 0, 2]  # close partner, far partner, then by strength


def test_likely_pairs_of_a_camera_find_the_true_correspondences():
    cam = Camera((0.0, 0.0, 100.0), 0.0, -5.0, 0.0, 60.0, (800, 600))
    rng = np.random.default_rng(4)
    world = np.column_stack([rng.uniform(-800, 800, 300), rng.uniform(500, 3000, 300), rng.uniform(0, 50, 300)])
    uv_true = cam.project(world)
    seen = np.flatnonzero(cam.in_image(uv_true))
    photo = uv_true[seen[:120]] + rng.normal(0, 0.7, (120, 2))  # 120 of the seen DEM points, plus clutter
    photo = np.vstack([photo, rng.uniform([0, 0], [800, 600], (60, 2))])
    proj = cam.project(world)
    proj[~cam.in_image(proj)] = np.nan
    pairs = likely_pairs(photo, proj, threshold=3.0)
    truth = {(k, int(seen[k])) for k in range(120)}
    found = {(int(a), int(b)) for a, b in pairs}
    assert len(found & truth) >= 100
    assert len(found - truth) <= 10
    # mutual: no photo point and no DEM point twice
    assert len(set(pairs[:, 0])) == len(pairs) and len(set(pairs[:, 1])) == len(pairs)
    pi, pd, di, dd = agreement(photo, proj, 3.0)
    assert np.all(pd[pairs[:, 0]] <= 3.0) and np.all(dd[pairs[:, 1]] <= 3.0)


def test_a_rough_camera_does_not_rank_dense_texture_before_strong_features():
    """A rough camera (sigma 30 px) finds a near partner for every photo suggestion in dense texture (the DEM
    points project densely on the terrain) and a farther one for the strong features of sparse parts (summits under
    the sky): its agreement says little there, and the detector's strongest, the features, lead. A sharp camera's
    agreement still ranks first the suggestions it explains."""
    from monoplot_plugin.core.recommend import clutter

    rng = np.random.default_rng(5)
    size = (800, 600)
    dense = rng.uniform([0, 300], [800, 600], (2000, 2))  # DEM points projected on the terrain, lower half
    peaks = rng.uniform([20, 20], [780, 280], (40, 2))  # DEM summits and skyline points, upper half
    truth = np.vstack([peaks, dense])
    features = peaks + rng.normal(0, 0.7, (40, 2))  # strong photo corners on the summits
    texture = rng.uniform([0, 300], [800, 600], (400, 2))  # weak photo texture on the terrain
    photo = np.vstack([features, texture])
    score = np.r_[rng.uniform(0.6, 1.0, 40), rng.uniform(0.0, 0.6, 400)]
    is_feature = np.r_[np.ones(40, bool), np.zeros(400, bool)]
    for shift, sigma, expect in ((np.array([22.0, 12.0]), 30.0, 34), (np.zeros(2), 3.0, 36)):
        proj = truth + shift  # a rough camera: every point some 25 px off; a sharp one: where they are
        _, dist, _, _ = agreement(photo, proj, 3.0 * sigma)
        weighed = np.argsort(-priority(score, dist, sigma, clutter(proj, size)), kind="stable")
        assert is_feature[weighed[:40]].sum() >= expect, sigma
        if sigma > 10:  # without the weight, the texture's chance partners led
            plain = np.argsort(-priority(score, dist, sigma), kind="stable")
            assert is_feature[plain[:40]].sum() < 10


def test_a_rough_camera_links_no_chance_pairs_and_a_sharp_one_the_true_ones():
    """Likely pairs are what "Accept likely" accepts. Under a rough camera (sigma 30 px, every point some 25 px
    off) over dense suggestions, the mutual nearest pairs within a few pixels are chance pairs: none is linked.
    Under a sharp camera (sigma 4 px) over the same suggestions, the true pairs are, with fewer chance ones."""
    from monoplot_plugin.core.recommend import clutter

    rng = np.random.default_rng(6)
    size = (800, 600)
    truth = rng.uniform([0, 0], [800, 600], (1500, 2))  # DEM points as the true camera projects them
    photo = np.vstack([truth[:600] + rng.normal(0, 0.7, (600, 2)),  # 600 of them found on the photo
                       rng.uniform([0, 0], [800, 600], (900, 2))])  # and texture with no partner
    is_true = {(k, k) for k in range(600)}
    for shift, sigma in ((np.array([22.0, 12.0]), 30.0), (np.zeros(2), 4.0)):
        proj = truth + shift
        dense = max(clutter(proj, size), clutter(photo, size))
        plain = {(int(a), int(b)) for a, b in likely_pairs(photo, proj, 8.0)}
        weighed = {(int(a), int(b)) for a, b in likely_pairs(photo, proj, 8.0, sigma, dense)}
        assert weighed <= plain
        if sigma > 10:
            assert len(plain) > 50 and len(plain & is_true) < 0.1 * len(plain)  # without sigma: chance pairs
            assert not weighed
        else:
            # nearer than the plain threshold: as many true pairs, fewer by chance (unmatched texture remains)
            assert len(weighed & is_true) >= 0.97 * len(plain & is_true) >= 550
            assert len(weighed - is_true) / len(weighed) < 0.8 * len(plain - is_true) / len(plain)
