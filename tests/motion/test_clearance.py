"""One clearance for planners and motion: the planners' swept corridor holds the real arm.

The planners judge a pick by a 2-D corridor (`GripperConfig.corridor_half_width`,
`corridor_reach`, clearance included); the motion level moves the UR5e and the pre-shaped gripper
along the straight approach line and keeps `MotionConfig.clearance` from everything. These tests
put the arm's collision geometry, solved by IK and followed along the line, into the planner's
corridor at random poses, and plant a near-miss that both layers must refuse alike.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
import pytest
from pydrake.geometry import Box, Capsule, Cylinder, Sphere

from tsad_drake.motion.cartesian import line_path
from tsad_drake.motion.keyframes import grasp_geometry, keyframe_targets, solve_keyframe
from tsad_drake.motion.scene import MotionConfig, MotionModel
from tsad_drake.motion.verify import motion_check
from tsad_drake.planning.feasibility import OracleFeasibility
from tsad_drake.planning.state import true_state
from tsad_drake.planning.types import Action
from tsad_drake.scenario import SHARED_CLEARANCE, GripperConfig, ObjectConfig, Scenario
from tsad_drake.station import StationConfig
from tsad_drake.station_models import FINGER_OPEN

#: m, tallest object the generator makes: robot geometry above it cannot touch an object
TALLEST_OBJECT = 0.22


def _surface_points(shape, spacing: float = 0.003) -> np.ndarray:
    """(P, 3) points on the surface of a Drake shape in its own frame (edges included)."""
    if isinstance(shape, Box):
        half = np.array([shape.width(), shape.depth(), shape.height()]) / 2
        axes = [np.linspace(-h, h, max(int(np.ceil(2 * h / spacing)), 1) + 1) for h in half]
        points = []
        for k in range(3):  # the two faces normal to axis k
            i, j = [a for a in range(3) if a != k]
            gi, gj = np.meshgrid(axes[i], axes[j], indexing="ij")
            for sign in (-1.0, 1.0):
                p = np.zeros((gi.size, 3))
                p[:, i], p[:, j], p[:, k] = gi.ravel(), gj.ravel(), sign * half[k]
                points.append(p)
        return np.concatenate(points)
    if isinstance(shape, Sphere):
        return _sphere_points(shape.radius(), spacing)
    if isinstance(shape, Cylinder | Capsule):
        r, half = shape.radius(), shape.length() / 2
        angles = np.linspace(0.0, 2 * np.pi, max(int(2 * np.pi * r / spacing), 8), endpoint=False)
        zs = np.linspace(-half, half, max(int(np.ceil(2 * half / spacing)), 1) + 1)
        rim = np.stack([r * np.cos(angles), r * np.sin(angles)], axis=1)
        side = np.array([[x, y, z] for z in zs for x, y in rim])
        if isinstance(shape, Capsule):
            caps = _sphere_points(r, spacing)
            return np.concatenate([side, caps + [0, 0, half], caps - [0, 0, half]])
        rings = [np.column_stack([rim * f, np.full(len(rim), z)])
                 for z in (-half, half) for f in np.linspace(0.0, 1.0, 6)]
        return np.concatenate([side] + rings)
    raise TypeError(f"no surface sampling for {type(shape).__name__}")


def _sphere_points(radius: float, spacing: float) -> np.ndarray:
    count = max(int(4 * np.pi * radius ** 2 / spacing ** 2), 20)
    k = np.arange(count) + 0.5
    polar = np.arccos(1 - 2 * k / count)
    azimuth = np.pi * (1 + 5 ** 0.5) * k
    return radius * np.stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth),
                              np.cos(polar)], axis=1)


def _robot_points_S(model: MotionModel, q: np.ndarray, X_SW) -> dict[str, np.ndarray]:
    """Surface points of every arm and gripper collision geometry at q in the shelf frame, by
    body name."""
    plant = model.plant
    inspector = model.diagram.scene_graph().model_inspector()
    plant.SetPositions(model.context, q)
    points = {}
    for instance in (model.robot, model.gripper):
        for index in plant.GetBodyIndices(instance):
            body = plant.get_body(index)
            X_SB = X_SW @ plant.EvalBodyPoseInWorld(model.context, body)
            for gid in plant.GetCollisionGeometriesForBody(body):
                local = _surface_points(inspector.GetShape(gid))
                X_SG = X_SB @ inspector.GetPoseInFrame(gid)
                world = (X_SG.rotation().matrix() @ local.T).T + X_SG.translation()
                points[body.name()] = np.concatenate([points.get(body.name(), np.zeros((0, 3))),
                                                      world])
    return points


def _shared_clearance_scenario() -> Scenario:
    return Scenario(gripper=GripperConfig(planning_clearance=SHARED_CLEARANCE))


def _random_object(rng: np.random.Generator) -> ObjectConfig:
    height = rng.uniform(0.12, 0.20)
    if rng.random() < 0.5:
        return ObjectConfig(name="target", kind="cylinder", shape="cylinder",
                            size=[rng.uniform(0.025, 0.035), height])
    side = rng.uniform(0.040, 0.055)
    return ObjectConfig(name="target", kind="square_pillar", shape="box",
                        size=[side, side, height], yaw=rng.uniform(-np.pi / 4, np.pi / 4))


def _in_shelf(points_S: np.ndarray, scenario: Scenario) -> np.ndarray:
    """Mask of points inside the shelf (walls included) and below the tallest object."""
    shelf = scenario.shelf
    return ((points_S[:, 0] >= 0.0) & (points_S[:, 0] <= shelf.depth + shelf.wall_thickness)
            & (np.abs(points_S[:, 1]) <= shelf.width / 2 + shelf.wall_thickness)
            & (points_S[:, 2] <= TALLEST_OBJECT))


def _corridor_excess(points_S: np.ndarray, obj: ObjectConfig, theta: float,
                     scenario: Scenario, clearance: float) -> float:
    """Largest distance (m) by which points inside the shelf and below the tallest object, grown
    by `clearance`, reach past the planners' corridor to obj at theta (<= 0: contained)."""
    g = scenario.gripper
    inside = _in_shelf(points_S, scenario)
    if not inside.any():
        return -np.inf
    u = np.array([np.cos(theta), np.sin(theta)])
    v = np.array([-u[1], u[0]])
    rel = points_S[inside, :2] - [obj.x, obj.y]
    along, across = rel @ u, np.abs(rel @ v)
    return float(max(np.max(across + clearance - g.corridor_half_width),
                     np.max(along + clearance - g.corridor_reach)))


