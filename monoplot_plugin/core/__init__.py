"""Monoplot's pure core: camera model, DEM, per-pixel XYZ, rendering, suggestions and camera fit.

No Qt and no qgis import here: the core runs in plain Python scripts and notebooks.

>>> from monoplot_plugin.core import Camera
"""

from .camera import Camera, PARAMETER_NAMES, project_points, rotation_matrix  # noqa: F401

__all__ = ["Camera", "PARAMETER_NAMES", "project_points", "rotation_matrix"]

# Other engineers: append your exports below with a guarded import block of your own module, e.g.
#   from .dem import Dem  # noqa: E402,F401
#   __all__ += ["Dem"]

from .dem import Dem  # noqa: E402,F401

__all__ += ["Dem"]

# fit (issue 4): camera fit and GCP suggestions (torch, cv2 and scipy are imported lazily inside the functions).
from .fit import FitResult, fit_camera  # noqa: E402,F401

__all__ += ["FitResult", "fit_camera"]

from .xyz import XyzResult, compute_xyz, compute_xyz_full  # noqa: E402,F401

__all__ += ["XyzResult", "compute_xyz", "compute_xyz_full"]

from .render import RenderedDem, render_dem  # noqa: E402,F401

__all__ += ["RenderedDem", "render_dem"]

# auto (issue 13): fully automatic registration from a rough prior.
from .auto import AutoFitResult, register_any_heading, register_automatic  # noqa: E402,F401

__all__ += ["AutoFitResult", "register_automatic", "register_any_heading"]
