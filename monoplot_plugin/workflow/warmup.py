"""Warm the compiled kernels and the heavy imports once, in the background, so the first real step is quick.

numba compiles (or loads from its cache) each kernel the first time it is called with a given type signature, and
torch, OpenCV and SciPy take seconds to import. A fresh QGIS session paid all of that on the first Suggest (11-18 s
with the bar at 5 %) and when a saved project was reopened. :func:`warm_up` runs every step of the dock once on a
tiny generated scene (both DEM dtypes the readers produce), so the plugin can call it in a task when it starts.

>>> sorted(warm_up())
['fit', 'render', 'sight', 'suggest']
"""

from __future__ import annotations

import threading
import time
from typing import Dict, Optional

import numpy as np

from .progress import IsCanceled, Progress, check_canceled

__all__ = ["warm_up", "yield_to_work", "import_torch", "import_plugin_modules", "finish_imports"]

#: set when real work starts (the dock's first Suggest or fit): a warm-up still running stops after its step,
#: rather than compete with that work for the two cores (the work compiles what it needs itself)
_REAL_WORK = threading.Event()


#: set once torch, and what its optimisers import on their first use, are imported (see :func:`import_torch`)
_TORCH_READY = threading.Event()
_TORCH_LOCK = threading.Lock()
_TORCH_THREAD: list = []


def import_torch(is_canceled: Optional[IsCanceled] = None, progress: Optional[Progress] = None,
                 poll_s: float = 0.05) -> None:
    """Import torch and ``torch._dynamo`` in a thread of their own and wait for them, polling ``is_canceled``.

    torch takes seconds to import, and its optimisers import ``torch._dynamo`` (3-5 s more under load) when the
    first one is made. An import cannot be interrupted: a fit that imported them itself could not be canceled
    for that long (a Fit clicked soon after a Suggest, a refit started by the first accept). Here the import runs
    in a daemon thread (started once; later calls wait for the same one) and only the wait is given up on a
    cancel, raising ``Canceled``; the import goes on for the next fit. An import error is left to the caller's
    own import, which reports it. ``progress(0, message)`` is told when there is a wait.

    >>> import_torch()
    >>> import sys; "torch._dynamo" in sys.modules
    True
    """
    if _TORCH_READY.is_set():
        return
    with _TORCH_LOCK:
        if not _TORCH_THREAD:
            thread = threading.Thread(target=_import_torch, name="monoplot-import-torch", daemon=True)
            _TORCH_THREAD.append(thread)
            thread.start()
    if progress is not None:
        progress(0.0, "loading PyTorch (once per QGIS session)")
    while not _TORCH_READY.wait(poll_s):
        check_canceled(is_canceled)


def finish_imports(timeout_s: float) -> bool:
    """Wait up to ``timeout_s`` seconds for the background import of :func:`import_torch`, if one runs; True when
    none is left running. The host calls it when it quits: Python finalised under a thread still importing
    torch's compiled modules, and QGIS crashed on quit.

    >>> finish_imports(0.0) or not _TORCH_READY.is_set()
    True
    """
    with _TORCH_LOCK:
        threads = list(_TORCH_THREAD)
    for thread in threads:
        thread.join(timeout_s)
    return not any(t.is_alive() for t in threads)


def _import_torch() -> None:
    try:
        import torch  # noqa: F401
        import torch._dynamo  # noqa: F401  (what torch.optim's first optimiser imports)
    except Exception:  # noqa: BLE001 — the fit's own import reports it
        pass
    finally:
        _TORCH_READY.set()


def import_plugin_modules() -> int:
    """Import every module of the plugin's core and workflow (about 0.4 s: numba, SciPy; not torch, OpenCV or
    Dask, which stay lazy). Call it on the main thread before the warm-up starts: two threads importing modules
    that import each other can find one of them half-initialised ("cannot import name ... from partially
    initialized module"), which once broke the Processing provider's start in QGIS 3.40 while the warm-up was
    importing the same modules. Returns how many modules there are.

    >>> import_plugin_modules() > 50
    True
    """
    import importlib
    import pkgutil

    from .. import core, workflow

    names = [m.name for pkg in (core, workflow) for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + ".")]
    for name in names:
        importlib.import_module(name)
    return len(names)


def yield_to_work() -> None:
    """Real work begins: a running :func:`warm_up` stops after the step it is in."""
    _REAL_WORK.set()


