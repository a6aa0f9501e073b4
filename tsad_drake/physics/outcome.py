"""Measurements on the simulated state: object poses, tilt, falls, disturbance, placement, slip.

Every pose is read from the plant; planar quantities are in the shelf frame S (m, rad), tilt is
the angle between a body's z-axis and the world vertical (deg). The thresholds come from
`PhysicsConfig`.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
from pydrake.math import RigidTransform

from tsad_drake.physics.config import PhysicsConfig
from tsad_drake.scenario import ObjectConfig, ShelfConfig


@dc.dataclass
class BodyPose:
    """One object's simulated pose: centre in S, heading, tilt."""

    x: float  #: m, body centre in S
    y: float  #: m
    z: float  #: m, body centre above the shelf floor
    yaw: float  #: rad, heading of the body's x-axis projected on the floor
    tilt_deg: float  #: deg, body z-axis against the vertical
    X_SB: RigidTransform  #: the full pose in S


def body_pose(X_SB: RigidTransform) -> BodyPose:
    """A BodyPose from the body's pose in the shelf frame."""
    R = X_SB.rotation().matrix()
    p = X_SB.translation()
    tilt = math.degrees(math.acos(float(np.clip(R[2, 2], -1.0, 1.0))))
    return BodyPose(float(p[0]), float(p[1]), float(p[2]), math.atan2(R[1, 0], R[0, 0]), tilt,
                    X_SB)


def fall_reason(obj: ObjectConfig, pose: BodyPose, shelf: ShelfConfig,
                config: PhysicsConfig) -> str:
    """Why the object counts as fallen ("" when it stands on the shelf floor)."""
    if pose.tilt_deg > config.fall_tilt_deg:
        return f"tilted {pose.tilt_deg:.0f} deg"
    if (pose.z < obj.height / 2 - config.floor_drop or not 0.0 <= pose.x <= shelf.depth
            or abs(pose.y) > shelf.width / 2):
        return "left the shelf floor"
    return ""


def displacement(before: BodyPose, after: BodyPose) -> float:
    """m, horizontal distance the centre moved."""
    return float(math.hypot(after.x - before.x, after.y - before.y))


def yaw_error_deg(obj: ObjectConfig, yaw: float, intended: float) -> float:
    """deg, smallest turn from `intended` to `yaw` under the shape's symmetry (a cylinder: 0;
    a square box: 90 degrees; a box: 180 degrees)."""
    if obj.shape == "cylinder":
        return 0.0
    period = math.pi / 2 if abs(obj.size[0] - obj.size[1]) < 1e-6 else math.pi
    d = (yaw - intended) % period
    return math.degrees(min(d, period - d))


def relative_slip(X_TO_start: RigidTransform, X_TO_end: RigidTransform) -> tuple[float, float]:
    """(mm, deg): how far the held object moved in the gripper's tcp frame during transport."""
    d = X_TO_start.inverse() @ X_TO_end
    return (float(np.linalg.norm(d.translation()) * 1000.0),
            math.degrees(d.rotation().ToAngleAxis().angle()))
