"""Motion level: IK keyframes, optimised segments, dense verification, plan.json export, replay."""

import copy
import json
import math

import numpy as np
import pytest
from pydrake.multibody.parsing import LoadModelDirectives, Parser, ProcessModelDirectives
from pydrake.multibody.plant import MultibodyPlant

from tsad_drake.motion.export import (
    motion_section,
    validate_motion_section,
    write_scene_directives,
)
from tsad_drake.motion.keyframes import keyframe_targets, pose_errors
from tsad_drake.motion.replay import replay_collisions, write_replay_html
from tsad_drake.motion.scene import Held, MotionConfig, MotionModel
from tsad_drake.motion.verify import motion_check, ready_q, transfer_segment, verify_plan
from tsad_drake.planning.types import Action
from tsad_drake.station import StationConfig
from tsad_drake.station_models import PACKAGE_XML, X_SO

ACTIONS = [Action("front", 0.0, 0.08, 0.16, 0.0),
           Action("side", math.radians(-10), 0.08, -0.16, math.radians(-10))]


@pytest.fixture(scope="module")
def motions(scene):
    return verify_plan(scene, ACTIONS)


@pytest.fixture(scope="module")
def section(scene, motions):
    # through JSON text, as plan.json would carry it
    return json.loads(json.dumps(motion_section(scene, motions)))


def test_actions_verified(motions):
    assert [m.verified for m in motions] == [True, True], [m.failure for m in motions]
    names = [s.name for s in motions[0].segments]
    assert names[:3] == ["start->pre_grasp", "pre_grasp->grasp", "close"]
    assert names[-2:] == ["open", "place->post_place"]
    # the second action starts where the first ended, on one time line
    assert np.allclose(motions[1].segments[0].q[0], motions[0].end_q)
    assert motions[1].segments[0].times[0] == pytest.approx(motions[0].segments[-1].times[-1])


def test_keyframes_forward_kinematics_and_clearance(scene, motions):
    config = MotionConfig()
    X_WS = StationConfig().X_WS(scene.shelf.floor_height)
    motion = motions[0]
    obj = scene.object(motion.action.object)
    a = motion.action
    targets = keyframe_targets(obj, a.theta_pick, a.x, a.y, a.theta_place, config)
    pick = MotionModel(scene.shelf, X_WS, motion.objects_before, config, near=obj.name)
    carry = MotionModel(scene.shelf, X_WS, motion.objects_before, config, Held(obj, motion.X_TO))
    place = MotionModel(scene.shelf, X_WS, motion.objects_after, config, near=obj.name)
    phase = {"pre_grasp": pick, "grasp": pick, "post_place": place}
    assert set(motion.keyframes) == set(targets)
    for name, q in motion.keyframes.items():
        model = phase.get(name, carry)
        position, angle = pose_errors(model, q, X_WS @ targets[name])
        assert position < 1e-3 and np.degrees(angle) < 1.0, name
        # clearance: every pair at least its bound (distance minus padding >= 0)
        _, _, margin = model.closest_pair(q)
        assert margin >= -1e-6, (name, model.closest_pair(q))
    # the carried object sits between the pads at the grasp (object centre near the tcp)
    assert np.linalg.norm(motion.X_TO.translation()[:2]) < 0.05


def test_motion_section_matches_schema(section):
    assert validate_motion_section(section) == []
    record = section[0]
    assert len(record["position_names"]) == 6 + 2 + 7 * 4
    assert any(seg["held"] == "front" for seg in record["segments"])


def test_schema_rejects_broken_sections(section):
    assert validate_motion_section({}) == ["motion must be a list"]
    broken = copy.deepcopy(section)
    del broken[0]["verified"]
    assert "missing verified" in validate_motion_section(broken)[0]
    broken = copy.deepcopy(section)
    broken[0]["segments"][1]["q"][0] = broken[0]["segments"][1]["q"][0][:-1]
    assert "finite numbers" in validate_motion_section(broken)[0]
    broken = copy.deepcopy(section)
    broken[0]["segments"][1]["t"] = broken[0]["segments"][1]["t"][::-1]
    assert "times" in validate_motion_section(broken)[0]
    broken = copy.deepcopy(section)
    broken[0]["failure"] = "x"
    assert "verified" in validate_motion_section(broken)[0]


def test_replay_from_json_at_five_times_checker_sampling(scene, section):
    assert replay_collisions(scene, section, oversample=5) == []


def test_replay_finds_a_collision_planted_in_the_json(scene, section):
    broken = copy.deepcopy(section)
    seg = broken[0]["segments"][1]  # pre_grasp -> grasp, nothing held
    shoulder_lift = broken[0]["position_names"].index("ur5e_shoulder_lift_joint_q")
    for row in seg["q"]:
        row[shoulder_lift] += 0.6  # dips the gripper into the shelf floor
    assert replay_collisions(scene, broken)


