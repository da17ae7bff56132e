"""No data loss: every Monoplot output is written to a temporary file beside its target, flushed and synced to disk,
read back and checked (GDAL/OGR/JSON; the feature count for vectors), then renamed into place.

- An existing output is never replaced unless the caller says ``overwrite=True``
  (:class:`OutputExistsError` otherwise, raised before anything is written).
- A failure (read-only folder, disk full, a bug half-way through a writer) leaves the earlier output untouched and
  removes the temporary files; the error is an :class:`OutputError` whose message says why in plain words.
- Cancel (:func:`cancel_before_commit`) is asked just before the rename: a canceled run leaves the earlier file.
- SIGINT/SIGTERM while writing remove the temporary files (see :func:`_signals_clean_up`).
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

import atexit
import errno
import json
import os
import signal
import threading
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator, Optional, Sequence, Union

__all__ = ["OutputError", "OutputExistsError", "OutputCanceled", "atomic_output", "check_can_write",
           "sidecar_suffixes", "describe_os_error", "incomplete_write", "cancel_before_commit", "write_text",
           "temporary_path",
           "commit_temporary", "remove_temporary", "WriteInterrupted", "signal_handlers"]

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
    if code == errno.EFBIG:
        return f"cannot write {Path(target).name}: the file is larger than the folder allows (quota or file-size limit)"
    if code == errno.ENOENT:
        if folder.is_dir():  # /proc, a virtual file system: no file can be created in it (a trial said "no folder")
            return f"cannot write into {folder}: no file can be created there"
        return f"cannot write {Path(target).name}: the folder {folder} does not exist"
    if code == errno.ENAMETOOLONG:
        return f"cannot write {target}: the file name is too long"
    return f"cannot write {target}: {exc.strerror or exc}"


def incomplete_write(target: PathLike, detail: str = "") -> OutputError:
    """The error for a write that did not reach the disk whole (what GDAL, OGR and QGIS report then is rarely the
    cause): the disk is full or the file hit a size limit."""
    extra = f" ({detail})" if detail else ""
    return OutputError(f"cannot write {Path(target).name}: the disk is full, or the file is larger than the folder "
                       f"allows (quota, file-size limit){extra}")


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


class OutputCanceled(OutputError):
    """The user canceled before the new output was put in place; the earlier file (if any) is untouched."""


class WriteInterrupted(KeyboardInterrupt):
    """SIGTERM arrived while an output was being written (raised so that the temporary files are removed)."""


_local = threading.local()
#: Temporary files of the writes in progress (removed at exit if a write is cut short without its cleanup).
_ACTIVE_TEMPS: set = set()


@contextmanager
def cancel_before_commit(is_canceled: Callable[[], bool], also_outer: bool = False) -> Iterator[None]:
    """Inside the block, every :func:`atomic_output` of this thread asks ``is_canceled()`` just before the final
    rename and raises :class:`OutputCanceled` (leaving the earlier output as it was) when it returns True. An inner
    block replaces an outer one's check, or with ``also_outer`` adds to it."""
    saved = getattr(_local, "is_canceled", None)
    if also_outer and saved is not None:  # a product step inside a Processing run: either one's cancel counts
        _local.is_canceled = lambda: bool(is_canceled()) or bool(saved())
    else:  # replaces it (the batch's log is written, canceled or not)
        _local.is_canceled = is_canceled
    try:
        yield
    finally:
        _local.is_canceled = saved


def stop_if_canceled(target) -> None:
    """Raise :class:`OutputCanceled` when the cancel check of :func:`cancel_before_commit` says so: a writer asks
    between its parts, so that a cancel acts within one of them, not only before the rename at the end."""
    if _canceled():
        raise OutputCanceled(f"canceled: {Path(os.fspath(target)).name} was not written")


def _canceled() -> bool:
    check = getattr(_local, "is_canceled", None)
    try:
        return bool(check()) if check is not None else False
    except Exception:  # a dead feedback object: not a cancel
        return False


def _raise_interrupted(signum, frame):
    raise WriteInterrupted(f"signal {signum}")


@contextmanager
def signal_handlers(handler, signums=(signal.SIGINT, signal.SIGTERM), only_default: bool = False) -> Iterator[None]:
    """Install ``handler`` for ``signums`` inside the block (main thread only; elsewhere nothing happens), and the
    earlier handlers again after it. ``only_default``: leave a signal alone unless its handler is the default one."""
    installed = []
    if threading.current_thread() is threading.main_thread():
        for signum in signums:
            try:
                if not only_default or signal.getsignal(signum) == signal.SIG_DFL:
                    installed.append((signum, signal.signal(signum, handler)))
            except (ValueError, OSError, TypeError):  # not the main interpreter, or no such signal
                pass
    try:
        yield
    finally:
        for signum, previous in installed:
            try:
                signal.signal(signum, previous if previous is not None else signal.SIG_DFL)
            except (ValueError, OSError, TypeError):
                pass


def _signals_clean_up():
    """In the main thread, turn a SIGTERM (and a SIGINT whose handler is the default one; Python's own already
    raises KeyboardInterrupt) into an exception for the duration of a write, so that the ``finally`` that removes
    the temporary files runs. Handlers installed by someone else (QGIS, Processing's cancel) are left alone: they
    do not kill the process."""
    return signal_handlers(_raise_interrupted, only_default=True)


