"""Keyframes of one pick-and-place: tcp target poses along the approach lines, solved by IK.

The gripper stays horizontal: its approach axis (gripper z) points along u(theta) = (cos theta,
sin theta, 0) in the shelf frame S, its x axis (the camera side) points up, the fingers open
sideways. The tcp (between the pad centres) goes to the object's centre at `grasp_height`; an object
longer along the approach than the pads are deep is grasped nearer its front face, so that the palm
keeps `palm_margin` from it. The keyframes, in order:

  pre_grasp  outside the shelf on the line through the grasp point at theta_pick
  grasp      tcp at the grasp point, fingers open; then the fingers close
  lift       `lift` above the grasp
  retreat    outside the shelf on the same line, lifted
  pre_place  outside the shelf on the line through the place point at theta_place, lifted
  place_above, place   above the place point, then lowered; then the fingers open
  post_place outside the shelf on the place line

Each is solved with Drake's InverseKinematics (tcp position, gripper orientation, and a
MinimumDistanceLowerBoundConstraint on the phase's collision checker), seeded from the previous
keyframe, then home, then perturbed home configurations.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.inverse_kinematics import (
    InverseKinematics,
    MinimumDistanceLowerBoundConstraint,
)
from pydrake.solvers import SnoptSolver, Solve, SolverOptions

from tsad_drake.geometry2d import extent_along, width_across
from tsad_drake.motion.scene import MotionConfig, MotionModel
from tsad_drake.scenario import ObjectConfig

#: m, tcp to the palm face along the approach axis (pads 0.10..0.16 from the mount, tcp 0.145)
TCP_TO_PALM = 0.045
#: m, tcp to the fingertips along the approach axis
TCP_TO_TIP = 0.015
#: m, half the width of the open fingers (outer faces)
OPEN_HALF_WIDTH = 0.055

_IK_OPTIONS = SolverOptions()
_IK_OPTIONS.SetOption(SnoptSolver.id(), "Major iterations limit", 200)

KEYFRAMES = ("pre_grasp", "grasp", "lift", "retreat", "pre_place", "place_above", "place",
             "post_place")


def R_SG(theta: float) -> RotationMatrix:
    """Gripper orientation in S for approach angle theta: z along u(theta), x up."""
    c, s = np.cos(theta), np.sin(theta)
    return RotationMatrix(np.array([[0.0, s, c], [0.0, -c, s], [1.0, 0.0, 0.0]]))


def approach_direction(theta: float) -> np.ndarray:
    return np.array([np.cos(theta), np.sin(theta), 0.0])


@dc.dataclass
class GraspGeometry:
    """Where the tcp holds an object: height above the floor and set-back from its centre."""

    height: float  #: m, tcp above the shelf floor
    setback: float  #: m, tcp behind the object's centre along the approach direction
    reach: float  #: m, how far past the tcp the gripper or held object reaches along u
    finger: float  #: m, each finger's opening when closed on the object


def grasp_geometry(obj: ObjectConfig, theta: float, config: MotionConfig) -> GraspGeometry:
    half_along = extent_along(obj.shape, obj.size, obj.yaw, theta) / 2
    setback = max(0.0, half_along + config.palm_margin - TCP_TO_PALM)
    finger = width_across(obj.shape, obj.size, obj.yaw, theta) / 2 + config.finger_gap
    return GraspGeometry(height=max(obj.height / 2, config.grasp_height_min), setback=setback,
                         reach=max(TCP_TO_TIP, setback + half_along), finger=finger)


def outside_point(p_S: np.ndarray, theta: float, reach: float, config: MotionConfig) -> np.ndarray:
    """The point on the line through p_S along u(theta) where the gripper is clear of the shelf.

    The tcp goes back until the farthest forward corner of the gripper (or of the held object)
    lies `config.outside` in front of the shelf's front edge (x = 0 in S).
    """
    u = approach_direction(theta)
    x_target = -config.outside - reach * np.cos(theta) - OPEN_HALF_WIDTH * abs(np.sin(theta))
    distance = (p_S[0] - x_target) / np.cos(theta)
    return p_S - max(distance, 0.0) * u


def keyframe_targets(obj: ObjectConfig, theta_pick: float, x: float, y: float,
                     theta_place: float, config: MotionConfig) -> dict[str, RigidTransform]:
    """Target tcp poses X_ST (in the shelf frame) of every keyframe (see the module docstring)."""
    g = grasp_geometry(obj, theta_pick, config)
    up = np.array([0.0, 0.0, config.lift])
    grasp = np.array([obj.x, obj.y, g.height]) - g.setback * approach_direction(theta_pick)
    place = np.array([x, y, g.height]) - g.setback * approach_direction(theta_place)
    pick_out = outside_point(grasp, theta_pick, g.reach, config)
    place_out = outside_point(place, theta_place, g.reach, config)
    R_pick, R_place = R_SG(theta_pick), R_SG(theta_place)
    return {
        "pre_grasp": RigidTransform(R_pick, pick_out),
        "grasp": RigidTransform(R_pick, grasp),
        "lift": RigidTransform(R_pick, grasp + up),
        "retreat": RigidTransform(R_pick, pick_out + up),
        "pre_place": RigidTransform(R_place, place_out + up),
        "place_above": RigidTransform(R_place, place + up),
        "place": RigidTransform(R_place, place),
        "post_place": RigidTransform(R_place, place_out),
    }


def seeds(previous: np.ndarray, config: MotionConfig) -> list[np.ndarray]:
    """IK seeds: the previous keyframe, home, then home perturbed (fixed-seed generator)."""
    home = np.asarray(config.home_q, dtype=float)
    rng = np.random.default_rng(config.seed)
    out = [np.asarray(previous, dtype=float), home]
    out += [home + rng.normal(0.0, 0.3, 6) for _ in range(max(config.ik_seeds - 2, 0))]
    return out[:max(config.ik_seeds, 1)]


def _ik_program(model: MotionModel, X_WT: RigidTransform, previous: np.ndarray, finger: float,
                with_collision: bool):
    config = model.config
    plant = model.plant
    tol = config.ik_position_tolerance
    ik = InverseKinematics(plant, with_joint_limits=True)
    q = ik.q()
    ik.AddPositionConstraint(model.tcp, np.zeros(3), plant.world_frame(),
                             X_WT.translation() - tol, X_WT.translation() + tol)
    ik.AddOrientationConstraint(plant.world_frame(), X_WT.rotation(), model.tcp,
                                RotationMatrix(), np.radians(config.ik_orientation_tolerance_deg))
    prog = ik.get_mutable_prog()
    if with_collision:
        prog.AddConstraint(MinimumDistanceLowerBoundConstraint(
            model.checker, 0.0, model.checker.MakeStandaloneModelContext(), None, 0.02), q)
    prog.AddBoundingBoxConstraint(finger, finger, q[model.finger_indices])
    prog.AddQuadraticErrorCost(np.eye(6), np.asarray(previous, dtype=float), q[model.arm_indices])
    return prog, q


class KeyframeError(RuntimeError):
    """No collision-free IK solution for a keyframe (the message names the closest pair)."""


def reach_keyframe(model: MotionModel, X_WT: RigidTransform, previous: np.ndarray,
                   finger: float, retry_unreachable: bool = True
                   ) -> tuple[np.ndarray | None, bool]:
    """(full positions, collision-free) putting the tcp at X_WT with the fingers at `finger`:
    the first collision-free solution, else the first one found (False), else (None, False).

    Tries each seed without the distance constraint first (fast; kept when the checker finds it
    collision-free), then with the checker's MinimumDistanceLowerBoundConstraint (its padding is
    each pair's clearance); `retry_unreachable` False skips the second pass when the first found
    no solution at all (the pose is then out of the arm's reach for these seeds).
    """
    best = None
    for with_collision in (False, True):
        if with_collision and best is None and not retry_unreachable:
            break
        for seed in seeds(previous, model.config):
            prog, q = _ik_program(model, X_WT, previous, finger, with_collision)
            prog.SetInitialGuess(q, model.full_q(seed, finger))
            result = Solve(prog, solver_options=_IK_OPTIONS)
            if not result.is_success():
                continue
            solution = result.GetSolution(q)
            if model.checker.CheckConfigCollisionFree(solution):
                return solution, True
            best = solution if best is None else best
    return best, False


def solve_keyframe(model: MotionModel, X_WT: RigidTransform, previous: np.ndarray,
                   finger: float) -> np.ndarray:
    """Full position vector putting the tcp at X_WT with the fingers at `finger`, collision-free
    (`reach_keyframe`). Raises KeyframeError naming the closest body pair of the best pose."""
    best, free = reach_keyframe(model, X_WT, previous, finger)
    if free:
        return best
    if best is None:
        raise KeyframeError("unreachable (no IK solution for the tcp pose)")
    a, b, margin = model.closest_pair(best)
    raise KeyframeError(f"no collision-free IK solution; closest: {a} vs {b} "
                        f"({margin * 1000:+.1f} mm from the bound)")


def pose_errors(model: MotionModel, q: np.ndarray, X_WT: RigidTransform) -> tuple[float, float]:
    """Forward-kinematics check of a keyframe: (position error m, orientation error rad)."""
    X = model.X_WT(q)
    position = float(np.linalg.norm(X.translation() - X_WT.translation()))
    angle = float(X.rotation().InvertAndCompose(X_WT.rotation()).ToAngleAxis().angle())
    return position, angle
