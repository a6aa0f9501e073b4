"""Contact is not overlap (issue 38): touching objects load, deeper interpenetration is refused
with its depth, and every layer (planners' corridors, world rule, perception, physics) treats a
touching neighbour as a neighbour."""

import dataclasses as dc
import math

import numpy as np
import pytest
from touching_scenes import box, cylinder, touching_scene

from tsad_drake.errors import ScenarioError
from tsad_drake.execution.world import GeometricWorld
from tsad_drake.geometry2d import (
    convex_polygon_penetration,
    footprint_penetration,
    footprint_polygon,
)
from tsad_drake.perception.observe import interpenetration, observe_raycast, perception_config
from tsad_drake.perception.sensor import sensor_config
from tsad_drake.planning.feasibility import GeometricFeasibility, OracleFeasibility
from tsad_drake.planning.state import make_workspace, true_state
from tsad_drake.planning.types import Action
from tsad_drake.scenario import CONTACT_TOLERANCE, Scenario, interpenetrations, validate


def test_penetration_depth_of_polygons_is_the_minimum_translation():
    a = footprint_polygon("box", [0.05, 0.04], 0.0, 0.0, 0.0)
    assert convex_polygon_penetration(a, footprint_polygon("box", [0.05, 0.04], 0.047, 0.01,
                                                           0.0)) == pytest.approx(0.003)
    assert convex_polygon_penetration(a, footprint_polygon("box", [0.05, 0.04], 0.05, 0.0,
                                                           0.0)) == 0.0  # touching
    apart = footprint_polygon("box", [0.05, 0.04], 0.06, 0.0, 0.0)
    assert convex_polygon_penetration(a, apart) == 0.0
    assert convex_polygon_penetration(a, apart, signed=True) == pytest.approx(-0.01)
    # a turned square's corner pushed 2 mm into a face: the depth is along the face normal
    corner = 0.025 * math.sqrt(2)
    turned = footprint_polygon("box", [0.05, 0.05], 0.025 + corner - 0.002, 0.0, math.pi / 4)
    assert convex_polygon_penetration(a, turned) == pytest.approx(0.002)


def test_penetration_of_discs_uses_the_true_circle():
    disc = ("cylinder", [0.03, 0.1], 0.0, 0.0, 0.0)
    for angle in np.linspace(0.0, math.pi, 7):  # touching discs in any direction: zero
        other = ("cylinder", [0.04, 0.1], 0.07 * math.cos(angle), 0.07 * math.sin(angle), 0.0)
        assert footprint_penetration(disc, other) == pytest.approx(0.0, abs=1e-12)
    assert footprint_penetration(disc, ("cylinder", [0.04, 0.1], 0.068, 0.0, 0.0)) == (
        pytest.approx(0.002))
    square = ("box", [0.05, 0.05, 0.1], 0.0, 0.0, 0.0)
    assert footprint_penetration(square, ("cylinder", [0.03, 0.1], 0.055, 0.0, 0.0)) == 0.0
    assert footprint_penetration(("cylinder", [0.03, 0.1], 0.053, 0.0, 0.0), square) == (
        pytest.approx(0.002))
    # the disc's centre inside the box: the radius plus the way out
    assert footprint_penetration(square, ("cylinder", [0.01, 0.1], 0.02, 0.0, 0.0)) == (
        pytest.approx(0.015))
    # beside a box corner, off its faces' lines: apart although the projections overlap
    assert footprint_penetration(square, ("cylinder", [0.01, 0.1], 0.034, 0.034, 0.0)) == 0.0


def test_touching_scene_loads_and_deeper_overlap_is_refused_with_the_pair_and_depth():
    validate(touching_scene())
    validate(touching_scene(-0.9 * CONTACT_TOLERANCE))  # within the tolerance: contact
    deep = touching_scene(-0.002)
    assert [(i, j) for i, j, _ in interpenetrations(deep)] == [(0, 1), (2, 3)]
    with pytest.raises(ScenarioError) as err:
        validate(deep)
    message = str(err.value)
    assert "objects[0] (front_box) and objects[1] (back_box)" in message
    assert "2.0 mm" in message and "\n" not in message
    validate(deep, overlaps=False)  # a scene to settle


def _index(scenario: Scenario, name: str) -> int:
    return [o.name for o in scenario.objects].index(name)


