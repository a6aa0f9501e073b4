"""Scenario dataclasses, YAML I/O and the generator's invariants."""

import dataclasses as dc

import numpy as np
import pytest

from tsad_drake.execution.world import GeometricWorld
from tsad_drake.geometry2d import convex_polygon_distance, width_across
from tsad_drake.planners.optimal import plan_optimal
from tsad_drake.planning.feasibility import OracleFeasibility
from tsad_drake.planning.state import make_workspace, true_state
from tsad_drake.scenario import ScenarioError, load_scenario, save_scenario, validate
from tsad_drake.scenario_generator import (
    BUILTIN_SCENARIOS,
    removal_solvable,
    scenario_defaults,
    target_blockers,
)
from tsad_drake.scenes import generate_scenario, plan_solvable
from tsad_drake.viewpoints import CameraConfig, target_visibility

SCENES_PER_SCENARIO = 100


def _check_invariants(scenario):
    shelf, cfg = scenario_defaults(scenario.name)
    low, high = cfg.num_objects_range
    assert (low <= len(scenario.objects) <= high if high
            else len(scenario.objects) == cfg.num_objects)
    polys = [o.footprint() for o in scenario.objects]
    for obj, poly in zip(scenario.objects, polys):
        assert obj.height < shelf.height
        assert poly[:, 0].min() >= 0 and poly[:, 0].max() <= shelf.depth
        assert np.abs(poly[:, 1]).max() <= shelf.width / 2
    for i in range(len(polys)):
        for j in range(i + 1, len(polys)):
            assert convex_polygon_distance(polys[i], polys[j]) >= scenario.min_gap - 1e-9
    target = scenario.object(scenario.target)
    assert target.x >= cfg.target_depth_fraction * shelf.depth
    # the target itself fits the gripper from every angle; blockers must be moved first
    stroke = scenario.gripper.stroke - scenario.gripper.grasp_margin
    assert all(width_across(target.shape, target.size, target.yaw, th) <= stroke
               for th in scenario.approach_angles)
    assert min(len(target_blockers(scenario, th)) for th in scenario.approach_angles) >= 1
    visible = target_visibility(scenario, CameraConfig(), 0.0)
    if cfg.hidden_in_front:  # (tests/test_wide_scenario.py checks it is in view when alone)
        assert visible == 0.0
    else:
        assert cfg.min_visible <= visible <= cfg.max_visible
    return cfg


def _unchecked(name):
    """The generator settings of scenario `name` without the (costly) solvability check."""
    return dc.replace(scenario_defaults(name)[1], solvable_nodes=0)


#: seeds the default suite checks per scenario (0.8 s a scene); the slow tests check the rest of
#: SCENES_PER_SCENARIO, and the `real` and `wide` layouts (not in the headline rows) entirely
#: (tests/test_wide_scenario.py checks eight wide scenes in the default suite)
DEFAULT_SCENES = 25


def _invariant_cases():
    for name in BUILTIN_SCENARIOS:
        if name not in ("real", "wide"):
            yield pytest.param(name, range(DEFAULT_SCENES), id=f"{name}-first")
        first = 0 if name in ("real", "wide") else DEFAULT_SCENES
        yield pytest.param(name, range(first, SCENES_PER_SCENARIO), id=f"{name}-rest",
                           marks=pytest.mark.slow)


@pytest.mark.parametrize(("name", "seeds"), _invariant_cases())
def test_generated_scenes_satisfy_invariants(name, seeds):
    # the solvability check is the generator's last test: skipping it keeps every other invariant
    kinds = []
    for seed in seeds:
        scenario = generate_scenario(name, seed, config=_unchecked(name))
        _check_invariants(scenario)
        kinds.extend(o.kind for o in scenario.objects)
    stroke = 0.085 - 0.005
    if name == "1":
        assert set(kinds) <= {"cylinder", "square_pillar"}
    if name == "2":
        assert "rectangular" in kinds
    if name == "3":
        assert kinds.count("large") == len(seeds)
    # what the kinds promise about the gripper
    for seed in range(5):
        for obj in generate_scenario(name, seed, config=_unchecked(name)).objects:
            widths = [width_across(obj.shape, obj.size, obj.yaw, np.radians(a))
                      for a in range(-30, 31, 10)]
            if obj.kind in ("cylinder", "square_pillar"):
                assert max(widths) <= stroke
            if obj.kind == "large":
                assert min(widths) > 0.085


