"""Fixtures of the bad-input suite: the Processing scene of tests/processing, one good output of every algorithm
(the "earlier output" each case must leave byte for byte), and hostile folders (full disk, file-size limit,
read-only, missing).

Full and read-only folders are small tmpfs mounts when running as root (CI containers, this machine); otherwise a
file-size limit (``RLIMIT_FSIZE``, which needs no privilege) stands in for the full disk and ``chmod`` for the
read-only folder.
"""

import contextlib
import os
import resource
import signal
import subprocess
import uuid
from pathlib import Path

import pytest

from tests.processing.conftest import processing_provider, run_alg, small_scene  # noqa: F401 (fixtures)

ROOT = os.geteuid() == 0


def _mount_tmpfs(path: Path, size: str) -> bool:
    if not ROOT:
        return False
    path.mkdir(parents=True, exist_ok=True)
    return subprocess.call(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)]) == 0


def _umount(path: Path) -> None:
    subprocess.call(["umount", "-l", str(path)])


@pytest.fixture()
def full_disk(tmp_path):
    """A folder on a full file system (a tmpfs filled to the last byte after the earlier output is placed):
    ``with full_disk(place) as folder`` where ``place(folder)`` puts the earlier output there first."""
    mounts = []

    @contextlib.contextmanager
    def make(place):
        folder = tmp_path / f"full-{uuid.uuid4().hex[:6]}"
        if not _mount_tmpfs(folder, "2m"):
            pytest.skip("a full disk needs root to mount a tmpfs (the file-size-limit cases cover the rest)")
        mounts.append(folder)
        place(folder)
        fd = os.open(folder / ".filler", os.O_WRONLY | os.O_CREAT)  # fill what is left, to the last byte
        chunk = 1 << 16
        while chunk:
            try:
                os.write(fd, b"\0" * chunk)
            except OSError:
                chunk //= 2
        os.close(fd)
        yield folder

    yield make
    for folder in mounts:
        _umount(folder)


@pytest.fixture()
def read_only(tmp_path):
    """``with read_only(place) as folder``: a folder holding the earlier output that cannot be written into."""
    mounts = []

    @contextlib.contextmanager
    def make(place):
        folder = tmp_path / f"ro-{uuid.uuid4().hex[:6]}"
        if _mount_tmpfs(folder, "4m"):
            mounts.append(folder)
            place(folder)
            subprocess.check_call(["mount", "-o", "remount,ro", str(folder)])
            yield folder
        else:
            folder.mkdir()
            place(folder)
            folder.chmod(0o555)
            try:
                yield folder
            finally:
                folder.chmod(0o755)

    yield make
    for folder in mounts:
        _umount(folder)


@contextlib.contextmanager
def file_size_limit(limit: int):
    """Files of this process cannot grow past ``limit`` bytes inside the block (EFBIG instead of SIGXFSZ)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    previous = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, previous)


def snapshot(folder: Path) -> dict:
    """{name: bytes} of every file in a folder (the filler of a full disk excepted)."""
    return {p.name: p.read_bytes() for p in sorted(Path(folder).iterdir()) if p.is_file() and p.name != ".filler"}


def leftovers(folder: Path) -> list:
    return [p.name for p in Path(folder).iterdir() if "monoplot-tmp" in p.name or "monoplot-probe" in p.name]
