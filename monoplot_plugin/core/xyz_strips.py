"""Memory-bounded per-pixel XYZ: the memory a product needs is estimated before anything is allocated, and an image
whose XYZ raster does not fit in what is free is computed in horizontal strips, one at a time.

A strip of rows ``[row0, row0 + rows)`` is the same camera with the principal point moved up by ``row0`` and an
image ``rows`` high (:func:`strip_camera`): every pixel keeps its exact ray, so the strips put together equal the
whole raster computed at once (apart from triangles drawn at the strip borders, which are the same triangles).
A product that cannot be made even in the thinnest strips is refused with the numbers
(:class:`MemoryBudgetError`).

>>> import numpy as np
>>> from .camera import Camera
>>> from .dem import Dem
>>> flat = Dem.from_array(np.full((50, 50), 100.0), (0, 10, 0, 500, 0, -10))
>>> cam = Camera(position=(250, 0, 200), heading=0, pitch=-30, roll=0, fov=60, image_size=(64, 48))
>>> whole = compute_xyz(cam, flat)
>>> parts = [(row0, xyz) for row0, xyz, _ in xyz_strips(cam, flat, rows_per_strip=10)]
>>> [row0 for row0, _ in parts]
[0, 10, 20, 30, 40]
>>> bool(np.allclose(np.concatenate([x for _, x in parts]), whole, equal_nan=True))
True
"""

from __future__ import annotations

import os
from dataclasses import replace
from typing import Iterator, Optional, Tuple

import numpy as np

from .camera import Camera
from .dem import Dem
from .xyz import compute_xyz, compute_xyz_full

__all__ = ["MemoryBudgetError", "available_memory", "xyz_bytes_per_pixel", "xyz_memory", "plan_strips",
           "strip_camera", "xyz_strips", "MIN_STRIP_ROWS"]

#: Bytes per photo pixel while the XYZ raster of a strip is computed and written: float64 X, Y, Z (24, which also
#: hold up to three depth buffers), the triangle ids (4), the distance (4) and a margin (8); more threads than three
#: add 8 bytes each (their depth buffers, see core.xyz.zbuffer._depth_buffers).
XYZ_BYTES_PER_PIXEL = 40
#: Bytes needed whatever the strips: GDAL's block cache while writing (capped by the writer) and the interpreter.
FIXED_OVERHEAD = 384 << 20
#: Thinner strips than this cost more in passes over the DEM than they save.
MIN_STRIP_ROWS = 16
#: Part of the free memory a product may take (the rest is for QGIS, the photo, the DEM and other programs).
MEMORY_SHARE = 0.6


class MemoryBudgetError(MemoryError):
    """A product needs more memory than is free even in strips; the message gives the numbers."""


def xyz_bytes_per_pixel() -> int:
    """:data:`XYZ_BYTES_PER_PIXEL` plus 8 bytes per z-buffer thread beyond three."""
    from .xyz import _threads

    return XYZ_BYTES_PER_PIXEL + 8 * max(0, _threads() - 3)


def available_memory() -> int:
    """Bytes this process may use now: ``MONOPLOT_MEMORY_LIMIT_MB`` when set, else the smaller of the system's
    available memory (``MemAvailable``) and the container's limit (cgroup), times :data:`MEMORY_SHARE`."""
    limit = os.environ.get("MONOPLOT_MEMORY_LIMIT_MB")
    if limit:
        return int(float(limit) * (1 << 20))
    candidates = []
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    candidates.append(int(line.split()[1]) * 1024)
                    break
    except OSError:
        pass
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as fh:
                text = fh.read().strip()
            if text.isdigit() and int(text) < 1 << 60:
                candidates.append(int(text))
        except OSError:
            pass
    if not candidates:
        try:
            candidates.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            candidates.append(4 << 30)
    return int(min(candidates) * MEMORY_SHARE)


def xyz_memory(camera: Camera, rows: Optional[int] = None) -> int:
    """Bytes the XYZ raster of ``rows`` image rows (default: all) needs while it is computed and written."""
    return int(camera.width) * int(camera.height if rows is None else rows) * xyz_bytes_per_pixel()


