"""Point-cloud simulation, workspace grid and empty-cell count on hand-built states."""

import numpy as np
import pytest

from tsad_drake.geometry2d import rotation2d
from tsad_drake.planning.pointcloud_sim import move_object, placement_valid, simulate_pick_place
from tsad_drake.planning.state import empty_cell_count, make_workspace
from tsad_drake.planning.types import Action, PlanningState, PlanObject
from tsad_drake.scenario import Scenario


def _disc(name, x, y, r=0.03, n=200, seed=0):
    rng = np.random.default_rng(seed)
    a = rng.uniform(0, 2 * np.pi, n)
    pts = np.stack([x + r * np.cos(a), y + r * np.sin(a), rng.uniform(0.0, 0.15, n)], axis=1)
    return PlanObject(name, pts, x, y, 0.3, origin=(x, y, 0.3))


@pytest.fixture(scope="module")
def workspace():
    return make_workspace(Scenario())


def test_moves_exactly_the_objects_points_by_the_rigid_transform():
    objs = (_disc("a", 0.1, 0.0, seed=1), _disc("b", 0.2, 0.1, seed=2), _disc("t", 0.25, -0.1))
    state = PlanningState(objs, "t")
    action = Action("b", np.radians(-10), 0.07, -0.18, np.radians(20))
    nxt = simulate_pick_place(state, action)
    assert nxt.objects[0] is state.objects[0] and nxt.objects[2] is state.objects[2]
    moved, before = nxt.objects[1], state.objects[1]
    rot = rotation2d(np.radians(30))
    expect = (before.points[:, :2] - [0.2, 0.1]) @ rot.T + [0.07, -0.18]
    np.testing.assert_allclose(moved.points[:, :2], expect, atol=1e-12)
    np.testing.assert_array_equal(moved.points[:, 2], before.points[:, 2])
    assert (moved.x, moved.y) == (0.07, -0.18)
    assert moved.yaw == pytest.approx(0.3 + np.radians(30))
    assert moved.origin == before.origin and moved.moved and not before.moved
    assert not np.shares_memory(moved.points, before.points)  # the parent state is untouched
    np.testing.assert_allclose(before.points[:, :2].mean(axis=0), [0.2, 0.1], atol=0.01)


def test_move_back_restores_points():
    obj = _disc("a", 0.1, 0.05)
    there = move_object(obj, 0.2, -0.1, 0.7)
    back = move_object(there, 0.1, 0.05, -0.7)
    np.testing.assert_allclose(back.points, obj.points, atol=1e-12)


def test_placement_validity(workspace):
    state = PlanningState((_disc("a", 0.1, 0.0), _disc("t", 0.25, 0.0)), "t")
    assert placement_valid(state, 0, 0.1, 0.15, 0.0, workspace)
    assert not placement_valid(state, 0, 0.24, 0.03, 0.0, workspace)  # onto the target
    assert not placement_valid(state, 0, 0.01, 0.0, 0.0, workspace)  # over the front edge
    assert not placement_valid(state, 0, 0.1, 0.24, 0.0, workspace)  # into the side wall


def test_workspace_grid_and_empty_cells(workspace):
    scenario = Scenario()
    assert len(workspace.cell_centres) == scenario.grid.cells_x * scenario.grid.cells_y
    m = scenario.grid.margin
    assert workspace.cell_centres[:, 0].min() > m and workspace.cell_centres[:, 0].max() < 0.32 - m
    assert np.abs(workspace.cell_centres[:, 1]).max() < 0.25 - m
    cell = workspace.cell_centres[7]
    state = PlanningState((_disc("a", *cell, r=0.025),), "a")
    assert empty_cell_count(state, workspace) == len(workspace.cell_centres) - 1
    far = PlanningState((_disc("a", cell[0], cell[1], r=0.001),), "a")
    assert empty_cell_count(far, workspace) == len(workspace.cell_centres) - 1


def test_edge_margin_keeps_perceived_placements_off_the_floor_edges(workspace):
    from tsad_drake.planning.feasibility import GeometricFeasibility

    front_cell = int(np.argmin(workspace.cell_centres[:, 0] + workspace.cell_centres[:, 1]))
    x, y = workspace.cell_centres[front_cell]
    radius = x - 0.0005  # the disc placed there ends 0.5 mm inside the front edge
    state = PlanningState((_disc("a", 0.2, 0.0, r=radius, n=400), _disc("t", 0.25, 0.18, r=0.02)),
                          "t")
    exact = GeometricFeasibility(workspace, placement_gap=0.003, edge_margin=0.0)
    margin = GeometricFeasibility(workspace, placement_gap=0.003, edge_margin=0.001)
    assert not np.isnan(exact.place_options(state, 0, 0.0)[front_cell])
    assert np.isnan(margin.place_options(state, 0, 0.0)[front_cell])
    assert GeometricFeasibility(workspace).edge_margin > 0.0  # the perceived model's default


def test_fit_margin_refuses_perceived_widths_just_under_the_stroke(workspace):
    from tsad_drake.planning.feasibility import GeometricFeasibility

    limit = workspace.stroke - workspace.grasp_margin
    radius = (limit - 0.0005) / 2  # seen 0.5 mm narrower than the grasp limit at every angle
    state = PlanningState((_disc("a", 0.15, 0.0, r=radius, n=400), _disc("t", 0.25, 0.18, r=0.02)),
                          "t")
    exact = GeometricFeasibility(workspace, fit_margin=0.0)
    margin = GeometricFeasibility(workspace, fit_margin=0.001)
    assert exact.reachable(state, 0).any()
    assert not margin.reachable(state, 0).any() and not margin.pickable(state, 0).any()
    # another name: hulls and geometry are cached by name and pose
    narrow = PlanningState((_disc("b", 0.15, 0.0, r=radius - 0.001, n=400), state.objects[1]), "t")
    assert margin.reachable(narrow, 0).any()  # 2.5 mm under the limit still fits
    assert GeometricFeasibility(workspace).fit_margin > 0.0  # the perceived model's default


def test_a_fitted_cylinders_hull_contains_its_circle_however_little_of_it_was_seen():
    from tsad_drake.planning.pointcloud_sim import footprint_hull

    r, centre = 0.032, np.array([0.2, 0.05])
    arc = np.radians(np.linspace(160, 200, 5))  # 5 points of the front, 40 degrees of arc
    pts = np.column_stack([centre[0] + r * np.cos(arc), centre[1] + r * np.sin(arc),
                           np.full(5, 0.1)])
    bare = PlanObject("c", pts, *centre, 0.0, origin=(*centre, 0.0))
    fitted = PlanObject("c", pts, *centre, 0.0, origin=(*centre, 0.0), shape="cylinder", size=(r,))
    angles = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    dirs = np.stack([np.cos(angles), np.sin(angles)])
    support = ((footprint_hull(fitted) - centre) @ dirs).max(axis=0)  # per direction
    assert support.min() >= r - 1e-9  # the whole circle is inside
    assert support.max() <= r / np.cos(np.pi / 24) + 1e-9  # by at most the polygon's corners
    assert ((footprint_hull(bare) - centre) @ dirs).max(axis=0).min() < 0.5 * r  # points: a sliver
    # the polygon moves with the object
    moved = move_object(fitted, 0.1, -0.1, 0.4)
    assert ((footprint_hull(moved) - [0.1, -0.1]) @ dirs).max(axis=0).min() >= r - 1e-9
