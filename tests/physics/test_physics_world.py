"""The physics world: pick-and-places simulated with contact in Drake, outcomes measured.

Hand-built scenes (no generator); the simulations are deterministic (fixed step, no noise).
"""

import json
import math

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix

from tsad_drake.perception.types import PerceivedObject, PerceivedScene
from tsad_drake.physics.config import PhysicsConfig
from tsad_drake.physics.outcome import body_pose, relative_slip, yaw_error_deg
from tsad_drake.physics.world import PhysicsWorld, lying_footprint
from tsad_drake.planning.types import Action
from tsad_drake.scenario import ObjectConfig, Scenario, validate


def _scene(objects, name="physics-test", target="target") -> Scenario:
    scenario = Scenario(name=name, objects=objects, target=target)
    validate(scenario)
    return scenario


def _cylinder(name, x, y, height=0.15):
    return ObjectConfig(name=name, kind="cylinder", shape="cylinder", size=[0.03, height], x=x, y=y)


@pytest.fixture(scope="module")
def placed():
    """One pick-and-place of `front` to (0.08, 0.16) in a four-object scene, then an observation."""
    scenario = _scene([
        _cylinder("front", 0.08, 0.0),
        ObjectConfig(name="box", kind="square_pillar", shape="box", size=[0.045, 0.045, 0.14],
                     x=0.20, y=0.10, yaw=0.3),
        _cylinder("side", 0.18, -0.12, 0.16),
        _cylinder("target", 0.25, 0.0, 0.13)])
    world = PhysicsWorld(scenario)
    before = world.poses()
    outcome = world.execute(Action("front", 0.0, 0.08, 0.16, 0.0))
    return world, before, outcome, world.observe()


def test_pick_and_place_moves_the_object_to_the_place_point(placed):
    world, before, outcome, _ = placed
    assert outcome.moved, outcome.reason
    assert outcome.aimed_at == "true"  # nothing observed yet
    assert outcome.lifted
    assert outcome.placement_error_mm < 5.0
    assert outcome.slip_mm < 3.0
    assert outcome.tracking_error < world.config.tracking_tolerance
    assert outcome.fallen == [] and outcome.disturbed == []
    after = world.poses()
    assert math.hypot(after["front"].x - 0.08, after["front"].y - 0.16) < 0.005
    assert after["front"].tilt_deg < 2.0
    for name in ("box", "side", "target"):  # the neighbours stand where they stood
        assert math.hypot(after[name].x - before[name].x, after[name].y - before[name].y) < 0.002
        assert after[name].tilt_deg < 1.0
    assert world.relocations == 1 and world.num_actions == 1 and not world.fallen
    assert outcome.sim_seconds > 1.0 and outcome.wall_seconds > 0.0


def test_the_same_action_gives_the_same_physics_outcome_twice(placed):
    """Deterministic: a fresh world executing the same action ends in the same state."""
    world, _, outcome, _ = placed
    again = PhysicsWorld(world._start)
    repeat = again.execute(Action("front", 0.0, 0.08, 0.16, 0.0))
    assert (repeat.moved, repeat.fallen, repeat.disturbed) == (outcome.moved, outcome.fallen,
                                                               outcome.disturbed)
    assert repeat.placement_error_mm == pytest.approx(outcome.placement_error_mm, abs=1e-6)
    assert repeat.slip_mm == pytest.approx(outcome.slip_mm, abs=1e-6)
    first, second = world.poses(), again.poses()
    for name in first:
        assert first[name].x == pytest.approx(second[name].x, abs=1e-9), name
        assert first[name].y == pytest.approx(second[name].y, abs=1e-9), name


def test_next_observation_is_rendered_from_the_simulated_state(placed):
    world, _, _, scene = placed
    front = next(o for o in scene.objects if o.name == "front")
    assert math.hypot(front.x - 0.08, front.y - 0.16) < 0.01  # seen where physics left it
    assert scene.target == "target"
    truth = world.scenario().object("front")
    assert math.hypot(truth.x - 0.08, truth.y - 0.16) < 0.005


