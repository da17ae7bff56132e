"""Helpers for the output tests: a small analytic scene (camera over a tilted plane) whose per-pixel XYZ is exact
ray-plane intersection, so writers and photo<->map geometry are tested against known truth without the rasteriser."""

import os
import shutil
import stat
import subprocess
from contextlib import contextmanager
import sys
from dataclasses import dataclass

import numpy as np
from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem

CRS = "EPSG:21781"


@dataclass
class PlaneScene:
    camera: Camera
    dem: Dem
    xyz: np.ndarray  # (H, W, 3), NaN for sky / off the DEM
    distance: np.ndarray  # (H, W)
    photo: np.ndarray  # (H, W, 3) uint8


def plane_height(x, y):
    """Terrain z = 400 + 0.1 x' (x' = x - 600000): tilted so that Z varies across the photo."""
    return 400.0 + 0.1 * (np.asarray(x) - 600000.0)


def build_plane_scene() -> PlaneScene:
    x0, y0, cell = 600000.0, 206000.0, 25.0
    rows, cols = 240, 160  # 4 km east, 6 km north
    xs = x0 + (np.arange(cols) + 0.5) * cell
    elevation = np.tile(plane_height(xs, 0.0), (rows, 1))
    dem = Dem.from_array(elevation, (x0, cell, 0.0, y0, 0.0, -cell), crs_wkt=CRS)
    camera = Camera(position=(602000.0, 200500.0, 1200.0), heading=5.0, pitch=-12.0, roll=2.0, fov=60.0,
                    image_size=(240, 160), crs_wkt=dem.crs_wkt)
    origin, rays = camera.pixel_to_world_ray(camera.pixel_centres().reshape(-1, 2))
    # Ray-plane intersection: z0 + t dz = 400 + 0.1 (x0 + t dx - 600000)
    a = rays[:, 2] - 0.1 * rays[:, 0]
    b = 400.0 + 0.1 * (origin[0] - 600000.0) - origin[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = b / a
    pts = origin + t[:, None] * rays
    xmin, ymin, xmax, ymax = dem.bounds()
    # The DEM mesh spans cell centres only: half a cell inside the outer edges.
    ok = (t > 0) & (pts[:, 0] >= xmin + cell / 2) & (pts[:, 0] <= xmax - cell / 2) & \
         (pts[:, 1] >= ymin + cell / 2) & (pts[:, 1] <= ymax - cell / 2)
    pts[~ok] = np.nan
    xyz = pts.reshape(camera.height, camera.width, 3)
    distance = np.linalg.norm(xyz - origin, axis=-1)
    rng = np.random.default_rng(1)
    photo = rng.integers(1, 255, size=(camera.height, camera.width, 3), dtype=np.uint8)
    return PlaneScene(camera, dem, xyz, distance, photo)


def run_as_unprivileged(code: str, *paths) -> subprocess.CompletedProcess:
    """Run Python ``code`` as an ordinary user (root ignores permission bits, so a read-only folder is only
    read-only for someone else). Without root, runs as the current user."""
    env = dict(os.environ, PYTHONPATH=os.getcwd())
    kwargs = {}
    if os.geteuid() == 0:
        kwargs = dict(user=65534, group=65534, extra_groups=[])
        env["HOME"] = "/tmp"
    return subprocess.run([sys.executable, "-c", code, *map(str, paths)], capture_output=True, text=True,
                          env=env, timeout=60, **kwargs)


@contextmanager
def read_only_folder(folder):
    """Make ``folder`` read-only for this process, however privileged, and restore it afterwards.

    Yields how: "chmod" (ordinary user: permission bits), "immutable" (root: ``chattr +i``, which binds root too),
    or "other-user" (root without chattr: the caller must write from :func:`run_as_unprivileged`).
    """
    mode = stat.S_IRUSR | stat.S_IXUSR | stat.S_IRGRP | stat.S_IXGRP | stat.S_IROTH | stat.S_IXOTH
    if os.geteuid() != 0:
        os.chmod(folder, mode)
        try:
            yield "chmod"
        finally:
            os.chmod(folder, 0o755)
        return
    chattr = shutil.which("chattr")
    if chattr and subprocess.run([chattr, "+i", str(folder)], capture_output=True).returncode == 0:
        try:
            yield "immutable"
        finally:
            subprocess.run([chattr, "-i", str(folder)], check=True)
        return
    os.chmod(folder, mode)
    try:
        yield "other-user"
    finally:
        os.chmod(folder, 0o755)