def _remove_active_temps() -> None:
    for name in list(_ACTIVE_TEMPS):
        try:
            os.unlink(name)
        except OSError:
            pass
    _ACTIVE_TEMPS.clear()


atexit.register(_remove_active_temps)


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_folder(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems cannot sync a folder; the data itself is synced
        pass
    finally:
        os.close(fd)


def temporary_path(path: PathLike) -> Path:
    """A hidden temporary file name beside ``path`` with the same suffix (for writers that must be given a name,
    e.g. a QGIS feature sink); :func:`commit_temporary` or :func:`remove_temporary` ends it."""
    target = Path(os.fspath(path))
    stem = target.name[: len(target.name) - len(target.suffix)]
    tmp = target.with_name(f".{stem}.monoplot-tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}{target.suffix}")
    for member in _members(tmp, sidecar_suffixes(target)):
        _ACTIVE_TEMPS.add(str(member))
    return tmp


def remove_temporary(tmp: PathLike, target: PathLike) -> None:
    """Delete every member file of a temporary output made by :func:`temporary_path` (missing ones are fine)."""
    for member in _members(Path(os.fspath(tmp)), sidecar_suffixes(target)):
        try:
            member.unlink()
        except OSError:
            pass
        _ACTIVE_TEMPS.discard(str(member))


def commit_temporary(tmp: PathLike, target: PathLike, overwrite: bool = False,
                     verify: Optional[Callable[[str], None]] = None) -> Path:
    """Sync, verify and rename a finished temporary output into place (see :func:`atomic_output`, which calls
    this). On any failure the temporary files are removed and the earlier output is untouched.

    Raises:
        OutputError (OutputExistsError, OutputCanceled) with the reason in words.
    """
    tmp, target = Path(os.fspath(tmp)), Path(os.fspath(target))
    suffixes = sidecar_suffixes(target)
    tmp_members, final_members = _members(tmp, suffixes), _members(target, suffixes)
    try:
        if not tmp.exists():
            raise OutputError(f"{target.name} was not written (the writer produced no file)")
        for member in tmp_members:  # the data reach the disk before the name does
            if member.exists():
                _fsync_file(member)
        if verify is not None:
            try:
                verify(str(tmp))
            except Exception as exc:  # an unreadable result is a failed write, whatever the reader says
                raise incomplete_write(target, f"the file written does not read back: {exc}") from exc
        if _canceled():
            raise OutputCanceled(f"canceled: {target.name} was not replaced" if target.exists() else
                                 f"canceled: {target.name} was not written")
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
        _fsync_folder(target.parent)
    except OSError as exc:
        if isinstance(exc, OutputError):
            raise
        raise OutputError(describe_os_error(exc, target)) from exc
    finally:
        remove_temporary(tmp, target)
    return target


@contextmanager
def atomic_output(path: PathLike, overwrite: bool = False,
                  verify: Optional[Callable[[str], None]] = None) -> Iterator[str]:
    """Context manager: yields a temporary path (same folder, same suffix) to write to; on success syncs it to disk,
    reads it back with ``verify``, and renames it to ``path``; on failure deletes it.

    Args:
        path: the final output file (``.shp``: its sidecar files follow it).
        overwrite: replace an existing output (default False: :class:`OutputExistsError`).
        verify: ``verify(temporary path)`` reopens the finished file and raises when it is not what was meant
            (GDAL/OGR/JSON readers in the writers; feature counts for vectors).
    Yields:
        str: the temporary path to hand to GDAL/OGR or ``open``.
    Raises:
        OutputExistsError, OutputCanceled (see :func:`cancel_before_commit`), OutputError (with the reason in
        words); exceptions of the writer pass through unchanged after the temporary files are removed, and the
        earlier output is intact in every case, including SIGINT and SIGTERM while writing.
    """
    target = check_can_write(path, overwrite)
    tmp = temporary_path(target)
    try:
        with _signals_clean_up():
            try:
                yield str(tmp)
            except OSError as exc:
                if isinstance(exc, OutputError):
                    raise
                raise OutputError(describe_os_error(exc, target)) from exc
            commit_temporary(tmp, target, overwrite, verify)
    finally:
        remove_temporary(tmp, target)


def write_text(path: PathLike, text: str, overwrite: bool = False, encoding: str = "utf-8") -> Path:
    """Write a text file (camera JSON, CSV) through :func:`atomic_output`; verified by reading it back (and, for
    ``.json``, parsing it).

    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "camera.json"
    >>> write_text(p, '{"a": 1}').read_text()
    '{"a": 1}'
    """
    target = Path(os.fspath(path))

    def verify(tmp: str) -> None:
        with open(tmp, encoding=encoding, newline="") as fh:
            back = fh.read()
        if back != text:
            raise incomplete_write(target, f"{len(back)} of {len(text)} characters reached the disk")
        if target.suffix.lower() == ".json":
            json.loads(back)

    with atomic_output(target, overwrite, verify=verify) as tmp:
        with open(tmp, "w", encoding=encoding, newline="") as fh:
            fh.write(text)
            fh.flush()
    return target