def test_second_action_aims_at_the_perceived_poses(placed):
    world, _, _, _ = placed
    objects, aimed_at = world.believed_objects("side")
    assert aimed_at == "perceived"
    side = next(o for o in objects if o.name == "side")
    assert side.size[0] == pytest.approx(0.03, abs=0.003)  # the fitted radius, not the true one
    assert side.height == pytest.approx(0.16, abs=0.005)


def test_retrieval_carries_the_target_out_of_the_shelf(placed):
    world = placed[0]
    assert world.retrieve() and world.success
    outcome = world.retrieval
    assert outcome.moved and outcome.lifted and outcome.fallen == []
    assert world.poses()["target"].x < 0.0  # in the gripper, in front of the shelf
    assert world.num_actions == 2 and world.outcome().success


def test_a_retrieval_without_motion_ends_the_episode_naming_each_refused_angle():
    # a box 0.11 m across at every angle: wider than the 85 mm stroke, no angle has a motion
    box = ObjectConfig(name="target", kind="rectangular", shape="box", size=[0.11, 0.11, 0.12],
                       x=0.20, y=0.0)
    scenario = _scene([box], name="too-wide-target")
    world = PhysicsWorld(scenario)
    assert not world.retrieve() and not world.success
    assert world.num_actions == 0 and world.done  # nothing simulated, and the episode is over
    reason = world.outcome().reason
    assert reason.startswith("no retrieval motion: every angle refused")
    assert reason.count(" deg ") == len(scenario.approach_angles) and "width" in reason


def test_unseen_object_in_the_approach_is_knocked_over_and_named():
    # the robot saw only `pick` and the target: its motion goes straight through `blocker`
    scenario = _scene([
        _cylinder("pick", 0.20, 0.0),
        ObjectConfig(name="blocker", kind="rectangular", shape="box", size=[0.03, 0.03, 0.20],
                     x=0.08, y=0.01),
        _cylinder("target", 0.26, 0.15, 0.13)], name="unseen-blocker")
    world = PhysicsWorld(scenario)
    world.believe(PerceivedScene([
        PerceivedObject("pick", np.array([[0.20, 0.0, 0.15]]), 0.20, 0.0, 0.0, shape="cylinder",
                        size=(0.03,)),
        PerceivedObject("target", np.array([[0.26, 0.15, 0.13]]), 0.26, 0.15, 0.0,
                        is_target=True, shape="cylinder", size=(0.03,))], "target"))
    outcome = world.execute(Action("pick", 0.0, 0.10, -0.15, 0.0))
    assert outcome.aimed_at == "perceived"
    assert "blocker" in outcome.fallen
    assert not outcome.moved and outcome.reason
    assert world.outcome().falls == len(world.fallen) >= 1
    assert not world.failure  # the target still stands
    lying = world.scenario().object("blocker")  # its true footprint is now the lying one
    assert lying.shape == "box" and lying.height < 0.05 and max(lying.size[:2]) > 0.15
    scene = world.observe()
    blocker = next(o for o in scene.objects if o.name == "blocker")
    assert np.max(blocker.points[:, 2]) < 0.05  # seen lying on the floor


def test_body_pose_tilt_and_yaw():
    R = RotationMatrix.MakeXRotation(math.radians(30)) @ RotationMatrix.MakeZRotation(0.0)
    pose = body_pose(RigidTransform(RotationMatrix.MakeZRotation(0.4), [0.1, 0.2, 0.05]))
    assert pose.tilt_deg == pytest.approx(0.0, abs=1e-9) and pose.yaw == pytest.approx(0.4)
    assert body_pose(RigidTransform(R, [0, 0, 0])).tilt_deg == pytest.approx(30.0)


def test_yaw_error_respects_symmetry():
    box = ObjectConfig(name="b", shape="box", size=[0.04, 0.06, 0.1])
    square = ObjectConfig(name="s", shape="box", size=[0.05, 0.05, 0.1])
    cylinder = ObjectConfig(name="c", shape="cylinder", size=[0.03, 0.1])
    assert yaw_error_deg(box, math.pi + 0.1, 0.0) == pytest.approx(math.degrees(0.1))
    assert yaw_error_deg(square, math.pi / 2 - 0.1, 0.0) == pytest.approx(math.degrees(0.1))
    assert yaw_error_deg(cylinder, 2.0, 0.0) == 0.0


