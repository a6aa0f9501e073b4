"""World model on hand-built true scenes: falls, too-wide picks, out-of-workspace, retrieval."""

import numpy as np
import pytest

from tsad_drake.execution.world import GeometricWorld
from tsad_drake.planning.types import Action
from tsad_drake.scenario import ObjectConfig, Scenario


def _cyl(name, x, y, r=0.03):
    return ObjectConfig(name=name, kind="cylinder", shape="cylinder", size=[r, 0.15], x=x, y=y)


def _scene(*objects, target="target"):
    return Scenario(name="hand", objects=list(objects), target=target)


def test_approach_sweeping_through_a_neighbour_knocks_it_over_once():
    # the gripper's 55 mm half-width corridor to `a` at 0 deg also covers `n` beside it
    world = GeometricWorld(_scene(_cyl("target", 0.27, -0.15), _cyl("a", 0.20, 0.05),
                              _cyl("n", 0.12, 0.11)))
    world.execute(Action("a", 0.0, 0.07, -0.05, 0.0))
    assert world.fallen == ["n"] and world.relocations == 1 and not world.failure
    assert world.object("a").x == pytest.approx(0.07)
    world.execute(Action("a", 0.0, 0.20, 0.05, 0.0))  # back along the same corridor: counted once
    assert world.outcome().falls == 1 and world.num_actions == 2


def test_too_wide_object_tips_over_and_target_fall_fails():
    wide = ObjectConfig(name="w", kind="large", shape="box", size=[0.11, 0.11, 0.15], x=0.1, y=0.1)
    world = GeometricWorld(_scene(_cyl("target", 0.27, 0.1), wide))
    world.execute(Action("w", 0.0, 0.1, -0.15, 0.0))
    assert world.fallen == ["w"] and world.relocations == 0 and world.num_actions == 1
    world = GeometricWorld(_scene(_cyl("target", 0.27, 0.12), _cyl("a", 0.24, 0.04)))
    world.execute(Action("a", 0.0, 0.1, -0.15, 0.0))  # reaching past `a` clips the target
    assert world.outcome().reason == "target fell" and not world.retrieve()


def test_placement_out_of_workspace_and_overlap():
    world = GeometricWorld(_scene(_cyl("target", 0.27, 0.15), _cyl("a", 0.08, -0.05)))
    world.execute(Action("a", 0.0, 0.01, -0.05, 0.0))
    assert world.outcome().reason == "object out of workspace"
    world = GeometricWorld(_scene(_cyl("target", 0.27, 0.17), _cyl("a", 0.08, -0.17),
                              _cyl("b", 0.20, -0.02)))
    world.execute(Action("a", 0.0, 0.20, 0.03, 0.0))  # dropped onto b: b falls
    assert "b" in world.fallen


def test_retrieval_and_turning_with_the_gripper():
    box = ObjectConfig(name="r", kind="rectangular", shape="box", size=[0.12, 0.045, 0.15],
                       x=0.08, y=-0.15, yaw=0.0)
    world = GeometricWorld(_scene(_cyl("target", 0.25, 0.1), box))
    assert world.retrieval_angle() is not None
    world.execute(Action("r", 0.0, 0.09, -0.05, np.radians(20)))
    assert world.object("r").yaw == pytest.approx(np.radians(20)) and not world.fallen
    assert world.retrieve() and world.outcome().success and world.outcome().num_actions == 2
