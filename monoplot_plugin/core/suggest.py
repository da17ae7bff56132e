"""Suggested ground-control points: key points in the photo and on the DEM, for the user to accept or reject.

Photo (:func:`suggest_photo_points`): ORB key points (OpenCV FAST + Harris score) and Shi-Tomasi corners, which
find the blunt corners (glacier junctions, moraine tips) that FAST misses, inside the picture proper (no paper
border, frame or printed caption, see :func:`~monoplot_plugin.core.suggest_photo.picture_mask`), spread over the
picture by grid bucketing.

DEM (:func:`suggest_dem_points`): with an approximate camera, the DEM is rendered from it with the core's z-buffer
(:func:`~monoplot_plugin.core.xyz.compute_xyz_full`): shaded relief plus dark silhouettes, and the same detectors
run on that picture, so suggestions are the terrain points that look like corners *from there* (peaks on the
skyline, ridge crossings, spur tips); each key point takes the X, Y, Z of the nearest terrain it shows (the
foreground side of a silhouette). Only points the camera sees, inside its view (plus a margin), are suggested.
Without a camera the detectors run on a map hillshade. Terrain landmarks are added in both cases: summits ranked
by topographic prominence, saddles and ridge junctions, X / Y from the geotransform and Z from the DEM; with a
camera also the peaks of the silhouettes it sees (:func:`silhouette_peaks`, kind "skyline").

Scores (documented, in [0, 1], higher first):

- key points: the percentile rank of the detector response among that detector's candidates in the same picture
  (ORB: Harris response; corners: the smaller eigenvalue of the structure tensor), so both detectors compare;
- landmarks: ``0.5 + 0.5 * rank`` of their strength (prominence for summits, relief drop for saddles, ridge
  sharpness for junctions), so that landmarks come before ordinary key points of the same rank.

Ids are stable for the same input and settings: suggestions sorted by decreasing score (ties by position) and
numbered "p0000", "p0001", ... (photo) or "d0000", ... (DEM).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from .keypoints import detect_keypoints, percentile_rank, spread_by_grid, stable_order, thin_evenly
from .landmarks import terrain_landmarks
from .silhouettes import foreground_xyz, render_for_keypoints, scaled_camera, silhouette_peaks
from .suggest_photo import FEATURELESS_CONTRAST, coarse_contrast, picture_mask, to_gray
from .xyz.zbuffer import NEAR_PLANE_M

#: Terrain nearer than this (metres) to a rough camera whose view it fills is left out of the DEM suggestions, unless
#: the caller states the position's uncertainty: the fit's default position σ is at least this
#: (:meth:`~.fit.options.FitOptions.prior_sigmas`), so such a slope may as well stand behind the true camera.
BLOCKED_VIEW_NEAR_M = 100.0
#: DEM suggestions within this many cells of the DEM's border are left out: where the DEM stops, its rendering
#: ends in an edge against the sky that no photo shows (the world goes on), and key points crowd on it (a drone
#: trial: most of 161 suggestions on the border of its DEM tile, none on the landslide it was made for).
EDGE_CELLS = 3.0
#: ... and, in the rendering from a camera, key points whose terrain lies within this many rendered pixels more
EDGE_PX = 6

__all__ = ["PhotoSuggestions", "DemSuggestions", "suggest_photo_points", "suggest_dem_points", "detect_keypoints",
           "spread_by_grid", "thin_evenly", "terrain_landmarks", "silhouette_peaks", "PHOTO_DETECTOR", "DEM_DETECTOR"]


@dataclass
class PhotoSuggestions:
    """Suggested photo points.

    Attributes:
        uv: (N, 2) float64 pixels (u = column, v = row; pixel centres at +0.5, like the rest of Monoplot).
        score: (N,) float64 in [0, 1], decreasing.
        ids: N stable ids "p0000", ...
        source: (N,) str: "orb", "corner", or "summit" / "notch" (of the skyline).
        contrast: the photo's contrast at a coarse scale (grey levels, :func:`~.suggest_photo.coarse_contrast`);
            below :data:`~.suggest_photo.FEATURELESS_CONTRAST` the suggestions are on noise (fog, a blank frame).
    """

    uv: np.ndarray
    score: np.ndarray
    ids: list
    source: np.ndarray
    contrast: float = float("nan")

    @property
    def featureless(self) -> bool:
        """True when the photo shows almost nothing (:data:`~.suggest_photo.FEATURELESS_CONTRAST`)."""
        return bool(self.contrast < FEATURELESS_CONTRAST)

    def __len__(self) -> int:
        return len(self.ids)

    def subset(self, keep) -> "PhotoSuggestions":
        """The suggestions selected by a bool mask or an index array (ids unchanged).

        >>> s = PhotoSuggestions(np.zeros((2, 2)), np.array([0.9, 0.5]), ["p0000", "p0001"], np.array(["orb", "orb"]))
        >>> s.subset([False, True]).ids, len(s.subset([1]))
        (['p0001'], 1)
        """
        idx = np.flatnonzero(keep) if np.asarray(keep).dtype == bool else np.asarray(keep, dtype=np.int64)
        return PhotoSuggestions(self.uv[idx], self.score[idx], [self.ids[i] for i in idx], self.source[idx],
                                self.contrast)


@dataclass
class DemSuggestions:
    """Suggested DEM points.

    Attributes:
        xyz: (M, 3) float64 map coordinates (DEM CRS; Z from the DEM, metres).
        score: (M,) float64 in [0, 1], decreasing.
        ids: M stable ids "d0000", ...
        kind: (M,) str: "summit", "saddle", "junction", "skyline" (peak of a silhouette seen by the camera), "orb" or
            "corner".
        uv: (M, 2) their pixels in the approximate camera (NaN without a camera).
        prominence: (M,) metres for summits (NaN for the others).
        near_clip_m: terrain nearer than this to the camera was left out (0 = none; see :func:`blocked_view`).
    """

    xyz: np.ndarray
    score: np.ndarray
    ids: list
    kind: np.ndarray
    uv: np.ndarray
    prominence: np.ndarray = field(default_factory=lambda: np.zeros(0))
    near_clip_m: float = 0.0

    def __len__(self) -> int:
        return len(self.ids)

    def subset(self, keep) -> "DemSuggestions":
        """The suggestions selected by a bool mask or an index array (ids unchanged)."""
        idx = np.flatnonzero(keep) if np.asarray(keep).dtype == bool else np.asarray(keep, dtype=np.int64)
        return DemSuggestions(self.xyz[idx], self.score[idx], [self.ids[i] for i in idx], self.kind[idx],
                              self.uv[idx], self.prominence[idx], self.near_clip_m)


# ----------------------------------------------------------------------------------------------------------------
# Photo
# ----------------------------------------------------------------------------------------------------------------
#: Detector settings of :func:`suggest_photo_points` (dense, small-scale corners: a GCP is a precise spot, and the
#: user's curation needs a suggestion within a few pixels of the feature they recognise; tuned on Aletsch).
PHOTO_DETECTOR = dict(orb_features=4000, fast_threshold=10, corner_count=8000, corner_quality=0.001,
                      corner_min_distance=3.0, corner_block_size=7)
#: Photo key points more than this share of the picture's height above the clear skyline are left out (sky).
SKY_MARGIN = 0.03
#: Detector settings of :func:`suggest_dem_points` (on the rendering: only clear corners, fewer but sharper).
DEM_DETECTOR = dict(orb_features=4000, fast_threshold=10, corner_count=8000, corner_quality=0.01,
                    corner_min_distance=5.0, corner_block_size=5)


#: A photo key point whose pixels differ from their 5 x 5 median by more than this many times the key points'
#: median difference (and by at least :data:`SPECK_MIN_GREY` grey levels) sits on a blob or line at most two pixels
#: wide at the working size: dust, a scratch, a speck of noise, no shape of the terrain a DEM point could match.
#: Measured on a desktop trial's scanned print (14 scratches, 150 specks: 18 % of the suggestions on 2.6 % of the
#: picture): 158 of its 363 suggestions on damage left out and none elsewhere; Aletsch: 8 of 2,000, none of the 15
#: within 10 px of a GCP.
SPECK_RATIO = 3.0
SPECK_MIN_GREY = 40.0


def on_specks(gray: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(K,) bool: key points ``uv`` (K, 2) pixels of the (H, W) uint8 ``gray`` on specks or thin scratches
    (:data:`SPECK_RATIO`).

    >>> import cv2
    >>> img = np.full((60, 60), 120, np.uint8); img[20:40, 20:40] = 60; img[10, 45] = 255   # a corner, a speck
    >>> img = cv2.GaussianBlur(img, (0, 0), 0.7)                                          # as a lens draws them
    >>> pts = np.array([[20.5, 20.5], [45.5, 10.5]] + [[x + 0.5, 30.5] for x in range(5, 45, 4)])
    >>> on_specks(img, pts)[:2].tolist()
    [False, True]
    """
    import cv2

    if not len(uv):
        return np.zeros(0, dtype=bool)
    residual = np.abs(gray.astype(np.int16) - cv2.medianBlur(gray, 5).astype(np.int16)).astype(np.uint8)
    residual = cv2.dilate(residual, np.ones((3, 3), np.uint8))
    cols = np.clip(uv[:, 0].astype(np.int64), 0, gray.shape[1] - 1)
    rows = np.clip(uv[:, 1].astype(np.int64), 0, gray.shape[0] - 1)
    at = residual[rows, cols].astype(np.float64)
    return at > max(SPECK_MIN_GREY, SPECK_RATIO * float(np.median(at)))


