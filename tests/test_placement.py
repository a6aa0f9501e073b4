"""The station placed for the shelf: from where the robot stands, every grid cell is reached at
every approach angle (each IK answer re-checked by forward kinematics), or one line names the
cells out of reach; grids scale with the shelf unless the scene sets them."""

import dataclasses as dc
import json
import math

import numpy as np
import pytest
from cli_harness import assert_clean, invoke

from tsad_drake.motion.keyframes import keyframe_targets, pose_errors
from tsad_drake.motion.scene import MotionConfig, MotionModel
from tsad_drake.placement import PlacementError, grasps, place_station, probe_at
from tsad_drake.plan_format import plan_json
from tsad_drake.planning.types import Action
from tsad_drake.scenario import (
    GridConfig,
    ObjectConfig,
    Scenario,
    ShelfConfig,
    load_scenario,
    save_scenario,
)
from tsad_drake.station import StationConfig
from tsad_drake.verification import verify_plan


def wide_shelf(floor_height: float) -> Scenario:
    shelf = ShelfConfig(width=0.90, floor_height=floor_height)
    return Scenario(name="wide", shelf=shelf, grid=GridConfig.for_shelf(shelf))


def assert_reaches_every_cell(scenario: Scenario, placement) -> None:
    """Every (cell, angle) grasp has pre-grasp and grasp solutions that put the tcp where asked
    (forward kinematics), within the joint limits, collision-free unless reported as contact."""
    config = MotionConfig()
    X_WS = placement.station.X_WS(scenario.shelf.floor_height)
    model = MotionModel(scenario.shelf, X_WS, [], config)
    low, high = model.plant.GetPositionLowerLimits(), model.plant.GetPositionUpperLimits()
    expected = grasps(scenario)
    assert len(expected) == placement.report.checked > 100
    assert not placement.report.unreachable and not placement.report.views
    for grasp in expected:
        targets = keyframe_targets(probe_at(grasp.x, grasp.y), grasp.theta, grasp.x, grasp.y,
                                   grasp.theta, config)
        for name in ("pre_grasp", "grasp"):
            q = placement.report.solutions[(grasp, name)]
            position, angle = pose_errors(model, q, X_WS @ targets[name])
            assert position < 2e-4 and angle < math.radians(0.2), (grasp, name, position, angle)
            assert np.all(q >= low - 1e-9) and np.all(q <= high + 1e-9)
            if grasp not in placement.report.contact:
                assert model.checker.CheckConfigCollisionFree(q), (grasp, name)


def test_a_09_m_shelf_is_reached_from_the_default_station():
    scenario = wide_shelf(0.10)
    assert (scenario.grid.cells_x, scenario.grid.cells_y) == (4, 12)  # cells of the paper's size
    placement = place_station(scenario)
    assert not placement.moved and placement.station.shelf_distance == StationConfig().shelf_distance
    assert_reaches_every_cell(scenario, placement)
    assert place_station(scenario) is placement  # found once per shelf


def test_a_high_09_m_shelf_moves_the_robot_and_plans_execute_there():
    scenario = wide_shelf(0.50)
    placement = place_station(scenario)
    # from the default 0.70 m the far corners are out of reach; the robot steps closer
    assert placement.moved and placement.station.shelf_distance < 0.70
    assert_reaches_every_cell(scenario, placement)
    # a relocation on that shelf verifies at the motion level from where the robot now stands
    scene = dc.replace(scenario, target="target", objects=[
        ObjectConfig(name="front", shape="cylinder", size=[0.03, 0.15], x=0.08, y=0.30),
        ObjectConfig(name="target", shape="cylinder", size=[0.03, 0.13], x=0.25, y=0.30)])
    report = verify_plan(scene, [Action("front", 0.0, 0.08, 0.10, 0.0)], world="none",
                         retrieve_target=True)
    assert report.success, report.to_json()
    assert all(m.verified for m in report.motions)


def test_a_shelf_out_of_reach_is_refused_in_one_line_naming_the_cells(tmp_path, capsys):
    shelf = ShelfConfig(depth=0.32, width=0.5, floor_height=1.4)
    scene = Scenario(name="high", shelf=shelf, grid=GridConfig(cells_x=2, cells_y=2),
                     approach_angles_deg=[-10.0, 0.0, 10.0], target="target", objects=[
                         ObjectConfig(name="front", shape="cylinder", size=[0.03, 0.15], x=0.08),
                         ObjectConfig(name="target", shape="cylinder", size=[0.03, 0.13],
                                      x=0.25)])
    with pytest.raises(PlacementError, match=r"12 of 12 cell-angle grasps are out of the arm's reach "
                                               r"\(cell \(1, [01]\) at -10/\+0/\+10 deg"):
        place_station(scene)
    save_scenario(scene, tmp_path / "scene.yaml")
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps(plan_json("scene.yaml", [Action("front", 0.0, 0.08, 0.15, 0.0)])))
    code, _, err = invoke(capsys, ["verify", plan, "--out", tmp_path / "out"])
    assert_clean((code, "", err))
    assert code == 2 and "no robot placement reaches the whole 0.50 x 0.32 m shelf" in err
    assert not (tmp_path / "out" / "report.json").exists()


def test_grid_scales_with_the_shelf_unless_the_scene_sets_it(tmp_path):
    shelf = ShelfConfig(depth=0.40, width=0.75)
    scene = Scenario(name="wide", shelf=shelf, target="target", objects=[
        ObjectConfig(name="target", shape="cylinder", size=[0.03, 0.13], x=0.25)])
    save_scenario(scene, tmp_path / "set.yaml")  # the dump writes the 4 x 6 counts: kept
    kept = load_scenario(tmp_path / "set.yaml").grid
    assert (kept.cells_x, kept.cells_y) == (4, 6)
    text = (tmp_path / "set.yaml").read_text()
    unset = "\n".join(line for line in text.splitlines()
                      if not line.strip().startswith(("cells_x", "cells_y")))
    (tmp_path / "unset.yaml").write_text(unset)
    grid = load_scenario(tmp_path / "unset.yaml").grid
    assert (grid.cells_x, grid.cells_y) == (5, 9)  # 0.33 x 0.68 m inside the margin
    assert GridConfig.for_shelf(ShelfConfig()) == GridConfig()  # the paper's shelf: its grid
