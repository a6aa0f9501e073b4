"""Straight-line tcp moves inside the shelf: the path the planners' 2-D corridor assumes.

The planners sweep the open gripper along the approach line (a rectangle in the shelf frame); a
joint-space trajectory between two keyframes on that line bows away from it by centimetres, which
is what pushed fingers into neighbours and walls that the corridor had cleared. Here the tcp
follows the line itself: waypoints every `line_step` metres, each reached from the previous
configuration by Newton steps on the tcp's spatial-velocity Jacobian (six arm joints, six pose
components, fingers held), so consecutive configurations are close and the joint-space edge
between them stays within micrometres of the line. Near the UR5e's wrist singularity the steps
are damped and the tool's pitch may lag (SINGULAR_ROTATION_TOLERANCE); a step that would make a
joint jump is halved. The path is timed rest to rest with a minimum-jerk profile under the
joints' velocity limits.

Failures (a joint limit, a pose not reached or a jump left after MAX_HALVINGS halvings) raise
`LineError`; the caller falls back to trajectory optimisation.
"""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.tree import JacobianWrtVariable

from tsad_drake.motion.scene import MotionModel

#: peak of the minimum-jerk profile's speed over its mean (ds/dtau of 10t^3 - 15t^4 + 6t^5 at 1/2)
MIN_JERK_PEAK = 1.875
#: m: every waypoint's tcp position is reached this closely
POSITION_TOLERANCE = 1e-5
#: rad: orientation tolerance away from the wrist singularity, and near it (where the tool's
#: pitch cannot be steered: the fingertips then move up or down by at most 1 mm, never sideways
#: out of the corridor; the line's end is always reached to ROTATION_TOLERANCE)
ROTATION_TOLERANCE = 1e-5
SINGULAR_ROTATION_TOLERANCE = 0.015
#: Newton steps allowed per waypoint (damped steps near the singularity converge slowly)
NEWTON_STEPS = 40
#: rad, largest joint change between consecutive waypoints; a larger one halves the step
MAX_JOINT_STEP = 0.05
#: a line step is halved at most this many times before the line is given up
MAX_HALVINGS = 6
#: m per rad: weight of the orientation error against the position error in the damped steps
ROTATION_WEIGHT = 0.05
#: damped least squares: below this smallest singular value of the weighted Jacobian the step is
#: damped (the UR5e's wrist singularity, wrist 2 near 0, lies on some approach lines)
SINGULAR_THRESHOLD = 0.02
MAX_DAMPING = 0.01


class LineError(RuntimeError):
    """The tcp cannot follow the straight line (the message says why)."""


def _pose_error(X: RigidTransform, X_target: RigidTransform) -> np.ndarray:
    """(6,) world-frame rotation vector then translation taking X to X_target."""
    R_err = X_target.rotation().multiply(X.rotation().inverse()).ToAngleAxis()
    return np.concatenate([R_err.axis() * R_err.angle(),
                           X_target.translation() - X.translation()])


def _reach(model: MotionModel, q: np.ndarray, X_target: RigidTransform, exact: bool) -> bool:
    """Newton steps (damped near the wrist singularity) moving q's tcp to X_target, in place.

    True when the position is reached and the orientation within tolerance (the singular one when
    not `exact` and the Jacobian is near singular).
    """
    plant, context, arm = model.plant, model.context, model.arm_indices
    weights = np.array([ROTATION_WEIGHT] * 3 + [1.0] * 3)
    damping = rotation_tolerance = None
    for _ in range(NEWTON_STEPS + 1):  # usually 1-2 from the predicted start
        plant.SetPositions(context, q)
        error = _pose_error(model.tcp.CalcPoseInWorld(context), X_target)
        J = weights[:, None] * plant.CalcJacobianSpatialVelocity(
            context, JacobianWrtVariable.kQDot, model.tcp, np.zeros(3), plant.world_frame(),
            plant.world_frame())[:, arm]
        if damping is None:  # the waypoint's distance to the singularity, taken once
            sigma = np.linalg.svd(J, compute_uv=False)[-1]
            singular = sigma < SINGULAR_THRESHOLD
            rotation_tolerance = (SINGULAR_ROTATION_TOLERANCE if singular and not exact
                                  else ROTATION_TOLERANCE)
            damping = MAX_DAMPING * (1.0 - (sigma / SINGULAR_THRESHOLD) ** 2) if singular else 0.0
        if (np.linalg.norm(error[3:]) < POSITION_TOLERANCE
                and np.linalg.norm(error[:3]) < rotation_tolerance):
            return True
        e = weights * error
        if damping > 0.0:
            q[arm] += J.T @ np.linalg.solve(J @ J.T + damping ** 2 * np.eye(6), e)
        else:
            q[arm] += np.linalg.solve(J, e)
    return False


