"""The footprint models' shared answers equal answers worked out afresh (the caches are exact)."""

import numpy as np
import pytest
from frozen_scenes import load_scene

from tsad_drake.geometry2d import (
    convex_polygons_overlap_pairs,
    edge_normals,
    pad_edge_normals,
    pad_polygons,
)
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.planning.actions import move_table
from tsad_drake.planning.feasibility import GeometricFeasibility
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.planning.types import Action


def _walk(model, state, workspace, rng, steps):
    """States along a random walk of feasible moves (the search's kind of sibling states)."""
    states = [state]
    for _ in range(steps):
        movable = [i for i, o in enumerate(state.objects) if o.name != state.target]
        moves = []
        for i in rng.permutation(movable):
            theta_pick, theta_place = move_table(model, state, int(i), workspace)
            moves = [(int(i), c, theta_pick[c], theta_place[c])
                     for c in np.nonzero(~np.isnan(theta_place))[0]]
            if moves:
                break
        if not moves:
            break
        i, c, pick, place = moves[int(rng.integers(len(moves)))]
        x, y = workspace.cell_centres[c]
        state = simulate_pick_place(state, Action(state.objects[i].name, float(pick), float(x),
                                                  float(y), float(place)))
        states.append(state)
    return states


@pytest.mark.parametrize("key", [("1", 1), ("2", 3), ("3", 1)])
def test_placement_answers_shared_across_states_equal_fresh_ones(key):
    scenario = load_scene(*key)
    workspace = make_workspace(scenario)
    state = state_from_perception(observe_raycast(scenario).scene)
    rng = np.random.default_rng(0)
    states = _walk(GeometricFeasibility(workspace), state, workspace, rng, 6)
    assert len(states) > 3
    shared, shared_hits = GeometricFeasibility(workspace), 0
    for s in states:
        fresh = GeometricFeasibility(workspace)  # nothing shared with another state
        for i in range(len(s.objects)):
            for theta in workspace.approach_angles:
                before = len(shared._place_answers)
                answer = shared.place_options(s, i, float(theta))
                shared_hits += len(shared._place_answers) == before
                np.testing.assert_array_equal(answer, fresh.place_options(s, i, float(theta)))
    # each question is asked once, so every answer found is another state's: the walk's states
    # differ from the last in one object's place, and the others' placements are shared
    assert shared_hits > 0


def test_kept_edge_normals_are_the_ones_the_overlap_test_works_out():
    rng = np.random.default_rng(3)
    polygons = []
    for _ in range(40):  # random convex polygons of 3-8 vertices, counter-clockwise
        angles = np.sort(rng.uniform(0, 2 * np.pi, int(rng.integers(3, 9))))
        radius = rng.uniform(0.01, 0.08)
        polygons.append(rng.uniform(-0.3, 0.3, 2) + radius * np.stack(
            [np.cos(angles), np.sin(angles)], axis=1))
    padded = pad_polygons(polygons)
    kept = pad_edge_normals([edge_normals(p) for p in polygons], padded.shape[1])
    np.testing.assert_array_equal(kept, edge_normals(padded))  # bit for bit
    a, b = padded[:20], padded[20:]
    for margin in (0.0, 0.02):
        np.testing.assert_array_equal(
            convex_polygons_overlap_pairs(a, b, margin, kept[:20], kept[20:]),
            convex_polygons_overlap_pairs(a, b, margin))
    assert convex_polygons_overlap_pairs(a, b, 0.02).any()  # the comparison saw both answers
    assert not convex_polygons_overlap_pairs(a, b, 0.0).all()
