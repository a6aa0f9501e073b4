"""The simulation diagram: the station's plant with contact, PD-controlled joints, a command player.

`build_sim(scenario, config)` adds the same plant as the station and the motion export
(`station_models.add_scene`, so the position vector is the same: UR5e joints, fingers, then each
object's free-body quaternion and position), on the discrete SAP solver. The URDFs declare one
actuator per UR5e joint and one finger actuator (the right finger follows through the coupler
constraint Drake makes of the `<mimic>`); each gets PD gains (`set_controller_gains`), so the
plant's `desired_state` input ports drive them implicitly inside the contact solve. A
`CommandPlayer` plays the desired joint trajectory and adds feed-forward gravity torques computed
on a robot-only plant at the desired configuration. Nothing writes positions into the plant state
while the simulator runs.

Frames: world W = the UR5e base frame, shelf frame S at `X_WS` (see station.py).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.geometry import (
    AddCompliantHydroelasticProperties,
    AddContactMaterial,
    ProximityProperties,
    RoleAssign,
    SceneGraph,
    Sphere,
)
from pydrake.math import RigidTransform
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlant,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import BodyIndex, JointActuatorIndex, PdControllerGains
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, Diagram, DiagramBuilder, LeafSystem
from pydrake.trajectories import PiecewisePolynomial

from tsad_drake.physics.config import PhysicsConfig
from tsad_drake.scenario import Scenario
from tsad_drake.station import StationConfig
from tsad_drake.station_models import (
    FINGER_JOINTS,
    UR5E_JOINTS,
    X_SO,
    SceneModels,
    add_robot,
    add_scene,
    filter_robot_collisions,
    make_parser,
)

#: m, resolution hint of the compliant hydroelastic meshes (objects, pads, shelf panels)
HYDRO_RESOLUTION = 0.01


class CommandPlayer(LeafSystem):
    """Plays a desired trajectory of the seven commanded joints (six UR5e joints in rad, then the
    left finger in m) on the simulator's clock.

    Outputs: `arm_desired_state` [q, v] (12), `finger_desired_state` [q, v] (2), and
    `arm_feedforward` (6, N m): the torques holding the robot (arm and gripper, no payload) against
    gravity at the desired configuration, computed on a separate robot-only plant. Before the first
    trajectory, and after one ends, the player holds the trajectory's last configuration.
    """

    def __init__(self, q_hold: np.ndarray, gravity_compensation: bool, time_step: float):
        super().__init__()
        self._traj = PiecewisePolynomial(np.asarray(q_hold, dtype=float).reshape(7, 1))
        self._gravity = gravity_compensation
        self._robot = MultibodyPlant(time_step)
        robot, gripper = add_robot(self._robot, make_parser(self._robot), RigidTransform())
        self._robot.Finalize()
        self._robot_context = self._robot.CreateDefaultContext()
        self._arm = [self._robot.GetJointByName(n, robot).position_start() for n in UR5E_JOINTS]
        self._fingers = [self._robot.GetJointByName(n, gripper).position_start()
                         for n in FINGER_JOINTS]
        self.DeclareVectorOutputPort("arm_desired_state", BasicVector(12), self._arm_state)
        self.DeclareVectorOutputPort("finger_desired_state", BasicVector(2), self._finger_state)
        self.DeclareVectorOutputPort("arm_feedforward", BasicVector(6), self._feedforward)

    def set_trajectory(self, traj: PiecewisePolynomial) -> None:
        """Play `traj` (7 rows, times on the simulator's clock) from now on."""
        if traj.rows() != 7:
            raise ValueError("the command trajectory has 7 rows (6 arm joints, 1 finger)")
        self._traj = traj

    def _sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        traj = self._traj
        if t <= traj.start_time() or t >= traj.end_time():
            t = min(max(t, traj.start_time()), traj.end_time())
            return traj.value(t).ravel(), np.zeros(7)
        return traj.value(t).ravel(), traj.EvalDerivative(t, 1).ravel()

    def desired(self, t: float) -> np.ndarray:
        """The seven commanded positions at simulator time t."""
        return self._sample(t)[0]

    def _arm_state(self, context, output) -> None:
        q, v = self._sample(context.get_time())
        output.SetFromVector(np.concatenate([q[:6], v[:6]]))

    def _finger_state(self, context, output) -> None:
        q, v = self._sample(context.get_time())
        output.SetFromVector([q[6], v[6]])

    def _feedforward(self, context, output) -> None:
        if not self._gravity:
            output.SetFromVector(np.zeros(6))
            return
        q = self._sample(context.get_time())[0]
        full = np.zeros(self._robot.num_positions())
        full[self._arm] = q[:6]
        full[self._fingers] = q[6]
        self._robot.SetPositions(self._robot_context, full)
        tau_g = self._robot.CalcGravityGeneralizedForces(self._robot_context)
        output.SetFromVector(-tau_g[self._arm])


@dc.dataclass
class SimParts:
    """A built simulation: diagram, plant, its models, the player, a simulator and contexts."""

    diagram: Diagram
    plant: MultibodyPlant
    scene_graph: SceneGraph
    models: SceneModels
    player: CommandPlayer
    simulator: Simulator
    X_WS: RigidTransform
    weld: object | None = None  #: MultibodyConstraintId of the grasp weld, when built with one

    @property
    def context(self):
        return self.simulator.get_mutable_context()

    @property
    def plant_context(self):
        return self.plant.GetMyMutableContextFromRoot(self.context)


def _set_gains(plant: MultibodyPlant, models: SceneModels, config: PhysicsConfig) -> None:
    """PD gains on the UR5e's six actuators and the finger actuator (before Finalize, when
    `GetJointActuatorIndices` is still empty, so every actuator is visited)."""
    for index in range(plant.num_actuators()):
        actuator = plant.get_joint_actuator(JointActuatorIndex(index))
        if actuator.model_instance() == models.robot:
            k = UR5E_JOINTS.index(actuator.joint().name())
            gains = PdControllerGains(p=config.arm_kp[k], d=config.arm_kd[k])
        elif actuator.model_instance() == models.gripper:
            gains = PdControllerGains(p=config.finger_kp, d=config.finger_kd)
            actuator.set_effort_limit(config.grip_force)
        else:
            continue
        actuator.set_controller_gains(gains)


#: m, stud centres on a pad in the finger frame: across the pad (x) and along it (z); the pad is
#: 22 mm wide and spans z = 0.0225..0.060 above the palm face, its inner face at y = 0
STUD_X = (-0.008, 0.008)
STUD_Z = (0.026, 0.056)


def _add_pad_studs(plant: MultibodyPlant, models: SceneModels, config: PhysicsConfig) -> None:
    """Four contact spheres on each finger pad (see PhysicsConfig.pad_studs); before Finalize."""
    friction = CoulombFriction(config.object_friction, config.object_friction)
    for finger in ("left_finger", "right_finger"):
        body = plant.GetBodyByName(finger, models.gripper)
        for i, x in enumerate(STUD_X):
            for j, z in enumerate(STUD_Z):
                props = ProximityProperties()
                AddContactMaterial(friction=friction, properties=props)
                y = config.stud_radius - config.stud_proud
                plant.RegisterCollisionGeometry(body, RigidTransform([x, y, z]),
                                                Sphere(config.stud_radius),
                                                f"{finger}_stud_{i}{j}", props)


def _contact_properties(plant: MultibodyPlant, scene_graph: SceneGraph, models: SceneModels,
                        config: PhysicsConfig) -> None:
    """Friction on every collision geometry; compliant hydroelastic on objects, fingers and shelf
    when the contact model is hydroelastic (the arm links fall back to point contact)."""
    inspector = scene_graph.model_inspector()
    friction = CoulombFriction(config.object_friction, config.object_friction)
    hydro_bodies = set(models.objects.values())
    hydro_bodies |= {plant.GetBodyByName(n, models.gripper) for n in ("left_finger", "right_finger")}
    hydro_bodies |= {plant.get_body(i) for i in plant.GetBodyIndices(models.shelf)}
    hydro_bodies.add(plant.world_body())  # the ground
    for index in range(plant.num_bodies()):
        body = plant.get_body(BodyIndex(index))
        for geometry in plant.GetCollisionGeometriesForBody(body):
            props = ProximityProperties(inspector.GetProximityProperties(geometry))
            for name in ("material",):
                if props.HasGroup(name):
                    props.RemoveProperty(name, "coulomb_friction")
            AddContactMaterial(friction=friction, properties=props)
            if config.contact_model == "hydroelastic" and body in hydro_bodies:
                AddCompliantHydroelasticProperties(HYDRO_RESOLUTION,
                                                   config.hydroelastic_modulus, props)
            scene_graph.AssignRole(plant.get_source_id(), geometry, props, RoleAssign.kReplace)


def build_sim(scenario: Scenario, q_robot: np.ndarray, config: PhysicsConfig | None = None,
              station: StationConfig | None = None,
              weld: tuple[str, RigidTransform] | None = None) -> SimParts:
    """The simulation of `scenario` with the robot at `q_robot` (6 arm joints, rad, then the two
    finger joints, m): objects standing at their scenario poses, at rest, the player holding
    `q_robot`. The caller advances `simulator`.

    `weld` = (object name, X_GO): a weld constraint holding that object at X_GO in the gripper's
    base frame, active from the start (the grasp; `SetConstraintActiveStatus` releases it). Drake
    fixes a weld's frames before Finalize, so a grasp with a measured X_GO is a new diagram that
    continues from the old one's state (`continue_sim`).
    """
    config = config or PhysicsConfig()
    station = station or StationConfig()
    X_WS = station.X_WS(scenario.shelf.floor_height)
    builder = DiagramBuilder()
    contact = "point" if config.contact_model == "point" else "hydroelastic_with_fallback"
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(
        time_step=config.time_step, contact_model=contact,
        discrete_contact_approximation=config.discrete_approximation), builder)
    models = add_scene(plant, scenario, X_WS)
    for obj, body in zip(scenario.objects, models.object_bodies, strict=True):
        plant.SetDefaultFloatingBaseBodyPose(body, X_WS @ X_SO(obj))
    _set_gains(plant, models, config)
    if config.pad_studs and config.contact_model == "point":
        _add_pad_studs(plant, models, config)
    weld_id = None
    if weld is not None:
        weld_id = plant.AddWeldConstraint(plant.GetBodyByName("gripper_base", models.gripper),
                                          weld[1], models.objects[weld[0]], RigidTransform())
    plant.Finalize()
    filter_robot_collisions(plant, scene_graph, models.robot, models.gripper)
    _contact_properties(plant, scene_graph, models, config)
    q_robot = np.asarray(q_robot, dtype=float)
    plant.SetDefaultPositions(models.robot, q_robot[:6])
    plant.SetDefaultPositions(models.gripper, q_robot[6:8])

    player = builder.AddSystem(CommandPlayer(q_robot[:7], config.gravity_compensation,
                                             config.time_step))
    player.set_name("command_player")
    builder.Connect(player.GetOutputPort("arm_desired_state"),
                    plant.get_desired_state_input_port(models.robot))
    builder.Connect(player.GetOutputPort("finger_desired_state"),
                    plant.get_desired_state_input_port(models.gripper))
    builder.Connect(player.GetOutputPort("arm_feedforward"),
                    plant.get_actuation_input_port(models.robot))
    diagram = builder.Build()
    diagram.set_name("tsad_physics")
    simulator = Simulator(diagram)
    simulator.Initialize()
    return SimParts(diagram, plant, scene_graph, models, player, simulator, X_WS, weld_id)