def plan_strips(camera: Camera, budget: Optional[int] = None, extra_per_row: int = 0, fixed: int = 0,
                what: str = "XYZ raster") -> int:
    """Rows per strip: the whole image when it fits in ``budget`` bytes (default :func:`available_memory`), else the
    most rows that fit. ``extra_per_row``: further bytes per image row (e.g. the photo's); ``fixed``: bytes needed
    whatever the strips (e.g. the DEM).

    Raises:
        MemoryBudgetError with the numbers when even :data:`MIN_STRIP_ROWS` rows do not fit.
    """
    budget = available_memory() if budget is None else int(budget)
    per_row = camera.width * xyz_bytes_per_pixel() + int(extra_per_row)
    fixed = int(fixed) + (FIXED_OVERHEAD if budget > 4 * FIXED_OVERHEAD else 0)
    room = budget - fixed
    if room >= per_row * camera.height:
        return camera.height
    rows = room // per_row if per_row else camera.height
    if rows < min(MIN_STRIP_ROWS, camera.height):
        need = fixed + per_row * min(MIN_STRIP_ROWS, camera.height)
        raise MemoryBudgetError(
            f"the {what} of a {camera.width} x {camera.height} px photo needs {_gb(fixed + per_row * camera.height)}"
            f" at once, and {_gb(need)} even in strips of {MIN_STRIP_ROWS} rows, but only {_gb(budget)} can be "
            f"used now: close other programs, or use a smaller photo (or a smaller DEM)")
    return int(rows)


def _gb(n: float) -> str:
    return f"{n / 1e9:.2f} GB" if n >= 1e8 else f"{n / 1e6:.0f} MB"


def strip_camera(camera: Camera, row0: int, rows: int) -> Camera:
    """The camera of image rows ``[row0, row0 + rows)``: same rays, principal point moved up by ``row0``.

    >>> cam = Camera((0, 0, 10), 0, -10, 0, 60, (640, 480))
    >>> s = strip_camera(cam, 100, 50)
    >>> same = np.allclose(s.pixel_to_world_ray([[10.5, 0.5]])[1], cam.pixel_to_world_ray([[10.5, 100.5]])[1])
    >>> s.image_size, bool(same)
    ((640, 50), True)
    """
    cx, cy = camera.cx, camera.cy
    return replace(camera, image_size=(camera.width, int(rows)), principal_point=(cx, cy - row0))


def xyz_strips(camera: Camera, dem: Dem, rows_per_strip: Optional[int] = None, max_range: Optional[float] = None,
               budget: Optional[int] = None, distance: bool = False) \
        -> Iterator[Tuple[int, np.ndarray, Optional[np.ndarray]]]:
    """(row0, (rows, W, 3) XYZ, (rows, W) distance or None) strip after strip, top to bottom; ``rows_per_strip``
    from :func:`plan_strips` unless given. Over a DEM file read by windows (core :class:`~.dem_large.LargeDem`) each
    strip is the level-of-detail z-buffer of the file (:data:`~.dem_large.PRODUCT_LOD`), as the whole raster is."""
    rows = rows_per_strip or plan_strips(camera, budget)
    source = getattr(dem, "source", None)  # a DEM file read by windows (core.dem_large.LargeDem): its own z-buffer
    for row0 in range(0, camera.height, rows):
        n = min(rows, camera.height - row0)
        cam = strip_camera(camera, row0, n)
        if source is not None:
            from .dem_large import PRODUCT_LOD
            from .xyz_lod import compute_xyz_lod

            result = compute_xyz_lod(cam, source, max_range=max_range, lod=PRODUCT_LOD)
            yield row0, result.xyz, result.distance if distance else None
        elif distance:
            result = compute_xyz_full(cam, dem, max_range=max_range, visibility=False)
            yield row0, result.xyz, result.distance
        else:
            yield row0, compute_xyz(cam, dem, max_range=max_range), None