@pytest.mark.parametrize("model", ["oracle", "geometric"])
def test_a_touching_neighbour_blocks_only_from_in_front(model):
    scenario = touching_scene()
    workspace = make_workspace(scenario)
    feasibility = (OracleFeasibility(scenario, workspace) if model == "oracle"
                   else GeometricFeasibility(workspace))
    state = true_state(scenario)
    front, back = _index(scenario, "front_box"), _index(scenario, "back_box")
    straight = int(np.argmin(np.abs(workspace.approach_angles)))
    assert back not in feasibility.blockers(state, front)[straight]
    assert feasibility.pickable(state, front)[straight]
    assert front in feasibility.blockers(state, back)[straight]
    target, blocker = _index(scenario, "target"), _index(scenario, "blocker")
    assert feasibility.pickable(state, blocker)[straight]
    assert all(blocker in hits for hits in feasibility.blockers(state, target))


def test_picking_a_touching_object_leaves_the_one_behind_standing():
    world = GeometricWorld(touching_scene())
    outcome = world.execute(Action("front_box", 0.0, 0.10, -0.19, 0.0))
    assert outcome.moved and outcome.fallen == []
    world.execute(Action("blocker", 0.0, 0.06, 0.19, 0.0))
    assert world.fallen == [] and world.retrieve()
    # picking the one behind first sweeps the fingers through the one in front
    behind = GeometricWorld(touching_scene())
    assert behind.execute(Action("back_box", 0.0, 0.10, -0.19, 0.0)).fallen == ["front_box"]


def _distinct_heights_scene() -> Scenario:
    """A box with a lower box touching its left side and a cylinder touching its right side."""
    scenario = Scenario(name="touching-sides", objects=[
        box("middle", 0.15, 0.0), box("left", 0.15, 0.05, height=0.11),
        cylinder("target", 0.15, -0.055, height=0.12)], target="target")
    validate(scenario)
    return scenario


@pytest.mark.parametrize("sensor_name", ["ideal", "realistic"])
def test_cluster_segmentation_keeps_touching_objects_of_distinct_heights_apart(sensor_name):
    scenario = _distinct_heights_scene()
    sensor = sensor_config(sensor_name)
    obs = observe_raycast(scenario, segmentation="cluster", config=perception_config(sensor),
                          sensor=sensor)
    owners = []
    for seg in obs.segments:  # each segment is (almost) one true object's points
        labels, counts = np.unique(obs.cloud.labels[seg.indices], return_counts=True)
        assert counts.max() >= 0.9 * counts.sum()
        owners.append(int(labels[np.argmax(counts)]))
    assert sorted(owners) == [0, 1, 2]
    fitted = [o.outline for o in obs.scene.objects if o.outline is not None]
    join_depth = perception_config(sensor).footprint.join_depth
    for i, a in enumerate(fitted):  # the fitted outlines touch well within the joining depth
        for b in fitted[:i]:
            assert interpenetration(a, b) < join_depth / 2


def test_touching_objects_of_one_height_in_a_row_are_one_cluster():
    """The limit of depth-only segmentation (docs/known-issues.md): two equal boxes pressed
    side to side show one continuous top and front, so the cluster mode sees one object."""
    scenario = Scenario(name="twins", objects=[box("a", 0.15, 0.0), box("b", 0.15, 0.05),
                                              cylinder("target", 0.25, -0.15)], target="target")
    validate(scenario)
    obs = observe_raycast(scenario, segmentation="cluster")
    assert len(obs.segments) == 2


def test_settled_scene_keeps_everything_but_the_poses():
    from tsad_drake.physics.settle import settle_scene

    deep = touching_scene(-0.002)
    settled, report = settle_scene(deep)
    validate(settled)
    assert interpenetrations(settled, tolerance=0.0005) == []
    assert [r.name for r in report] == [o.name for o in deep.objects]
    for before, after, moved in zip(deep.objects, settled.objects, report):
        assert dc.replace(after, x=before.x, y=before.y, yaw=before.yaw) == before
        assert moved.moved_mm == pytest.approx(1000 * math.hypot(after.x - before.x,
                                                                 after.y - before.y))
        assert 0.3 < moved.moved_mm < 2.0 and moved.tilt_deg < 1.0  # pushed apart, upright
    assert dc.replace(settled, objects=deep.objects) == deep


def test_touching_scene_rests_in_the_contact_simulation():
    """Objects touching at the start do not push each other away: 1 s from rest moves none of
    them by more than 0.1 mm."""
    from tsad_drake.physics.settle import settle_scene

    _, report = settle_scene(touching_scene())
    assert max(r.moved_mm for r in report) < 0.1
    assert max(r.tilt_deg for r in report) < 0.2
