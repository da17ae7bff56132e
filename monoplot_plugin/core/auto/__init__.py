"""Fully automatic registration (issue 13): a camera from the photo, the DEM and a rough prior, with no clicks.

Modules: :mod:`.photo_edges` (the photo's skyline and oriented edges), :mod:`.dem_edges` (the DEM's skyline and
occluding contours from a camera, as 3-D points), :mod:`.align` (the oriented chamfer score and the coarse-to-fine
search), :mod:`.fine` (the fine stage, the edge score that compares cameras, position probes), :mod:`.points` (the
suggestions and skyline points the aligned camera brings together, for the final fit), :mod:`.sigma` (σ that covers
what those points cannot see), :mod:`.register` (:func:`register_automatic`: alignment, consistent suggestions,
consensus fit, verdict), :mod:`.heading` (:func:`register_any_heading`: the same when the direction of view is not
known),
:mod:`.overlay` (the DEM's silhouettes under the camera found drawn over the photo's detected skyline).
"""

from .heading import register_any_heading
from .register import AutoFitResult, register_automatic

__all__ = ["register_automatic", "register_any_heading", "AutoFitResult"]
