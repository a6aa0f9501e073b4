"""Segments between keyframes by KinematicTrajectoryOptimization, and their exported samples.

One segment is a clamped B-spline from rest to rest, with the plant's joint position limits, the
joints' velocity limits (scaled by `velocity_scale`), duration bounds, a duration + path-length
cost, and a MinimumDistanceLowerBoundConstraint on the phase's collision checker at
`collision_samples` evenly spaced path parameters (the checker's padding is each pair's
clearance). The initial guess is the straight line in joint space. The finger joints are held
fixed by their bounds (the fingers move only in the separate gripper segments).
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.inverse_kinematics import MinimumDistanceLowerBoundConstraint
from pydrake.planning import KinematicTrajectoryOptimization
from pydrake.solvers import SnoptSolver, Solve, SolverOptions
from pydrake.trajectories import BsplineTrajectory

from tsad_drake.motion.scene import MotionModel

#: rad/s, UR5e joint speed limit (every joint; ros-industrial ur_description)
ARM_VELOCITY_LIMIT = np.pi
#: m/s, finger speed limit (gripper URDF)
FINGER_VELOCITY_LIMIT = 0.15


class SegmentError(RuntimeError):
    """Trajectory optimisation found no feasible segment."""


def optimise_segment(model: MotionModel, q0: np.ndarray, q1: np.ndarray,
                     with_collision: bool = True) -> BsplineTrajectory:
    """A rest-to-rest trajectory from q0 to q1 (full position vectors); raises SegmentError."""
    config = model.config
    n = model.num_positions
    trajopt = KinematicTrajectoryOptimization(n, config.control_points, spline_order=4)
    prog = trajopt.get_mutable_prog()
    lower = model.plant.GetPositionLowerLimits().copy()
    upper = model.plant.GetPositionUpperLimits().copy()
    lower[model.finger_indices] = q0[model.finger_indices]
    upper[model.finger_indices] = q0[model.finger_indices]
    velocity = np.full(n, ARM_VELOCITY_LIMIT * config.velocity_scale)
    velocity[model.finger_indices] = FINGER_VELOCITY_LIMIT
    trajopt.AddPositionBounds(lower, upper)
    trajopt.AddVelocityBounds(-velocity, velocity)
    trajopt.AddDurationConstraint(config.min_duration, config.max_duration)
    trajopt.AddDurationCost(1.0)
    trajopt.AddPathLengthCost(1.0)
    trajopt.AddPathPositionConstraint(q0, q0, 0.0)
    trajopt.AddPathPositionConstraint(q1, q1, 1.0)
    zero = np.zeros(n)
    trajopt.AddPathVelocityConstraint(zero, zero, 0.0)
    trajopt.AddPathVelocityConstraint(zero, zero, 1.0)
    if with_collision:
        context = model.checker.MakeStandaloneModelContext()
        constraint = MinimumDistanceLowerBoundConstraint(model.checker, 0.0, context, None, 0.02)
        for s in np.linspace(0.0, 1.0, config.collision_samples)[1:-1]:
            trajopt.AddPathPositionConstraint(constraint, s)
    guess = np.linspace(q0, q1, config.control_points).T
    prog.SetInitialGuess(trajopt.control_points(), guess)
    distance = float(np.max(np.abs(q1 - q0)[model.arm_indices]))
    prog.SetInitialGuess(trajopt.duration(), np.clip(
        2.0 * distance / (ARM_VELOCITY_LIMIT * config.velocity_scale) + config.min_duration,
        config.min_duration, config.max_duration))
    options = SolverOptions()
    options.SetOption(SnoptSolver.id(), "Major iterations limit", config.snopt_major_iterations)
    result = Solve(prog, solver_options=options)
    if not result.is_success():
        names = result.GetInfeasibleConstraintNames(prog)[:3]
        raise SegmentError(f"{result.get_solver_id().name()} failed"
                           + (f" ({', '.join(names)})" if names else ""))
    return trajopt.ReconstructTrajectory(result)


def sample_trajectory(traj, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Times (N,) and positions (N, n) along `traj`, no joint moving more than `step` between two.

    The first and last samples are the trajectory's ends; the samples are uniform in time.
    """
    t0, t1 = traj.start_time(), traj.end_time()
    fine = np.linspace(t0, t1, 201)
    q = np.column_stack([traj.value(t).ravel() for t in fine])
    largest = np.max(np.abs(np.diff(q, axis=1))) * 200
    count = max(int(np.ceil(largest / step)), 1) + 1
    times = np.linspace(t0, t1, count)
    return times, np.array([traj.value(t).ravel() for t in times])


def linear_segment(q0: np.ndarray, q1: np.ndarray, duration: float, step: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Times and positions of a straight joint-space move (used for the fingers)."""
    count = max(int(np.ceil(np.max(np.abs(q1 - q0)) / step)), 1) + 1
    s = np.linspace(0.0, 1.0, count)
    return s * duration, q0[None, :] + s[:, None] * (q1 - q0)[None, :]