def warm_up(progress: Optional[Progress] = None, is_canceled: Optional[IsCanceled] = None) -> Dict[str, float]:
    """Run a line of sight, then render, suggest and fit once on a 48 x 48 cell scene; returns the seconds each took
    (by step name). Not the photo's skyline detection (OpenCV): imported on this thread as QGIS 3.40 starts, it
    crashed QGIS (signal 11, the desktop smoke test).

    No result is kept; the point is the side effect (kernels compiled or loaded, modules imported). Raises
    ``Canceled`` when ``is_canceled()`` turns true between steps, or :func:`yield_to_work` was called."""
    from ..core.camera import Camera
    from ..core.dem import Dem
    from ..core.fit import FitOptions
    from ..core.render import render_dem
    from ..core.synthetic import render_photo, synthetic_terrain
    from ..core.transforms import photo_points_to_map
    from ..core.xyz import compute_xyz_full
    from . import fit as fit_step
    from . import suggest as suggest_step

    report = progress or (lambda fraction, message="": None)
    _REAL_WORK.clear()
    asked = is_canceled

    def is_canceled() -> bool:
        return _REAL_WORK.is_set() or bool(asked and asked())

    seconds: Dict[str, float] = {}
    terrain = synthetic_terrain((48, 48), cell=50.0, seed=1)
    x, y = terrain.cell_to_map(24, 46)
    camera = Camera((x, y, float(terrain.sample(x, y)) + 200.0), 0.0, -5.0, 0.0, 60.0, (96, 64),
                    crs_wkt=terrain.crs_wkt)
    t = time.perf_counter()
    # the exact line of sight: every fit with the DEM asks whether terrain hides its points (a GCP-table trial, who
    # never ran Suggest, waited 37 s for a first fit of 0.35 s, 13 s of it compiling this under load)
    from ..core.xyz.sight import segment_first_hit

    top = terrain.elevation.max() + 100.0
    segment_first_hit(terrain, np.array([x, y, top]), np.array([[x, y - 1500.0, top - 600.0]]))
    seconds["sight"] = time.perf_counter() - t
    report(0.05, "sight")
    check_canceled(is_canceled)
    t = time.perf_counter()
    for dtype in (np.float64, np.float32):  # the z-buffer and the render: one signature per DEM dtype
        check_canceled(is_canceled)
        dem = Dem.from_array(terrain.elevation.astype(dtype), terrain.geotransform, terrain.crs_wkt)
        res = compute_xyz_full(camera, dem, visibility=True)
        check_canceled(is_canceled)  # between kernels too: a plugin's unload waits for the one compiling
        render_dem(camera, dem, result=res)
        check_canceled(is_canceled)
        # the exact ray-terrain walk: drawing on the photo and the products' ground accuracy run it on the main
        # thread (its first compile took 3.8 s there in a desktop session)
        photo_points_to_map(np.array([[48.0, 40.0], [48.0, 60.0]]), camera, dem)
    seconds["render"] = time.perf_counter() - t
    report(0.3, "render")
    check_canceled(is_canceled)
    t = time.perf_counter()
    photo = render_photo(camera, terrain, noise=False)
    suggest_step.suggest(photo, terrain, camera, 20, 20, lambda *a: None, is_canceled)
    seconds["suggest"] = time.perf_counter() - t
    report(0.6, "suggest")
    check_canceled(is_canceled)
    t = time.perf_counter()
    xyz = res.xyz[8:56:6, 8:88:8].reshape(-1, 3)
    uv = np.stack(np.meshgrid(np.arange(8, 88, 8) + 0.5, np.arange(8, 56, 6) + 0.5), axis=-1).reshape(-1, 2)
    ok = np.isfinite(xyz).all(axis=1)
    if ok.sum() >= 6:
        pairs = np.column_stack([np.arange(ok.sum()), np.arange(ok.sum())])
        start = camera.with_parameters(heading=1.0)
        fit_step.fit(uv[ok], xyz[ok], start, terrain, pairs=pairs, on_ground=False, is_canceled=is_canceled)
        # the unpaired descent (torch): one short start, no consensus, no bootstrap
        quick = FitOptions(n_starts=1, n_escapes=0, consensus=False, bootstrap=0, coarse=False, time_budget_s=1.0)
        fit_step.fit(uv[ok], xyz[ok], start, terrain, on_ground=False, is_canceled=is_canceled, options=quick)
    seconds["fit"] = time.perf_counter() - t
    report(1.0, "fit")
    return seconds