def line_path(model: MotionModel, q0: np.ndarray, X_W1: RigidTransform,
              step: float) -> np.ndarray:
    """(K, n) motion-plant positions moving the tcp from its pose at q0 to X_W1 in a straight line.

    Waypoints every `step` (halved where a joint would move more than MAX_JOINT_STEP between
    two); the orientation is interpolated by slerp (the keyframes of one line share it). The
    fingers stay as in q0. Raises LineError.
    """
    plant, arm = model.plant, model.arm_indices
    lower = plant.GetPositionLowerLimits()[arm]
    upper = plant.GetPositionUpperLimits()[arm]
    X_W0 = model.X_WT(q0)
    p0, p1 = X_W0.translation(), X_W1.translation()
    Q0, Q1 = X_W0.rotation().ToQuaternion(), X_W1.rotation().ToQuaternion()
    length = float(np.linalg.norm(p1 - p0))
    base = 1.0 / max(int(np.ceil(length / step)), 1)
    q = np.asarray(q0, dtype=float).copy()
    path = [q.copy()]
    s, ds = 0.0, base
    rate = np.zeros(len(arm))  # dq/ds of the last accepted step: predicts the next waypoint
    while s < 1.0 - 1e-12:
        s_next = min(1.0, s + ds)
        X_target = RigidTransform(Q0.slerp(s_next, Q1), p0 + s_next * (p1 - p0))
        trial = q.copy()
        trial[arm] += rate * (s_next - s)
        reached = _reach(model, trial, X_target, exact=s_next == 1.0)
        jump = float(np.max(np.abs(trial[arm] - q[arm])))
        if not reached or jump > MAX_JOINT_STEP:
            if ds < base / 2 ** MAX_HALVINGS:
                why = "pose not reached" if not reached else "joints jump"
                raise LineError(f"{why} at {s_next:.0%} of the line")
            ds /= 2
            continue
        if np.any(trial[arm] < lower) or np.any(trial[arm] > upper):
            raise LineError(f"joint limit at {s_next:.0%} of the line")
        rate = (trial[arm] - q[arm]) / (s_next - s)
        q, s = trial, s_next
        path.append(q.copy())
        ds = min(base, 2 * ds)
    return np.array(path)


def time_path(path: np.ndarray, arm: list[int], max_speed: float, min_duration: float,
              sample_step: float) -> tuple[np.ndarray, np.ndarray]:
    """Times from 0 and positions of `path` (K, n) timed rest to rest by a minimum-jerk profile.

    The parameter is the joint path's length (largest joint change per piece), so no arm joint
    exceeds `max_speed` (rad/s); samples are uniform in time, no joint moving more than about
    `sample_step` between two.
    """
    pieces = np.max(np.abs(np.diff(path[:, arm], axis=0)), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(pieces)])
    length = float(arc[-1])
    duration = max(min_duration, MIN_JERK_PEAK * length / max_speed)
    count = int(np.ceil(MIN_JERK_PEAK * max(length / sample_step, len(path) - 1, 1.0))) + 1
    tau = np.linspace(0.0, 1.0, count)
    s = length * tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau ** 2)
    if length == 0.0:
        return tau * duration, np.repeat(path[:1], count, axis=0)
    q = np.column_stack([np.interp(s, arc, path[:, j]) for j in range(path.shape[1])])
    return tau * duration, q
