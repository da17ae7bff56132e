"""Fixtures for the output writers (helpers in outputs_helpers.py)."""

import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

# The test modules import outputs_helpers by its plain name; make that work under any pytest import mode
# (prepend, importlib, or test folders turned into packages).
sys.path.insert(0, str(Path(__file__).resolve().parent))

from outputs_helpers import PlaneScene, build_plane_scene  # noqa: E402


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