def test_slip_is_relative_motion_in_the_gripper():
    a = RigidTransform([0.0, 0.0, 0.1])
    b = RigidTransform(RotationMatrix.MakeZRotation(math.radians(5)), [0.0, 0.003, 0.1])
    mm, deg = relative_slip(a, b)
    assert mm == pytest.approx(3.0) and deg == pytest.approx(5.0)


def test_a_degenerate_perceived_fit_becomes_a_solid_the_motion_level_can_build():
    from tsad_drake.physics.world import MIN_BELIEVED_SIZE, believed_object
    points = np.array([[0.20, 0.0, 0.12], [0.21, 0.0, 0.10], [0.20, 0.004, 0.11]])
    sliver = PerceivedObject("obj1", points, 0.20, 0.0, 0.0, shape="cylinder", size=(0.0,))
    obj = believed_object(sliver, "obj1")
    assert obj.size[0] == pytest.approx(0.01) and obj.height == pytest.approx(0.12)
    flat = PerceivedObject("obj2", points[:1], 0.20, 0.0, 0.0, shape="box", size=(0.0, 0.04))
    box = believed_object(flat, "obj2")
    assert box.size[:2] == [MIN_BELIEVED_SIZE, 0.04]
    fine = PerceivedObject("obj3", points, 0.20, 0.0, 0.0, shape="cylinder", size=(0.03,))
    assert believed_object(fine, "obj3").size[0] == 0.03  # a sound fit is kept as it is


def test_lying_cylinder_footprint():
    obj = ObjectConfig(name="c", shape="cylinder", size=[0.03, 0.15])
    X = RigidTransform(RotationMatrix.MakeYRotation(math.pi / 2), [0.1, 0.0, 0.03])
    box = lying_footprint(obj, body_pose(X))
    assert box.shape == "box" and box.height == pytest.approx(0.06)
    assert sorted(box.size[:2]) == pytest.approx([0.06, 0.15], abs=1e-3)
    assert (box.x, box.y) == pytest.approx((0.1, 0.0))


def test_object_fallen_out_of_the_shelf_keeps_a_valid_shape():
    """A box lying on the ground below the shelf floor (scenario 2 seed 26 of ROTS in physics
    once aborted the process in Drake's Box() with height -0.054) gets a token slab, and a
    non-positive size raises ValueError in Python instead of reaching Drake."""
    from tsad_drake.physics.world import MIN_BELIEVED_SIZE
    from tsad_drake.station_models import object_shape
    obj = ObjectConfig(name="b", shape="box", size=[0.04, 0.06, 0.12])
    X = RigidTransform(RotationMatrix.MakeXRotation(math.pi / 2), [-0.05, 0.0, -0.09])
    box = lying_footprint(obj, body_pose(X))
    assert box.height == pytest.approx(MIN_BELIEVED_SIZE)
    assert object_shape(box).height() == pytest.approx(MIN_BELIEVED_SIZE)
    with pytest.raises(ValueError, match="height <= 0"):
        object_shape(ObjectConfig(name="b", shape="box", size=[0.04, 0.06, -0.054]))


def test_config_validation():
    with pytest.raises(ValueError):
        PhysicsConfig(contact_model="soft")
    with pytest.raises(ValueError):
        PhysicsConfig(arm_kp=(1.0,))


def test_weak_gains_without_gravity_feed_forward_are_reported_as_untracked():
    scenario = _scene([_cylinder("front", 0.08, 0.0), _cylinder("target", 0.25, 0.0, 0.13)],
                      name="weak-arm")
    config = PhysicsConfig(arm_kp=(300.0,) * 6, arm_kd=(30.0,) * 6, gravity_compensation=False)
    world = PhysicsWorld(scenario, config)
    outcome = world.execute(Action("front", 0.0, 0.08, 0.16, 0.0))
    assert outcome.tracking_error > config.tracking_tolerance
    assert "could not track" in outcome.reason and outcome.tracking_joint in outcome.reason


