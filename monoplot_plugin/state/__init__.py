"""Monoplot project state: photo, DEM, curated points, pairs, prior and fitted camera, with undo/redo.

Pure Python (no Qt, no qgis): the dock and its controller edit the state only through :class:`CommandStack`, so every
point edit can be undone, and listeners (the canvases, the table, the autosave) hear about every change.

Coordinates: photo points are pixels ``(u, v)`` (column, row; origin at the top-left corner, see
:mod:`monoplot_plugin.core.camera`); map points are ``(x, y)`` in the DEM's CRS (metres), ``z`` optional.

>>> state = ProjectState()
>>> stack = CommandStack(state)
>>> _ = stack.push(add_points(state, [Point.new("photo", 10.5, 20.5)], "Suggest"))
>>> pid = next(iter(state.points))
>>> _ = stack.push(set_status(state, [pid], ACCEPTED))
>>> state.points[pid].status
'accepted'
>>> _ = stack.undo(); state.points[pid].status
'suggested'
>>> ProjectState.from_json(state.to_json()) == state
True
"""

from .edits import (CommandStack, Edit, add_points, link, link_pairs, move_point, remove_points, replace_in_views,
                    replace_suggestions, set_check, set_status, unlink)
from .points import (ACCEPTED, CHECK, MAP, PHOTO, REJECTED, STATUSES, SUGGESTED, Point, ProjectState, points_from_table,
                     points_table)

__all__ = [
    "SUGGESTED", "ACCEPTED", "REJECTED", "CHECK", "STATUSES", "PHOTO", "MAP",
    "Point", "ProjectState", "Edit", "CommandStack",
    "add_points", "remove_points", "set_status", "move_point", "replace_suggestions", "replace_in_views", "link",
    "link_pairs", "unlink", "set_check",
    "points_table", "points_from_table",
]