def test_boxed_in_placement_is_a_named_failure(scene):
    # placing "front" straight behind "box" at theta 0: the gripper would have to pass through it
    behind = Action("front", 0.0, 0.29, 0.10, 0.0)
    ok, reason = motion_check(scene, behind)
    assert not ok
    assert reason.startswith(("keyframe ", "segment ")), reason
    ok, reason = motion_check(scene, Action("nothing", 0.0, 0.1, 0.1, 0.0))
    assert not ok and "no object named" in reason


def test_directives_load_in_plain_pydrake(scene, tmp_path):
    path = write_scene_directives(scene, tmp_path)
    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    parser.package_map().AddPackageXml(str(PACKAGE_XML))
    parser.package_map().AddPackageXml(str(tmp_path / "package.xml"))
    ProcessModelDirectives(LoadModelDirectives(str(path)), plant, parser)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    X_WS = StationConfig().X_WS(scene.shelf.floor_height)
    for obj in scene.objects:
        X = plant.EvalBodyPoseInWorld(context, plant.GetBodyByName(obj.name))
        expected = X_WS @ X_SO(obj)
        assert np.allclose(X.GetAsMatrix4(), expected.GetAsMatrix4(), atol=1e-6), obj.name


def test_replay_html_is_self_contained(scene, motions, tmp_path):
    path = write_replay_html(scene, ACTIONS, motions, tmp_path / "replay.html")
    text = path.read_text()
    assert path.stat().st_size > 100_000
    assert "<html" in text.lower() and "http://" not in text.split("<script")[0]


def test_transfer_segment_returns_to_ready(scene, motions):
    """The physics world's way back to the ready configuration after an action."""
    end = motions[0].end_q
    ready = ready_q(scene, motions[0].objects_after)
    segment = transfer_segment(scene, motions[0].objects_after, end, ready, "return->ready")
    assert segment.times[0] == 0.0 and segment.name == "return->ready"
    assert np.allclose(segment.q[0], end) and np.allclose(segment.q[-1], ready)


def test_backed_off_move_goes_out_across_and_in_on_straight_lines(scene):
    """The fallback for a move in front of the shelf the optimiser cannot give: straight out
    along the tool axis, across behind the shelf, straight in; every segment collision-free on
    replay and the tcp on both lines (forward kinematics)."""
    from tsad_drake.motion.keyframes import R_SG
    from tsad_drake.motion.verify import MotionFailure, _ActionPlanner, check_segment, plan_action

    config = MotionConfig()
    X_WS = StationConfig().X_WS(scene.shelf.floor_height)
    # start where an action ends: withdrawn in front of the shelf after a placement
    placed = plan_action(scene, scene.objects, Action("front", 0.0, 0.08, 0.10, math.radians(20)),
                         ready_q(scene, scene.objects))
    assert placed.verified, placed.failure
    target = scene.object("target")
    action = Action("target", math.radians(-20), 0.10, -0.15, 0.0)
    planner = _ActionPlanner(scene.shelf, X_WS, placed.objects_after, action, config)
    model = MotionModel(scene.shelf, X_WS, placed.objects_after, config, near="target")
    start = placed.end_q
    X_ST = keyframe_targets(target, action.theta_pick, action.x, action.y, action.theta_place,
                            config)["pre_grasp"]
    finger = float(start[model.finger_indices[0]])  # the fingers stay as they are
    end = planner._backed_off(model, "start->pre_grasp", start, X_ST, finger,
                              MotionFailure("direct"))
    names = [s.name for s in planner.segments]
    assert names == ["start->pre_grasp (out)", "start->pre_grasp (across)",
                     "start->pre_grasp (in)"]
    for a, b in zip(planner.segments[:-1], planner.segments[1:]):
        assert np.allclose(a.q[-1], b.q[0]) and a.times[-1] == pytest.approx(b.times[0])
    for segment in planner.segments:
        assert check_segment(model, segment) is None
    out, into = planner.segments[0], planner.segments[-1]
    for segment in (out, into):
        X0, X1 = model.X_WT(segment.q[0]), model.X_WT(segment.q[-1])
        axis = X1.translation() - X0.translation()
        assert np.linalg.norm(axis) == pytest.approx(config.back_off, abs=3e-4)  # IK: 1e-4 per axis
        assert np.allclose(axis / np.linalg.norm(axis),
                           (1 if segment is into else -1) * X0.rotation().matrix()[:, 2],
                           atol=3e-3)  # along the tool axis (the in-line starts at an IK pose)
        for q in segment.q:
            p = model.X_WT(q).translation() - X0.translation()
            assert np.linalg.norm(np.cross(p, axis / np.linalg.norm(axis))) < 2e-4  # on the line
    position, angle = pose_errors(model, into.q[-1], X_WS @ X_ST)
    assert position < 2e-4 and angle < 1e-3
    assert np.allclose(end, into.q[-1])  # the keyframe `move` records
    assert np.allclose(R_SG(action.theta_pick).matrix(),
                       (X_WS.inverse() @ model.X_WT(into.q[-1])).rotation().matrix(), atol=1e-3)
