"""Observation poses: the UR5e joint positions that put the wrist camera at each viewpoint.

Solved once per station with Drake's InverseKinematics on a small plant that holds only what the
arm can touch outside the shelf (robot, gripper, shelf, ground): the camera frame must reach
X_WS * camera_pose(theta) (position within `position_tolerance`, orientation within
`orientation_tolerance`) with every robot geometry at least `min_distance` away from everything.
The objects are left out on purpose: they stand on the shelf floor (signed distance 0 to it), which
a scene-wide minimum-distance constraint would read as a collision; the viewpoints lie outside the
shelf, and the tests re-check the clearance to the objects in the full station.
"""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.solvers import Solve
from pydrake.systems.framework import DiagramBuilder

from tsad_drake.scenario import Scenario
from tsad_drake.station_models import (
    FINGER_JOINTS,
    FINGER_OPEN,
    UR5E_JOINTS,
    add_scene,
    filter_robot_collisions,
)
from tsad_drake.viewpoints import CameraConfig, camera_pose


class ObservationPoseError(RuntimeError):
    """No collision-free arm configuration puts the camera at a requested viewpoint."""


class ArmIK:
    """A kinematic plant (robot, gripper, shelf, ground) for solving camera-pose IK."""

    def __init__(self, scenario: Scenario, X_WB: RigidTransform, X_WS: RigidTransform):
        builder = DiagramBuilder()
        self.plant, self.scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
        models = add_scene(self.plant, scenario, X_WS, X_WB, objects=False)
        self.robot, self.gripper = models.robot, models.gripper
        self.plant.Finalize()
        filter_robot_collisions(self.plant, self.scene_graph, self.robot, self.gripper)
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = self.plant.GetMyContextFromRoot(self.context)
        self.camera_frame = self.plant.GetFrameByName("camera_link", self.gripper)
        self.arm_indices = [self.plant.GetJointByName(n, self.robot).position_start()
                            for n in UR5E_JOINTS]
        self.finger_indices = [self.plant.GetJointByName(n, self.gripper).position_start()
                               for n in FINGER_JOINTS]

    def full_q(self, q_arm: np.ndarray) -> np.ndarray:
        q = np.zeros(self.plant.num_positions())
        q[self.arm_indices] = q_arm
        q[self.finger_indices] = FINGER_OPEN
        return q

    def solve_camera_pose(self, X_WC: RigidTransform, seeds: list[np.ndarray],
                          q_nominal: np.ndarray, min_distance: float,
                          position_tolerance: float, orientation_tolerance: float
                          ) -> np.ndarray | None:
        """Arm joint positions (6,) putting the camera frame at X_WC, or None (tries each seed)."""
        p_WC = X_WC.translation()
        for seed in seeds:
            ik = InverseKinematics(self.plant, self.plant_context)
            q = ik.q()
            ik.AddPositionConstraint(self.camera_frame, np.zeros(3), self.plant.world_frame(),
                                     p_WC - position_tolerance, p_WC + position_tolerance)
            ik.AddOrientationConstraint(self.plant.world_frame(), X_WC.rotation(),
                                        self.camera_frame, RotationMatrix(),
                                        orientation_tolerance)
            ik.AddMinimumDistanceLowerBoundConstraint(min_distance, min_distance + 0.05)
            prog = ik.get_mutable_prog()
            prog.AddBoundingBoxConstraint(FINGER_OPEN, FINGER_OPEN, q[self.finger_indices])
            prog.AddQuadraticErrorCost(0.01 * np.eye(6), q_nominal, q[self.arm_indices])
            prog.SetInitialGuess(q, self.full_q(seed))
            result = Solve(prog)
            if result.is_success():
                return result.GetSolution(q)[self.arm_indices]
        return None


def solve_observation_poses(scenario: Scenario, camera: CameraConfig, X_WB: RigidTransform,
                            X_WS: RigidTransform, home_q: np.ndarray, num_seeds: int,
                            min_distance: float, position_tolerance: float,
                            orientation_tolerance: float, seed: int = 0
                            ) -> dict[float, np.ndarray]:
    """theta (rad) -> arm joint positions (6,) for every approach angle of the scenario.

    Seeds, in order: the nearest solved angle's answer, `home_q`, then `home_q` perturbed by N(0, 0.5 rad)
    from a fixed-seed generator. Raises ObservationPoseError naming the first unreachable view.
    """
    ik = ArmIK(scenario, X_WB, X_WS)
    rng = np.random.default_rng(seed)
    home_q = np.asarray(home_q, dtype=float)
    perturbed = [home_q + rng.normal(0.0, 0.5, 6) for _ in range(max(num_seeds - 1, 0))]
    poses: dict[float, np.ndarray] = {}
    # Solve from the middle outwards so that each view starts from its nearest solved neighbour.
    for theta in sorted((float(t) for t in scenario.approach_angles), key=abs):
        previous = [poses[min(poses, key=lambda t: abs(t - theta))]] if poses else []
        X_WC = X_WS @ RigidTransform(camera_pose(scenario.shelf, camera, theta))
        q = ik.solve_camera_pose(X_WC, previous + [home_q] + perturbed, home_q, min_distance,
                                 position_tolerance, orientation_tolerance)
        if q is None:
            raise ObservationPoseError(
                f"no collision-free arm pose puts the camera at the theta = "
                f"{np.degrees(theta):.1f} deg viewpoint (camera at "
                f"{np.round(X_WC.translation(), 3).tolist()} m in the world) after "
                f"{len(perturbed) + 1 + len(previous)} IK seeds; move the robot "
                f"(StationConfig.shelf_distance) or the viewpoint (CameraConfig)")
        poses[theta] = q
    return {float(t): poses[float(t)] for t in scenario.approach_angles}
