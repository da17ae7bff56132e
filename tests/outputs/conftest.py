"""Fixtures for the output writers (helpers in outputs_helpers.py)."""

import os
import shutil
import tempfile
from pathlib import Path

import pytest

from outputs_helpers import PlaneScene, build_plane_scene


@pytest.fixture(scope="session")
def plane_scene() -> PlaneScene:
    """Camera over a tilted plane with exact per-pixel XYZ (see outputs_helpers.build_plane_scene)."""
    return build_plane_scene()


@pytest.fixture
def world_readable_tmp():
    """A temporary folder that another user can reach (pytest's tmp_path is private to its owner)."""
    path = Path(tempfile.mkdtemp(prefix="monoplot-outputs-"))
    os.chmod(path, 0o755)
    yield path
    shutil.rmtree(path, ignore_errors=True)