def _approach_configurations(model: MotionModel, obj: ObjectConfig, theta: float,
                             config: MotionConfig, X_WS) -> list[np.ndarray]:
    """Configurations of the pick: pre-grasp, the straight approach, the grasp, the lift."""
    targets = keyframe_targets(obj, theta, obj.x, obj.y, theta, config)
    closed = grasp_geometry(obj, theta, config).finger
    opening = min(FINGER_OPEN, closed + config.preshape_gap)
    home = np.asarray(config.home_q)
    q_pre = solve_keyframe(model, X_WS @ targets["pre_grasp"], home, opening)
    approach = line_path(model, q_pre, X_WS @ targets["grasp"], config.line_step)
    q_grasp = approach[-1].copy()
    q_grasp[model.finger_indices] = closed
    lift = line_path(model, q_grasp, X_WS @ targets["lift"], config.line_step)
    return list(approach) + list(lift)


@pytest.mark.parametrize("seed", range(4))
def test_planner_corridor_holds_the_arm_along_the_approach(seed):
    """At random objects and angles every part of the arm and the gripper inside the shelf, grown
    by the motion level's clearance, stays inside the planners' corridor (which has the planning
    clearance): the planners' 'free' implies the motion level's 'clear'. The wrist links too: the
    gripper's 0.10 m tool extension keeps them out of the shelf (without it wrist_1 entered up
    to 20 mm on deep grasps, beside the corridor)."""
    rng = np.random.default_rng(seed)
    scenario = _shared_clearance_scenario()
    config = MotionConfig()
    X_WS = StationConfig().X_WS(scenario.shelf.floor_height)
    X_SW = X_WS.inverse()
    model = MotionModel(scenario.shelf, X_WS, [], config)
    worst = []
    for _ in range(3):
        obj = _random_object(rng)
        obj.x = float(rng.uniform(0.06, scenario.shelf.depth - 0.05))
        obj.y = float(rng.uniform(-0.17, 0.17))
        theta = float(rng.choice(scenario.approach_angles))
        for q in _approach_configurations(model, obj, theta, config, X_WS):
            points = _robot_points_S(model, q, X_SW)
            excess = _corridor_excess(np.concatenate(list(points.values())), obj, theta,
                                      scenario, config.clearance)
            worst.append((excess, obj.shape, obj.x, obj.y, np.degrees(theta)))
    assert max(w[0] for w in worst) <= 0.0, max(worst)
    # and the containment is tight: the open fingers fill the corridor to within the tolerance
    assert min(-w[0] for w in worst) <= scenario.gripper.planning_clearance - config.clearance


