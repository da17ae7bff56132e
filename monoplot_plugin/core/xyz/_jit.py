"""numba for the z-buffer's kernels: ``njit`` with an on-disk cache of their own, or plain Python without numba.

The compiled kernels are cached (``cache=True``) in a folder per import name and per version of the kernels' source
(:func:`_numba_cache_dir`): numba's cache records the module name, so the same files imported as
``monoplot_plugin.core.xyz`` by tests and as ``monoplot.monoplot_plugin...`` by QGIS must not share a cache; and
numba checks only the timestamp of the file that defines a kernel, not of the files of the kernels it calls, so a
digest of all of them keeps an updated plugin from running stale machine code.

>>> os.path.basename(_numba_cache_dir()).startswith(_PACKAGE + "-")
True
"""

from __future__ import annotations

import hashlib
import os
import tempfile

#: Import name of the package whose kernels are compiled here ("monoplot_plugin.core.xyz" in tests).
_PACKAGE = __name__.rpartition(".")[0]
_HERE = os.path.dirname(os.path.abspath(__file__))


def _source_digest() -> str:
    """12 hex digits over the kernels' source files (this package and the distortion model they compile)."""
    digest = hashlib.sha1()
    files = sorted(os.path.join(_HERE, n) for n in os.listdir(_HERE) if n.endswith(".py"))
    for path in files + [os.path.join(os.path.dirname(_HERE), "distortion.py")]:
        try:
            with open(path, "rb") as fh:
                digest.update(fh.read())
        except OSError:
            pass
    return digest.hexdigest()[:12]


_DIGEST = _source_digest()


def _numba_cache_dir() -> str:
    """Where the compiled kernels are cached: ``<import name>-<source digest>`` under ``NUMBA_CACHE_DIR`` if set, else
    in the package's ``__pycache__``, else (read-only plugin folder) in a temporary folder."""
    base = os.environ.get("NUMBA_CACHE_DIR", "")
    if not base:
        base = os.path.join(_HERE, "__pycache__", "numba")
        try:
            os.makedirs(base, exist_ok=True)
            writable = os.access(base, os.W_OK)
        except OSError:
            writable = False
        if not writable:
            base = os.path.join(tempfile.gettempdir(), "monoplot-numba-cache")
    return os.path.join(base, f"{_PACKAGE}-{_DIGEST}")


try:
    import numba
    from numba import prange

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is missing
    numba = None
    HAVE_NUMBA = False
    prange = range


def njit(*args, **kwargs):
    """``numba.njit`` caching in :func:`_numba_cache_dir` (numba picks a function's cache folder when it is
    decorated); the function itself when numba is missing."""
    def decorate(fn):
        if not HAVE_NUMBA:
            return fn
        saved = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = _numba_cache_dir()
        try:
            return numba.njit(**kwargs)(fn)
        finally:
            numba.config.CACHE_DIR = saved

    if args and callable(args[0]):
        return decorate(args[0])
    return decorate


def _threads() -> int:
    """Threads the parallel kernels use."""
    return numba.get_num_threads() if HAVE_NUMBA else 1