def test_solvability_check_replaces_a_scene_with_no_room_for_its_blockers():
    # scenario 2 seed 17 without the check: the target (by the right wall) needs three blockers
    # moved and the scarce free cells cannot take them; removing objects alone would free it
    crowded = generate_scenario("2", 17, config=_unchecked("2"))
    assert removal_solvable(crowded)
    assert not plan_solvable(crowded, scenario_defaults("2")[1].solvable_nodes)
    scene = generate_scenario("2", 17)
    assert scene != crowded
    # the kept scene is solved by the optimal plan, checked in the world model on true shapes
    workspace = make_workspace(scene)
    oracle = OracleFeasibility(scene, workspace)
    plan = plan_optimal(true_state(scene), oracle, workspace)
    assert plan.success and plan.actions
    world = GeometricWorld(scene)
    for action in plan.actions:
        world.execute(action)
    assert not world.fallen and world.failure == ""
    assert world.retrieve() and world.outcome().success


def test_true_state_points_fill_each_footprint():
    scene = generate_scenario("3", 0, config=_unchecked("3"))
    state = true_state(scene)
    assert [o.name for o in state.objects] == [o.name for o in scene.objects]
    for obj, true in zip(state.objects, scene.objects):
        poly = true.footprint()
        assert obj.pose == (true.x, true.y, true.yaw)
        assert np.allclose(obj.points[:, 2], true.size[-1])
        # every point lies in the (counter-clockwise) footprint and the points span it
        edges = np.roll(poly, -1, axis=0) - poly
        rel = obj.points[:, None, :2] - poly[None, :, :]
        assert (edges[None, :, 0] * rel[:, :, 1] - edges[None, :, 1] * rel[:, :, 0] > -1e-12).all()
        assert np.allclose(obj.points[:, :2].min(axis=0), poly.min(axis=0))
        assert np.allclose(obj.points[:, :2].max(axis=0), poly.max(axis=0))


def test_same_seed_same_scene_and_different_seeds_differ():
    a, b, c = generate_scenario("2", 7), generate_scenario("2", 7), generate_scenario("2", 8)
    assert a == b
    assert a != c


@pytest.mark.parametrize("name", ["1", pytest.param("2", marks=pytest.mark.slow)])
def test_occluded_target_is_hidden_in_every_view_and_still_solvable(name):
    scenario = generate_scenario(name, 0, occluded=True)
    assert scenario.occluded
    for theta in scenario.approach_angles:
        assert target_visibility(scenario, CameraConfig(), theta) == 0.0
    # removing objects can free it, so random relocations that reveal it lead somewhere
    assert removal_solvable(scenario)


def test_yaml_round_trip(tmp_path):
    scenario = generate_scenario("3", 4)
    path = tmp_path / "scene.yaml"
    save_scenario(scenario, path)
    loaded = load_scenario(path)
    assert loaded == scenario


def test_malformed_and_impossible_yaml_raise_scenario_error(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("objects: [this is: not valid\n")
    with pytest.raises(ScenarioError):
        load_scenario(bad)
    unknown = tmp_path / "unknown.yaml"
    unknown.write_text("no_such_field: 3\n")
    with pytest.raises(ScenarioError):
        load_scenario(unknown)
    with pytest.raises(ScenarioError):
        load_scenario(tmp_path / "missing.yaml")


def test_validate_rejects_overlap_outside_and_bad_target():
    scenario = generate_scenario("1", 1)
    overlapping = dc.replace(scenario, objects=[dc.replace(o) for o in scenario.objects])
    overlapping.objects[1].x, overlapping.objects[1].y = scenario.objects[0].x, scenario.objects[0].y
    with pytest.raises(ScenarioError, match="overlap"):
        validate(overlapping)
    outside = dc.replace(scenario, objects=[dc.replace(o) for o in scenario.objects])
    outside.objects[0].x = -0.2
    with pytest.raises(ScenarioError, match="outside"):
        validate(outside)
    with pytest.raises(ScenarioError, match="target"):
        validate(dc.replace(scenario, target="nobody"))