def continue_sim(old: SimParts, scenario: Scenario, config: PhysicsConfig,
                 station: StationConfig | None, weld: tuple[str, RigidTransform],
                 command: PiecewisePolynomial) -> SimParts:
    """A new simulation with `weld`, continuing `old` (same time, positions and velocities, the
    player on `command`): the plant layouts are identical, so the state carries over unchanged."""
    new = build_sim(scenario, np.zeros(8), config, station, weld)
    new.player.set_trajectory(command)
    context = new.context
    context.SetTime(old.context.get_time())
    new.plant.SetPositionsAndVelocities(
        new.plant_context, old.plant.GetPositionsAndVelocities(old.plant_context))
    new.simulator.Initialize()
    return new


def touching(plant: MultibodyPlant, plant_context, body_a, body_b) -> bool:
    """Whether the contact results have a point pair or a hydroelastic surface between the two."""
    results = plant.get_contact_results_output_port().Eval(plant_context)
    wanted = {body_a.index(), body_b.index()}
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        if {info.bodyA_index(), info.bodyB_index()} == wanted:
            return True
    for i in range(results.num_hydroelastic_contacts()):
        surface = results.hydroelastic_contact_info(i).contact_surface()
        inspector = plant.EvalSceneGraphInspector(plant_context)
        bodies = {plant.GetBodyFromFrameId(inspector.GetFrameId(g)).index()
                  for g in (surface.id_M(), surface.id_N())}
        if bodies == wanted:
            return True
    return False
