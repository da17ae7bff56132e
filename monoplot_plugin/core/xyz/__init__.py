"""Per-pixel terrain intersection: the map coordinates (X, Y, Z) of the first terrain point each pixel sees.

Surface: the DEM's triangle mesh (vertices at cell centres, two triangles per square of four centres, split along the
diagonal from (row, col) to (row + 1, col + 1); see :mod:`.dem`). Interior voids are not holes to look through: they
are closed by a lid at the height of their rim, and a pixel whose nearest triangle touches a void vertex is
nodata (NaN), never the ground behind the void (see :func:`_filled_voids`).

Method (a z-buffer, not ray marching):

1. every mesh vertex is projected into the photo (coordinates recentred on the camera in float64 first, then
   kept as float32 pixels and depths: UTM northings would lose half a metre in float32), row by row as step 2
   goes, so that only two rows per thread are held;
2. every triangle is rasterised into a depth buffer of inverse depths that keeps, per pixel centre, the id of the
   nearest triangle. The two triangles of a quad are drawn in one pass over its pixel box (the side of the diagonal
   picks the triangle); triangles crossing the camera plane are clipped 1 cm in front of it; back faces are skipped
   when the camera is above the terrain (a ray from above meets the surface first from its top side);
3. each pixel's ray is then intersected *exactly* (float64) with the plane of the triangle in the buffer, so the
   result does not depend on interpolation in the buffer: only which triangle wins can differ from a brute-force
   search, on silhouettes.

The loops are compiled with numba (``cache=True``, in a folder per import name, see :func:`_numba_cache_dir`; parallel
over the available cores, each thread with its own depth buffer over interleaved blocks of DEM rows, merged at the
end; up to three such buffers live in the memory of the output array, see :func:`_depth_buffers`).
Without numba the same code runs as plain Python, which is only practical for tiny grids.

Radial distortion: vertices are projected with it (triangle edges are straight between distorted vertices, a
sub-pixel approximation for small triangles); the exact step undistorts each pixel's ray. Points beyond the radius
where the distortion polynomial stops growing are not projected.

>>> import numpy as np
>>> from ..camera import Camera
>>> from ..dem import Dem
>>> flat = Dem.from_array(np.full((50, 50), 100.0), (0, 10, 0, 500, 0, -10))
>>> cam = Camera(position=(250, 0, 200), heading=0, pitch=-30, roll=0, fov=60, image_size=(64, 48))
>>> xyz = compute_xyz(cam, flat)
>>> xyz.shape, bool(np.allclose(xyz[40, :, 2], 100.0))
((48, 64, 3), True)
>>> bool(np.isnan(xyz[0, 0]).all())     # above the horizon of a finite grid: sky
True
"""

from __future__ import annotations

from ._jit import HAVE_NUMBA, _numba_cache_dir, _threads, numba  # noqa: F401 (numba: for callers setting threads)
from .sight import segment_first_hit
from .zbuffer import NEAR_PLANE_M, XyzResult, compute_xyz, compute_xyz_full

__all__ = ["compute_xyz", "compute_xyz_full", "XyzResult", "segment_first_hit", "HAVE_NUMBA", "NEAR_PLANE_M"]