def test_weld_grasp_switches_on_when_both_fingers_touch_and_holds_without_slip():
    # a square box turned 32 degrees to the jaws: friction alone lets it turn in the grasp
    box = ObjectConfig(name="box", kind="square_pillar", shape="box", size=[0.054, 0.054, 0.13],
                       x=0.12, y=0.0, yaw=math.radians(32))
    scenario = _scene([box, _cylinder("target", 0.26, 0.05, 0.13)], name="weld")
    world = PhysicsWorld(scenario, PhysicsConfig(grasp_mode="weld"))
    outcome = world.execute(Action("box", 0.0, 0.10, -0.12, 0.0))
    assert outcome.welded and outcome.moved, outcome.reason
    assert outcome.slip_mm < 0.5 and outcome.placement_error_mm < 3.0
    assert outcome.placement_error_deg < 2.0
    assert not world.sim.plant.GetConstraintActiveStatus(world.sim.plant_context, world.sim.weld)


@pytest.mark.slow
def test_hydroelastic_pick_and_place():
    scenario = _scene([_cylinder("front", 0.08, 0.0), _cylinder("target", 0.25, 0.0, 0.13)],
                      name="hydro")
    world = PhysicsWorld(scenario, PhysicsConfig(contact_model="hydroelastic"))
    outcome = world.execute(Action("front", 0.0, 0.08, 0.16, 0.0))
    assert outcome.moved and outcome.placement_error_mm < 5.0 and outcome.slip_mm < 3.0
    assert outcome.fallen == [] and outcome.disturbed == []


def test_replay_of_the_simulation_ends_where_physics_left_the_scene(placed, tmp_path):
    from tsad_drake.motion.replay import write_trace_html

    world = placed[0]
    times = [t for t, _ in world.trace]
    assert times[0] == 0.0 and all(b > a for a, b in zip(times, times[1:]))
    assert times[-1] == pytest.approx(world.sim.context.get_time())
    final = world.trace[-1][1]
    assert np.array_equal(final, world.sim.plant.GetPositions(world.sim.plant_context))
    page = world.write_replay(tmp_path / "physics_replay.html")
    assert page.stat().st_size > 10_000 and "front" in page.read_text()
    with pytest.raises(ValueError, match="positions"):  # a trace of another scene is refused
        write_trace_html(world._start, world.X_WS, [(0.0, final[:-1])], tmp_path / "bad.html")


def test_plan_on_physics_replays_what_happened_beside_what_was_planned(tmp_path, capsys):
    from cli_harness import invoke

    from tsad_drake.scenario import save_scenario

    save_scenario(_scene([_cylinder("front", 0.08, 0.0), _cylinder("target", 0.25, 0.0, 0.13)]),
                  tmp_path / "scene.yaml")
    code, out, err = invoke(capsys, ["plan", "--scenario", tmp_path / "scene.yaml", "--planner",
                                     "tsad", "--feasibility", "geometric", "--world", "physics",
                                     "--out", tmp_path / "o"])
    assert code == 0, (out, err)
    doc = json.loads((tmp_path / "o" / "plan.json").read_text())
    assert doc["world"] == "physics" and doc["success"] and doc["actions"][0]["physics"]["moved"]
    simulated = (tmp_path / "o" / "replay.html").read_text()
    planned = (tmp_path / "o" / "planned_replay.html").read_text()
    assert len(simulated) > 10_000 and len(planned) > 10_000 and simulated != planned
    assert "contact simulation as it ran" in out


def test_observation_of_the_physics_world_goes_through_the_sensor_model():
    """With the realistic sensor the rendered views are noisy: the same simulated state seen with
    two noise seeds gives different (but close) estimates, and one seed repeats exactly."""
    from tsad_drake.perception.observe import perception_config
    from tsad_drake.perception.sensor import sensor_config

    scenario = _scene([_cylinder("front", 0.10, 0.05), _cylinder("target", 0.24, -0.05, 0.13)])
    sensor = sensor_config("realistic")
    ideal = PhysicsWorld(scenario).observe()

    def seen(seed: int):
        world = PhysicsWorld(scenario, sensor=sensor, perception=perception_config(sensor),
                             noise_seed=seed)
        return {o.name: (o.x, o.y, o.size[0]) for o in world.observe().objects}

    first, again, other = seen(3), seen(3), seen(4)
    assert first == again
    assert first != other
    truth = {o.name: (o.x, o.y) for o in ideal.objects}
    for name, (x, y, _) in first.items():
        assert math.hypot(x - truth[name][0], y - truth[name][1]) < 0.01