def suggest_photo_points(image: np.ndarray, max_points: int = 8000, cell_px: Optional[float] = None,
                         per_cell: int = 3, min_distance_px: Optional[float] = None, work_size: int = 2000,
                         mask: Optional[np.ndarray] = None, ignore_captions: bool = True, skyline: bool = True,
                         **detector) -> PhotoSuggestions:
    """Suggest photo points worth pairing with the DEM.

    Args:
        image: (H, W) or (H, W, 3) uint8 array (RGB).
        max_points: at most this many suggestions. The default is dense on purpose: the user accepts the few that
            sit on features they recognise. A shorter list is thinned evenly over the picture
            (:func:`thin_evenly`: the best point of each part of the picture first), not cut by score alone.
        cell_px: bucketing cell in full-resolution pixels (default: the long side / 170, 6 px on a 1024 px photo).
        per_cell: at most this many per cell.
        min_distance_px: no two suggestions closer (default: cell_px / 2).
        work_size: the picture is reduced so that its long side is at most this (speed on 24 MP photos);
            coordinates are returned at full resolution.
        mask: optional (H, W) bool, where to look (default :func:`~monoplot_plugin.core.suggest_photo.picture_mask`:
            no blank margins, frame or caption).
        ignore_captions: with the default mask, also remove printed text lines.
        skyline: add the skyline's summits and notches (:func:`~.skyline.skyline_features`) at the top score, and
            leave out key points clearly in the sky (:data:`SKY_MARGIN` above the clear skyline).
        **detector: settings of :func:`detect_keypoints` (ORB and corner detector), over :data:`PHOTO_DETECTOR`.
    Returns:
        :class:`PhotoSuggestions`.
    """
    import cv2

    gray = to_gray(image)
    h, w = gray.shape
    scale = min(1.0, float(work_size) / max(h, w))
    small = cv2.resize(gray, (max(1, round(w * scale)), max(1, round(h * scale))),
                       interpolation=cv2.INTER_AREA) if scale < 1.0 else gray
    if mask is None:
        small_mask = picture_mask(small, ignore_captions=ignore_captions)
    else:
        small_mask = np.asarray(mask, dtype=bool)
        if scale < 1.0:
            small_mask = cv2.resize(small_mask.astype(np.uint8), (small.shape[1], small.shape[0]),
                                    interpolation=cv2.INTER_NEAREST).astype(bool)
    uv, score, source = detect_keypoints(small, small_mask, **{**PHOTO_DETECTOR, **detector})
    keep = ~on_specks(small, uv)
    uv, score, source = uv[keep] / scale, score[keep], source[keep]
    if skyline and image.ndim == 3:
        # the skyline's summits and notches first: what a person recognises at once on a mountain photo
        from .auto.photo_edges import detect_photo_edges
        from .skyline import SKYLINE_WIDTH, above_skyline, skyline_features

        edges = detect_photo_edges(image, width=SKYLINE_WIDTH, mask=mask)
        sky_uv, sky_kind = skyline_features(image, mask=mask, edges=edges)
        # and nothing clearly in the sky (a desktop trial: 7 of the 30 on show, in a plain gradient sky 116-189 px
        # above the terrain; 7-13 % of the generated scenes' suggestions): no DEM point can be their partner
        terrain = ~above_skyline(uv, edges, SKY_MARGIN * h)
        uv, score, source = uv[terrain], score[terrain], source[terrain]
        uv = np.vstack([sky_uv, uv])
        score = np.concatenate([np.ones(len(sky_uv)), score])
        source = np.concatenate([sky_kind, source]).astype("<U8")
    cell = float(cell_px) if cell_px else max(w, h) / 170.0
    min_dist = cell / 2.0 if min_distance_px is None else float(min_distance_px)
    keep = spread_by_grid(uv, score, (w, h), cell, per_cell, min_dist)
    keep = keep[thin_evenly(uv[keep], score[keep], (w, h), max_points)]
    uv, score, source = uv[keep], score[keep], source[keep]
    order = stable_order(score, uv[:, 0], uv[:, 1])
    uv, score, source = uv[order], score[order], source[order]
    return PhotoSuggestions(uv, score, [f"p{i:04d}" for i in range(len(uv))], source,
                            coarse_contrast(small, small_mask))


