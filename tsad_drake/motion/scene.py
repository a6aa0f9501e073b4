"""Collision models for motion planning: one kinematic plant per phase of a pick-and-place.

A pick-and-place has three phases, each with its own small plant (built with RobotDiagramBuilder)
and SceneGraphCollisionChecker: before the grasp (every object welded to the world where it
stands), while carrying (the held object welded to the gripper's `tcp` frame, part of the robot),
after the release (the object welded where it was put). Every plant has the same position vector,
the UR5e's six joints then the two finger joints, so one configuration means the same arm pose in
each phase. Only gripper-held-object contact is ignored (a collision filter); the shelf panels are
separate bodies so that per-pair padding can tell the floor from the walls.

Padding (the clearance the optimiser keeps and the verifier demands, `MotionConfig`): robot vs
environment `clearance`; the open gripper vs the object it is about to grasp or has just released
`finger_clearance` (the open pads leave only a few millimetres around a graspable object); the held
object vs the environment `held_clearance`, vs the shelf floor `floor_clearance`.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.geometry import Box, CollisionFilterDeclaration, GeometrySet, ProximityProperties
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import SpatialInertia
from pydrake.planning import RobotDiagramBuilder, SceneGraphCollisionChecker

from tsad_drake.scenario import ObjectConfig, ShelfConfig
from tsad_drake.station import HOME_Q
from tsad_drake.station_models import (
    FINGER_JOINTS,
    UR5E_JOINTS,
    X_SO,
    add_ground,
    add_robot,
    filter_robot_collisions,
    make_parser,
    object_shape,
)
from tsad_drake.viewpoints import shelf_prisms

SHELF_PANELS = ("floor", "back", "left", "right", "top")


@dc.dataclass
class MotionConfig:
    """Keyframe geometry, clearances, IK, trajectory optimisation and verification settings."""

    #: m, robot (arm, gripper) vs shelf, ground and other objects. The planners and the world model
    #: count contact at zero distance, so a larger bound here rejects actions they consider safe
    clearance: float = 0.001
    finger_clearance: float = 0.001  #: m, open gripper vs the object it grasps / released
    held_clearance: float = 0.002  #: m, held object vs shelf walls and other objects
    floor_clearance: float = 0.001  #: m, held object vs the shelf floor
    lift_gap: float = 0.002  #: m, the held object rides this high above where it stood
    lift: float = 0.03  #: m, lift after the grasp (and lowering before the release)
    outside: float = 0.05  #: m, pre-grasp/retreat: fingertips this far in front of the shelf
    palm_margin: float = 0.005  #: m, gap kept between the palm and a long object's near face
    grasp_height_min: float = 0.055  #: m, lowest tcp height above the shelf floor
    finger_gap: float = 0.0005  #: m, each pad's gap to the held object when closed
    #: m, each pad's gap to the object while approaching and releasing: the fingers open only
    #: this much wider than the object (pre-shaped grasp), never beyond the full stroke
    preshape_gap: float = 0.012
    ik_seeds: int = 6  #: IK attempts per keyframe (previous keyframe, home, perturbed)
    ik_position_tolerance: float = 1e-4  #: m, per axis, tcp position
    ik_orientation_tolerance_deg: float = 0.1  #: deg, gripper orientation
    control_points: int = 8  #: B-spline control points per segment
    collision_samples: int = 16  #: s-values with a minimum-distance constraint per segment
    #: optimise each segment without the distance constraints first; add them only when the dense
    #: check finds a collision (False: always optimise with them)
    lazy_collision: bool = True
    #: the moves inside the shelf (approach, lift, retreat, placing, withdrawing) follow the
    #: straight approach line the planners' corridor assumes (`motion/cartesian.py`); a move the
    #: line cannot give falls back to trajectory optimisation. False: optimise every move
    straight_lines: bool = True
    line_step: float = 0.005  #: m, tcp waypoint spacing along a straight line
    #: m, a move in front of the shelf the optimiser cannot give goes out, across and in this far
    #: behind the two poses along their tool axes (straight lines; False straight_lines: never)
    back_off: float = 0.10
    snopt_major_iterations: int = 100  #: SNOPT iteration limit of one segment's optimisation
    min_duration: float = 0.2  #: s, shortest segment
    max_duration: float = 8.0  #: s, longest segment
    velocity_scale: float = 1.0  #: fraction of the joints' published velocity limits
    gripper_duration: float = 0.5  #: s, closing or opening the fingers
    sample_step: float = 0.03  #: rad, largest joint step between exported samples
    edge_step: float = 0.005  #: rad, the checker's interpolation step along each sample edge
    #: rad, where the arm starts and is seeded from
    home_q: list[float] = dc.field(default_factory=lambda: list(HOME_Q))
    seed: int = 0  #: perturbed IK seeds


@dc.dataclass
class Held:
    """An object carried by the gripper: its shape and its pose in the tcp frame."""

    obj: ObjectConfig
    X_TO: RigidTransform


class MotionModel:
    """A kinematic plant of one phase plus its collision checker (see the module docstring)."""

    def __init__(self, shelf: ShelfConfig, X_WS: RigidTransform, objects: list[ObjectConfig],
                 config: MotionConfig, held: Held | None = None, near: str = ""):
        builder = RobotDiagramBuilder(time_step=0.0)
        plant: MultibodyPlant = builder.plant()
        self.robot, self.gripper = add_robot(plant, make_parser(plant), RigidTransform())
        add_ground(plant)
        panels = _add_shelf_panels(plant, shelf, X_WS)
        bodies = {}
        for obj in objects:
            if held is not None and obj.name == held.obj.name:
                continue
            bodies[obj.name] = _add_welded_object(plant, obj, plant.world_frame(), X_WS @ X_SO(obj))
        self.tcp = plant.GetFrameByName("tcp", self.gripper)
        robot_instances = [self.robot, self.gripper]
        held_body = None
        if held is not None:
            held_body = _add_welded_object(plant, held.obj, self.tcp, held.X_TO)
            robot_instances.append(held_body.model_instance())
        plant.Finalize()
        scene_graph = builder.scene_graph()
        filter_robot_collisions(plant, scene_graph, self.robot, self.gripper)
        gripper_bodies = [plant.get_body(i) for i in plant.GetBodyIndices(self.gripper)]
        gripper_bodies.append(plant.GetBodyByName("wrist_3_link", self.robot))
        if held_body is not None:
            scene_graph.collision_filter_manager().Apply(CollisionFilterDeclaration().ExcludeBetween(
                GeometrySet(plant.GetCollisionGeometriesForBody(held_body)),
                plant.CollectRegisteredGeometries(gripper_bodies)))
        self.diagram = builder.Build()
        self.plant = plant
        self.held = held
        self.held_body = held_body
        self.object_bodies = bodies
        self.config = config
        self.checker = SceneGraphCollisionChecker(
            model=self.diagram, robot_model_instances=robot_instances,
            edge_step_size=config.edge_step, env_collision_padding=config.clearance,
            self_collision_padding=0.0)
        if held_body is not None:
            self.checker.SetPaddingOneRobotBodyAllEnvironmentPairs(held_body.index(),
                                                                   config.held_clearance)
            self.checker.SetPaddingBetween(held_body.index(), panels["floor"].index(),
                                           config.floor_clearance)
        if near in bodies:
            for body in gripper_bodies:
                self.checker.SetPaddingBetween(body.index(), bodies[near].index(),
                                               config.finger_clearance)
        self.arm_indices = [plant.GetJointByName(n, self.robot).position_start()
                            for n in UR5E_JOINTS]
        self.finger_indices = [plant.GetJointByName(n, self.gripper).position_start()
                               for n in FINGER_JOINTS]
        self.context = plant.CreateDefaultContext()

    def set_held_padding(self, names: list[str], padding: float) -> None:
        """Padding (m; negative lets them interpenetrate that much) between the held object and
        the named objects: the neighbours a picked object touches where it stood slide past it
        while it is lifted and carried out (`verify` relaxes theirs, then restores it)."""
        for name in names:
            self.checker.SetPaddingBetween(self.held_body.index(),
                                           self.object_bodies[name].index(), padding)

    @property
    def num_positions(self) -> int:
        return self.plant.num_positions()

    def full_q(self, q_arm: np.ndarray, finger: float) -> np.ndarray:
        q = np.zeros(self.plant.num_positions())
        q[self.arm_indices] = q_arm
        q[self.finger_indices] = finger
        return q

    def X_WT(self, q: np.ndarray) -> RigidTransform:
        """Pose of the tcp frame in the world at configuration q."""
        self.plant.SetPositions(self.context, q)
        return self.tcp.CalcPoseInWorld(self.context)

    def body_name(self, index) -> str:
        body = self.plant.get_body(index)
        instance = self.plant.GetModelInstanceName(body.model_instance())
        return body.name() if instance == body.name() else f"{instance}::{body.name()}"

    def closest_pair(self, q: np.ndarray) -> tuple[str, str, float]:
        """The pair of bodies with the smallest distance minus padding at q, and that margin (m)."""
        clearance = self.checker.CalcRobotClearance(q, 1.0)
        distances = clearance.distances()
        if len(distances) == 0:
            return "", "", np.inf
        # RobotClearance distances are signed distances minus the pair's padding already
        robot, other = clearance.robot_indices(), clearance.other_indices()
        k = int(np.argmin(distances))
        return self.body_name(robot[k]), self.body_name(other[k]), float(distances[k])


def _add_shelf_panels(plant: MultibodyPlant, shelf: ShelfConfig, X_WS: RigidTransform) -> dict:
    """The shelf's five panels, each its own body welded at X_WS (collision geometry only)."""
    panels = {}
    for name, prism in zip(SHELF_PANELS, shelf_prisms(shelf), strict=True):
        instance = plant.AddModelInstance(f"shelf_{name}")
        body = plant.AddRigidBody(f"shelf_{name}", instance, SpatialInertia.Zero())
        sx, sy = prism.size
        plant.RegisterCollisionGeometry(body, RigidTransform(), Box(sx, sy, prism.z1 - prism.z0),
                                        name, ProximityProperties())
        plant.WeldFrames(plant.world_frame(), body.body_frame(),
                         X_WS @ RigidTransform([prism.x, prism.y, (prism.z0 + prism.z1) / 2]))
        panels[name] = body
    return panels


def _add_welded_object(plant: MultibodyPlant, obj: ObjectConfig, parent, X_PO: RigidTransform):
    """An object's collision shape on a body welded to `parent` at X_PO (body named obj.name)."""
    instance = plant.AddModelInstance(obj.name)
    body = plant.AddRigidBody(obj.name, instance, SpatialInertia.Zero())
    plant.RegisterCollisionGeometry(body, RigidTransform(), object_shape(obj), obj.name,
                                    ProximityProperties())
    plant.WeldFrames(parent, body.body_frame(), X_PO)
    return body
