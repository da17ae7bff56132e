"""A small time-lapse on generated terrain, as files: a DEM GeoTIFF, the camera, frames rendered with known turns."""

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain
from monoplot_plugin.workflow.camera_files import camera_json


def timelapse_scene(folder, turns, size=(320, 200), lighting=True):
    """Write dem.tif, camera.json and one PNG frame per (d_heading, d_pitch, d_roll) of ``turns`` into ``folder``.

    Returns dict: dem (path), camera (path), cam (Camera), frames (paths), cameras (each frame's true Camera)."""
    import cv2

    dem = synthetic_terrain((150, 150), cell=50.0, seed=2)
    x, y = dem.cell_to_map(75, 149)
    cam = Camera((x, y, float(dem.elevation.max()) + 200.0), heading=0.0, pitch=-12.0, roll=0.0, fov=60.0,
                 image_size=size, crs_wkt=dem.crs_wkt)
    dem.save(str(folder / "dem.tif"))
    # as a fit writes it, with its verdict (a camera file without one is a rough prior to the batch)
    (folder / "camera.json").write_text(camera_json(cam, {"status": "ok", "message": "the true camera"}))
    frames, cameras = [], []
    rng = np.random.default_rng(1)
    (folder / "frames").mkdir(exist_ok=True)
    for i, (dh, dp, dr) in enumerate(turns):
        true = cam.with_parameters(heading=cam.heading + dh, pitch=cam.pitch + dp, roll=cam.roll + dr)
        sun = (135.0 + rng.uniform(-30, 30), 40.0 + rng.uniform(-10, 10)) if lighting and i else (135.0, 40.0)
        image = render_photo(true, dem, seed=1, sun_azimuth=sun[0], sun_altitude=sun[1])
        if lighting and i:
            image = np.clip(image * rng.uniform(0.8, 1.15) + rng.uniform(-15, 15), 0, 255).astype(np.uint8)
        path = folder / "frames" / f"frame_{i:03d}.png"
        cv2.imwrite(str(path), image[..., ::-1])
        frames.append(str(path))
        cameras.append(true)
    return {"dem": str(folder / "dem.tif"), "camera": str(folder / "camera.json"), "cam": cam, "frames": frames,
            "cameras": cameras, "folder": str(folder / "frames")}


@pytest.fixture(scope="session")
def still_timelapse(tmp_path_factory):
    """Six frames of a camera that does not move (lighting changes only)."""
    return timelapse_scene(tmp_path_factory.mktemp("still"), [(0.0, 0.0, 0.0)] * 6)


@pytest.fixture(scope="session")
def drifting_timelapse(tmp_path_factory):
    """A reference frame, then frames turned by known small rotations (up to 2 degrees) in new light."""
    turns = [(0.0, 0.0, 0.0), (0.6, 0.0, 0.0), (-1.2, 0.4, 0.0), (2.0, -0.3, 0.3), (0.0, 0.0, -0.8)]
    return timelapse_scene(tmp_path_factory.mktemp("drift"), turns)
