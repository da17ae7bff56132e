"""No data loss: every Monoplot output is written to a temporary file beside its target, then renamed into place.

- An existing output is never replaced unless the caller says ``overwrite=True``
  (:class:`OutputExistsError` otherwise, raised before anything is written).
- A failure (read-only folder, disk full, a bug half-way through a writer) leaves the earlier output untouched and
  removes the temporary files; the error is an :class:`OutputError` whose message says why in plain words.
- Paths may contain any Unicode character (GDAL and OGR get them as UTF-8 strings).

Multi-file formats (ESRI Shapefile: .shp .shx .dbf .prj .cpg) are renamed file by file, the main file last, so a
reader never sees a new .shp with an old .dbf.

>>> import tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> with atomic_output(folder / "a.txt") as tmp:
...     _ = pathlib.Path(tmp).write_text("hello")
>>> (folder / "a.txt").read_text()
'hello'
>>> with atomic_output(folder / "a.txt") as tmp:  # doctest: +IGNORE_EXCEPTION_DETAIL
...     pass
Traceback (most recent call last):
OutputExistsError: a.txt already exists in ... (set overwrite to replace it)
"""

from __future__ import annotations

import errno
import os
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Sequence, Union

__all__ = ["OutputError", "OutputExistsError", "atomic_output", "check_can_write", "sidecar_suffixes",
           "describe_os_error"]

PathLike = Union[str, os.PathLike]

#: Files that make up one ESRI Shapefile (the main ``.shp`` is renamed last).
SHAPEFILE_SUFFIXES = (".shx", ".dbf", ".prj", ".cpg", ".qix", ".sbn", ".sbx", ".shp.xml", ".shp")


class OutputError(RuntimeError):
    """An output could not be written; the message is meant for the user. Earlier outputs are intact."""


class OutputExistsError(OutputError, FileExistsError):
    """The target exists and the caller did not ask to overwrite it."""


def sidecar_suffixes(path: PathLike) -> Sequence[str]:
    """Suffixes of every file that belongs to ``path``'s format, the main file's suffix last.

    >>> sidecar_suffixes("glacier.shp")[-1], sidecar_suffixes("xyz.tif")
    ('.shp', ('.tif.aux.xml', '.tif'))
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".shp":
        return SHAPEFILE_SUFFIXES
    return (suffix + ".aux.xml", suffix)


def _members(path: Path, suffixes: Sequence[str]) -> list:
    stem = path.name[: len(path.name) - len(path.suffix)]
    return [path.with_name(stem + s) for s in suffixes]


def describe_os_error(exc: OSError, target: PathLike) -> str:
    """A sentence for the user about why ``target`` could not be written."""
    folder = Path(target).parent
    code = getattr(exc, "errno", None)
    if code in (errno.EACCES, errno.EPERM):
        return f"cannot write into {folder}: permission denied (the folder is read-only for you)"
    if code == errno.EROFS:
        return f"cannot write into {folder}: the file system is read-only"
    if code in (errno.ENOSPC, errno.EDQUOT):
        return f"cannot write {Path(target).name}: the disk is full (no space left in {folder})"
    if code == errno.ENOENT:
        return f"cannot write {Path(target).name}: the folder {folder} does not exist"
    if code == errno.ENAMETOOLONG:
        return f"cannot write {target}: the file name is too long"
    return f"cannot write {target}: {exc.strerror or exc}"


def check_can_write(path: PathLike, overwrite: bool = False) -> Path:
    """Raise :class:`OutputError` now if ``path`` cannot be written; return it as a Path.

    Checks: the folder exists and is a folder, the target (or, for a Shapefile, any of its member files) does not
    exist unless ``overwrite``, the target is not a folder, and a file can really be created in the folder (a probe
    file, since permission bits do not tell the truth for root or on read-only mounts).
    """
    path = Path(os.fspath(path))
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.exists():
        raise OutputError(f"cannot write {path.name}: the folder {folder} does not exist")
    if not folder.is_dir():
        raise OutputError(f"cannot write {path.name}: {folder} is not a folder")
    if path.is_dir():
        raise OutputError(f"cannot write {path}: a folder of that name exists")
    existing = [m for m in _members(path, sidecar_suffixes(path)) if m.exists()]
    if existing and not overwrite:
        raise OutputExistsError(f"{path.name} already exists in {folder} (set overwrite to replace it)")
    probe = folder / f".monoplot-probe-{uuid.uuid4().hex}"
    try:
        with open(probe, "wb"):
            pass
    except OSError as exc:
        raise OutputError(describe_os_error(exc, path)) from exc
    finally:
        try:
            probe.unlink()
        except OSError:
            pass
    return path


@contextmanager
def atomic_output(path: PathLike, overwrite: bool = False) -> Iterator[str]:
    """Context manager: yields a temporary path (same folder, same suffix) to write to; renames it to ``path`` on
    success, deletes it on failure.

    Args:
        path: the final output file (``.shp``: its sidecar files follow it).
        overwrite: replace an existing output (default False: :class:`OutputExistsError`).
    Yields:
        str: the temporary path to hand to GDAL/OGR or ``open``.
    Raises:
        OutputExistsError, OutputError (with the reason in words); exceptions of the writer pass through
        unchanged after the temporary files are removed, and the earlier output is intact in every case.
    """
    target = check_can_write(path, overwrite)
    suffixes = sidecar_suffixes(target)
    stem = target.name[: len(target.name) - len(target.suffix)]
    tmp = target.with_name(f".{stem}.monoplot-tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}{target.suffix}")
    tmp_members = _members(tmp, suffixes)
    final_members = _members(target, suffixes)
    try:
        yield str(tmp)
        if not tmp.exists():
            raise OutputError(f"{target.name} was not written (the writer produced no file)")
        # Re-check: another process may have created the target while we wrote.
        if not overwrite and any(m.exists() for m in final_members):
            raise OutputExistsError(f"{target.name} already exists in {target.parent} (set overwrite to replace it)")
        # Members the new output does not have must not survive from the old one (e.g. an old .cpg).
        for t, f in zip(tmp_members, final_members):
            if not t.exists() and f.exists() and f != target:
                f.unlink()
        for t, f in zip(tmp_members, final_members):  # main file last (see SHAPEFILE_SUFFIXES)
            if t.exists():
                os.replace(t, f)
    except OSError as exc:
        if isinstance(exc, OutputError):
            raise
        raise OutputError(describe_os_error(exc, target)) from exc
    finally:
        for t in tmp_members:
            try:
                t.unlink()
            except OSError:
                pass