def _near_miss_scene(gap: float) -> Scenario:
    """A 70 mm cylinder at the shelf's centre line with a box beside its 0-degree approach: the
    box's near face `gap` beyond the open fingers' outer face (0.055 m from the line)."""
    target = ObjectConfig(name="target", shape="cylinder", size=[0.035, 0.15], x=0.20, y=0.0)
    half_y = 0.02
    box = ObjectConfig(name="wall_box", kind="rectangular", shape="box",
                       size=[0.16, 2 * half_y, 0.15], x=0.10, y=-(0.055 + gap + half_y))
    return dc.replace(_shared_clearance_scenario(), objects=[target, box], target="target")


@pytest.mark.parametrize("gap, accepted", [(0.0007, False), (0.003, True)])
def test_planted_near_miss_is_judged_alike_by_planner_and_motion(gap, accepted):
    """With the shared clearance, a neighbour 0.7 mm from the open fingers' path is refused by the
    planners' model and by the motion level; at 3 mm both accept. The pick is at 0 degrees."""
    scenario = _near_miss_scene(gap)
    oracle = OracleFeasibility(scenario)
    state = true_state(scenario)
    theta_index = int(np.argmin(np.abs(scenario.approach_angles)))
    planner_ok = bool(oracle.pickable(state, 0)[theta_index])
    action = Action("target", 0.0, 0.26, 0.15, 0.0)
    motion_ok, failure = motion_check(scenario, action)
    assert planner_ok == accepted
    assert motion_ok == accepted, failure
    if not accepted:
        assert "wall_box" in failure and "finger" in failure


def test_straight_line_follows_the_approach_line():
    """The approach's tcp stays on the line (forward kinematics of every exported sample)."""
    scenario = Scenario()
    config = MotionConfig()
    X_WS = StationConfig().X_WS(scenario.shelf.floor_height)
    model = MotionModel(scenario.shelf, X_WS, [], config)
    obj = dc.replace(ObjectConfig(name="target", shape="cylinder", size=[0.03, 0.15]),
                     x=0.25, y=0.08)
    theta = np.radians(20.0)
    path = _approach_configurations(model, obj, theta, config, X_WS)
    u = np.array([np.cos(theta), np.sin(theta)])
    X_SW = X_WS.inverse()
    approach = [q for q in path if (X_SW @ model.X_WT(q)).translation()[2]
                <= (X_SW @ model.X_WT(path[0])).translation()[2] + 1e-6]
    offsets = []
    for q in approach:
        p = (X_SW @ model.X_WT(q)).translation()[:2] - [obj.x, obj.y]
        offsets.append(abs(p @ np.array([-u[1], u[0]])))
    assert len(approach) > 20
    assert max(offsets) < 2e-4  # the line starts where the pre-grasp IK put the tcp (1e-4)