# ----------------------------------------------------------------------------------------------------------------
# DEM
# ----------------------------------------------------------------------------------------------------------------
def suggest_dem_points(dem, camera=None, max_points: int = 8000, cell_px: Optional[float] = None,
                       per_cell: int = 1, min_distance_px: Optional[float] = None, render_width: int = 1024,
                       view_margin: float = 0.05, max_range: Optional[float] = None, landmarks: bool = True,
                       max_landmarks: int = 300, map_size: int = 2048, near_m: Optional[float] = None,
                       position_sigma_m: Optional[float] = None, poll: Optional[Callable[[], None]] = None,
                       **detector) -> DemSuggestions:
    """Suggest DEM points worth pairing with the photo.

    Args:
        dem: :class:`~monoplot_plugin.core.dem.Dem`, or a large DEM file's
            :class:`~monoplot_plugin.core.dem_window.DemSource` (what the camera sees of it, see ``as_dem``).
        camera: optional approximate :class:`~monoplot_plugin.core.camera.Camera`. With it, only points it sees
            (z-buffer visibility) inside its picture plus ``view_margin`` are suggested, and key points come from a
            rendering of the DEM from it.
        max_points: most suggestions in all; a shorter list than the candidates is thinned evenly over the
            camera's picture (over the map without a camera), see :func:`thin_evenly`.
        cell_px, per_cell, min_distance_px: spreading of the key points, in pixels of the camera's picture (with a
            camera) or of the map rendering (without); default cell = long side / 128 (8 px of a 1024 px
            rendering), distance = cell / 3.
        render_width: the camera's picture is rendered at most this wide (speed).
        view_margin: fraction of the picture size around it that still counts as "in view".
        max_range: ignore terrain farther from the camera (metres).
        landmarks: add summits, saddles and ridge junctions (:func:`terrain_landmarks`).
        max_landmarks: most landmarks (best first).
        map_size: without a camera, the hillshade is reduced so that its long side is at most this.
        near_m: terrain nearer than this (metres) is left out. None = automatic: the position's uncertainty when
            terrain nearer than it fills the rough camera's view (:func:`blocked_view`), else nothing.
        position_sigma_m: metres, one σ of the rough camera's position, if the user stated it (a GPS position
            known to 5 m keeps the street it stands in); None = :data:`BLOCKED_VIEW_NEAR_M`.
        poll: called between the steps (rendering, key points, landmarks); raises to stop, as a canceled task's.
        **detector: settings of :func:`detect_keypoints`, over :data:`DEM_DETECTOR`.
    Returns:
        :class:`DemSuggestions` (``uv`` = pixels in ``camera``, NaN without one).
    """
    from .dem_window import as_dem

    poll = poll or (lambda: None)
    dem = as_dem(dem, camera, max_range)
    poll()
    near_m = 0.0 if camera is None else near_m
    xyz_list, score_list, kind_list, prom_list = [], [], [], []
    res = None
    if camera is not None:
        from .xyz import compute_xyz_full

        small, scale = scaled_camera(camera, render_width)
        res = compute_xyz_full(small, dem, max_range=max_range, crop=True, visibility=False,
                               near=max(near_m or 0.0, NEAR_PLANE_M))
        clip = BLOCKED_VIEW_NEAR_M if position_sigma_m is None else float(position_sigma_m)
        if near_m is None and clip > 0 and blocked_view(res, small, dem, clip):
            near_m = clip
            poll()
            res = compute_xyz_full(small, dem, max_range=max_range, crop=True, visibility=False, near=near_m)
        poll()
        img = render_for_keypoints(res, dem)
        mask = np.asarray(res.hit)
        import cv2

        mask = cv2.dilate(mask.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
        mask &= ~beside_dem_edge(res, dem)
        uv, score, source = detect_keypoints(img, mask, **{**DEM_DETECTOR, **detector})
        cell = (float(cell_px) * scale) if cell_px else max(small.width, small.height) / 128.0
        min_dist = cell / 3.0 if min_distance_px is None else float(min_distance_px) * scale
        keep = spread_by_grid(uv, score, small.image_size, cell, per_cell, min_dist)
        pts = foreground_xyz(res, uv[keep])
        ok = np.isfinite(pts).all(axis=1)
        # none on the rendering's edge where the DEM stops (EDGE_CELLS): a key point sits a few rendered pixels
        # inside it, several cells at range; its own terrain is what counts (Aletsch's summits stand before
        # terrain near voids and must stay)
        metres_per_px = np.linalg.norm(pts[ok] - np.asarray(small.position), axis=1) / small.focal_px
        ok[ok] &= ~dem.near_edge(pts[ok], EDGE_CELLS + EDGE_PX * metres_per_px / dem.cell_size)
        xyz_list.append(pts[ok])
        score_list.append(score[keep][ok])
        kind_list.append(source[keep][ok])
        prom_list.append(np.full(int(ok.sum()), np.nan))
        if landmarks:
            spts, sstrength = silhouette_peaks(res)
            if len(spts):
                xyz_list.append(spts)
                score_list.append(0.5 + 0.5 * percentile_rank(sstrength))
                kind_list.append(np.full(len(spts), "skyline"))
                prom_list.append(np.full(len(spts), np.nan))
    else:
        import cv2

        scale = min(1.0, float(map_size) / max(dem.shape))
        view = dem
        if scale < 1.0:  # shade a reduced grid (same extent): hillshades of 25 M cells take seconds
            size = (max(2, round(dem.cols * scale)), max(2, round(dem.rows * scale)))
            small_z = cv2.resize(np.nan_to_num(dem.elevation.astype(np.float32), nan=np.float32(np.nanmin(
                dem.elevation))), size, interpolation=cv2.INTER_AREA)
            g = dem.geotransform
            sx, sy = dem.cols / size[0], dem.rows / size[1]
            view = type(dem).from_array(small_z, (g[0], g[1] * sx, g[2] * sy, g[3], g[4] * sx, g[5] * sy))
        shade = np.zeros(view.shape)
        for az in (315.0, 45.0, 135.0, 225.0):
            shade += np.nan_to_num(view.hillshade(az, 40.0), nan=0.0) / 4.0
        img = np.clip(30 + 200 * shade, 0, 255).astype(np.uint8)
        img = cv2.createCLAHE(clipLimit=4.0, tileGridSize=(8, 8)).apply(img)
        valid = np.isfinite(dem.elevation)
        if scale < 1.0:
            valid = cv2.resize(valid.astype(np.uint8), (img.shape[1], img.shape[0]),
                               interpolation=cv2.INTER_NEAREST).astype(bool)
        valid = cv2.erode(valid.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
        uv, score, source = detect_keypoints(img, valid, **{**DEM_DETECTOR, **detector})
        cell = float(cell_px) if cell_px else max(img.shape) / 128.0
        min_dist = cell / 3.0 if min_distance_px is None else float(min_distance_px)
        keep = spread_by_grid(uv, score, (img.shape[1], img.shape[0]), cell, per_cell, min_dist)
        colf, rowf = uv[keep, 0] / scale, uv[keep, 1] / scale
        x, y = dem.cell_to_map(colf, rowf)
        zz = dem.sample(x, y)
        pts = np.stack([np.atleast_1d(x), np.atleast_1d(y), np.atleast_1d(zz)], axis=1)
        ok = np.isfinite(pts).all(axis=1)
        xyz_list.append(pts[ok])
        score_list.append(score[keep][ok])
        kind_list.append(source[keep][ok])
        prom_list.append(np.full(int(ok.sum()), np.nan))

    near_m = near_m or 0.0
    poll()
    if landmarks:
        lxyz, lkind, lstrength, lprom = terrain_landmarks(dem)
        if len(lxyz):
            if res is not None:
                seen = _visible_in_view(dem, camera, lxyz, view_margin, near_m)
                lxyz, lkind, lstrength, lprom = lxyz[seen], lkind[seen], lstrength[seen], lprom[seen]
            lscore = np.zeros(len(lxyz))
            for k in np.unique(lkind):
                sel = lkind == k
                lscore[sel] = 0.5 + 0.5 * percentile_rank(lstrength[sel])
            top = np.argsort(-lscore, kind="stable")[:max_landmarks]
            xyz_list.append(lxyz[top])
            score_list.append(lscore[top])
            kind_list.append(lkind[top])
            prom_list.append(lprom[top])

    xyz = np.concatenate(xyz_list) if xyz_list else np.zeros((0, 3))
    score = np.concatenate(score_list) if score_list else np.zeros(0)
    kind = np.concatenate(kind_list).astype("<U8") if kind_list else np.zeros(0, dtype="<U8")
    prom = np.concatenate(prom_list) if prom_list else np.zeros(0)
    inner = ~dem.near_edge(xyz, EDGE_CELLS)
    xyz, score, kind, prom = xyz[inner], score[inner], kind[inner], prom[inner]
    if camera is not None and len(xyz):
        uv, depth = camera.project_with_depth(xyz)
        inside = camera.in_image(uv, margin=view_margin * max(camera.image_size)) & (depth > near_m)
        xyz, score, kind, prom, uv = xyz[inside], score[inside], kind[inside], prom[inside], uv[inside]
    else:
        uv = np.full((len(xyz), 2), np.nan)
    # Landmarks first where a key point falls on the same spot (within a third of a DEM cell: duplicates).
    order = stable_order(score, xyz[:, 0], xyz[:, 1])
    if len(order) > max_points:  # a short list spread over the camera's picture (or the map), not all on one ridge
        spread_uv = uv if camera is not None else np.stack(dem.map_to_cell(xyz[:, 0], xyz[:, 1]), axis=1)
        spread_size = camera.image_size if camera is not None else (dem.cols, dem.rows)
        order = order[thin_evenly(spread_uv[order], score[order], spread_size, max_points)]
        order = order[stable_order(score[order], xyz[order, 0], xyz[order, 1])]
    xyz, score, kind, prom, uv = xyz[order], score[order], kind[order], prom[order], uv[order]
    return DemSuggestions(xyz, score, [f"d{i:04d}" for i in range(len(xyz))], kind, uv, prom, near_m)


def beside_dem_edge(res, dem) -> np.ndarray:
    """(H, W) bool of a rendering ``res`` (:func:`~.xyz.compute_xyz_full`): pixels within :data:`EDGE_PX` of terrain
    at the DEM's edge (its border or a void) that see that terrain, terrain beyond it or sky; nearer terrain in front
    of it stays (Aletsch's summits stand before terrain near voids). Key points there sit on the edge where the DEM
    stops, and take the detector's budget from the terrain (a drone trial's tile: 11 of 36 on its border)."""
    import cv2

    hit = np.asarray(res.hit)
    at_edge = np.zeros(hit.shape, bool)
    at_edge[hit] = dem.near_edge(res.xyz[hit], 1.5)
    edge_depth = np.where(at_edge, res.distance, 0.0).astype(np.float32)
    nearby = cv2.dilate(edge_depth, np.ones((2 * EDGE_PX + 1,) * 2, np.uint8))  # the farthest edge terrain near
    beside = hit & (nearby > 0) & (res.distance >= 0.9 * nearby)
    # sky: beside the edge terrain, unless terrain well in front of it is as near (a summit's own outline)
    front = cv2.dilate((hit & (nearby > 0) & ~beside).astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    return beside | (~hit & (nearby > 0) & ~front)


def blocked_view(res, camera, dem, near_m: float = BLOCKED_VIEW_NEAR_M, step: int = 4) -> bool:
    """Whether terrain close to the rough camera fills its view: most pixels that see terrain see it nearer than
    ``near_m`` metres and nearer than half the distance at which their ray would meet flat ground at the
    camera's height above the terrain below it (a slope in the way, not the ground a camera looks down on).

    Args:
        res: :class:`~monoplot_plugin.core.xyz.XyzResult` of ``camera``.
        camera: the rough :class:`~monoplot_plugin.core.camera.Camera` (the size ``res`` was rendered at).
        dem: the terrain.
        step: every ``step``-th pixel of every ``step``-th row is looked at (speed).
    """
    distance = np.asarray(res.distance, dtype=np.float64)[::step, ::step]
    rows, cols = np.nonzero(np.isfinite(distance))
    if len(rows) == 0:
        return False
    ground = float(dem.sample(camera.position[0], camera.position[1]))
    height = camera.position[2] - ground if np.isfinite(ground) else np.inf
    uv = np.stack([cols * step + 0.5, rows * step + 0.5], axis=1)
    _, rays = camera.pixel_to_world_ray(uv)
    down = -rays[:, 2] / np.linalg.norm(rays, axis=1)  # sine of the ray's angle below the horizontal
    with np.errstate(divide="ignore", invalid="ignore"):
        flat = np.where((down > 0) & (height > 0), height / down, np.inf)
    seen = distance[rows, cols]
    in_the_way = (seen < near_m) & (seen < 0.5 * flat)
    return bool(in_the_way.mean() > 0.5)


def _visible_in_view(dem, camera, xyz: np.ndarray, margin: float, near_m: float = 0.0) -> np.ndarray:
    """(K,) bool: DEM points inside the camera's view (plus margin), beyond ``near_m`` metres, and in its line of
    sight (exact test with :func:`~monoplot_plugin.core.xyz.segment_first_hit`; a point is seen when the first
    terrain hit on the way is within one cell of it; terrain nearer than ``near_m`` does not hide it)."""
    from .xyz import segment_first_hit

    uv, depth = camera.project_with_depth(xyz)
    inside = camera.in_image(uv, margin=margin * max(camera.image_size)) & (depth > near_m)
    if not inside.any():
        return inside
    origin = np.asarray(camera.position, dtype=np.float64)
    targets = xyz[inside] + np.array([0.0, 0.0, 1.0])  # a metre above the ground: the point itself is on it
    length = np.linalg.norm(targets - origin, axis=1)
    starts = origin + (targets - origin) * (near_m / np.maximum(length, 1e-9))[:, None]
    s = segment_first_hit(dem, starts, targets)
    length = np.linalg.norm(targets - starts, axis=1)
    seen = ~np.isfinite(s) | ((1.0 - s) * length <= 1.5 * dem.cell_size)
    out = inside.copy()
    out[inside] = seen
    return out
