"""The pure state model: JSON round trip, undo/redo of every kind of edit, suggestion refresh keeps decisions."""

import pytest

from monoplot_plugin.state import (ACCEPTED, MAP, PHOTO, REJECTED, SUGGESTED, CommandStack, Point, ProjectState,
                                   add_points, link, move_point, remove_points, replace_suggestions, set_status)


def filled():
    state = ProjectState(photo_path="/x/photo.jpg", dem_layer_id="dem_1", prior={"fov": 50})
    stack = CommandStack(state)
    photo = [Point.new(PHOTO, 10 * i, 5 * i, score=1.0 - i / 10) for i in range(4)]
    world = [Point.new(MAP, 1000.0 + i, 2000.0 - i, 300.0 + i) for i in range(3)]
    stack.push(add_points(state, photo + world, "Suggest"))
    return state, stack, photo, world


def test_json_round_trip_keeps_everything():
    state, stack, photo, world = filled()
    stack.push(set_status(state, [photo[0].id], ACCEPTED))
    stack.push(link(state, photo[1].id, world[1].id))
    state.fitted = {"position": [1, 2, 3]}
    state.fit_info = {"rmse_px": 3.5}
    again = ProjectState.from_json(state.to_json())
    assert again == state
    assert again.pairs == [(photo[1].id, world[1].id)]


def test_undo_redo_each_edit_kind():
    state, stack, photo, world = filled()
    snapshots = [state.to_json()]
    for edit in (lambda: set_status(state, [photo[0].id, world[0].id], REJECTED),
                 lambda: move_point(state, photo[2].id, 55.0, 66.0),
                 lambda: link(state, photo[3].id, world[2].id),
                 lambda: remove_points(state, [world[2].id]),
                 lambda: add_points(state, [Point.new(PHOTO, 1, 2, status=ACCEPTED, manual=True)])):
        stack.push(edit())
        snapshots.append(state.to_json())
    assert state.pairs == []  # deleting a paired point drops its pair
    for expected in reversed(snapshots[:-1]):
        stack.undo()
        assert state.to_json() == expected
    for expected in snapshots[1:]:
        stack.redo()
        assert state.to_json() == expected


def test_new_suggestions_replace_only_untouched_ones():
    state, stack, photo, world = filled()
    stack.push(set_status(state, [photo[0].id], ACCEPTED))
    stack.push(set_status(state, [photo[1].id], REJECTED))
    fresh = [Point.new(PHOTO, 500, 500)]
    stack.push(replace_suggestions(state, PHOTO, fresh))
    ids = {p.id for p in state.in_space(PHOTO)}
    assert ids == {photo[0].id, photo[1].id, fresh[0].id}
    assert len(state.in_space(MAP)) == 3
    stack.undo()
    assert {p.id for p in state.in_space(PHOTO)} == {p.id for p in photo}


def test_listeners_hear_changed_ids_and_noop_edits_are_dropped():
    state, stack, photo, _ = filled()
    heard = []
    stack.add_listener(heard.append)
    stack.push(set_status(state, [photo[0].id], SUGGESTED))  # already suggested: nothing to do
    assert heard == [] and stack.undo_text() == "Suggest"
    stack.push(set_status(state, [photo[0].id], ACCEPTED))
    assert heard == [{photo[0].id}]


def test_link_requires_one_photo_and_one_map_point():
    state, stack, photo, world = filled()
    with pytest.raises(ValueError):
        link(state, photo[0].id, photo[1].id)
    stack.push(link(state, photo[0].id, world[0].id))
    stack.push(link(state, photo[1].id, world[0].id))  # re-linking moves the map point to the new partner
    assert state.pairs == [(photo[1].id, world[0].id)]
    assert state.points[photo[1].id].status == ACCEPTED
    assert [a.id for a, _ in state.valid_pairs()] == [photo[1].id]


def test_projects_of_format_1_still_open_and_counts_follow_edits():
    """Format 2 stores the points as columns (a cheap autosave); a project written with format 1 (a list of point
    objects) reads the same, and the cached counts stay right through edits, undo and redo."""
    import json

    state, stack, photo, world = filled()
    stack.push(set_status(state, [photo[0].id, world[0].id], ACCEPTED))
    old = {**json.loads(state.to_json()), "format": "monoplot-state/1",
           "points": [dict(vars(p)) for p in state.points.values()]}
    assert ProjectState.from_json(json.dumps(old)) == state
    with pytest.raises(ValueError):
        ProjectState.from_json(json.dumps({**old, "format": "monoplot-state/9"}))

    def recount():
        out = {s: {st: 0 for st in (SUGGESTED, ACCEPTED, REJECTED, "check")} for s in (PHOTO, MAP)}
        for p in state.points.values():
            out[p.space][p.status] += 1
        return out

    assert state.counts() == recount()
    stack.push(set_status(state, [photo[1].id], REJECTED))
    stack.push(remove_points(state, [world[2].id]))
    assert state.counts() == recount()
    stack.undo()
    stack.undo()
    assert state.counts() == recount()
    stack.redo()
    assert state.counts() == recount() and state.counts()[MAP][ACCEPTED] == 1
