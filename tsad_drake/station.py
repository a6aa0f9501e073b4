"""The station: a Drake diagram with the UR5e, the gripper, the shelf, the objects and a wrist camera.

`MakeStation(scenario)` builds it in a straight line (plant and scene graph, renderer, robot,
shelf, objects, finalize, depth camera, visualisation), solves the observation poses (one arm
configuration per approach angle) once, and returns a `Station` that renders 128x128 depth and
label images from those poses in milliseconds, reusing one diagram context.

World frame W: the UR5e base_link frame (on the floor, z up); the shelf stands straight ahead along
+x, its frame S (see scenario.py) at X_WS = [shelf_distance, shelf_lateral_offset,
shelf.floor_height] with the same orientation as W. Object bodies have their frame at the
geometric centre (x, y, height / 2 in S).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.geometry import (
    MakeRenderEngineVtk,
    Meshcat,
    MeshcatVisualizer,
    RenderEngineVtkParams,
)
from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.sensors import CameraConfig as DrakeCameraConfig
from pydrake.systems.sensors import RgbdSensor

from tsad_drake.scenario import ObjectConfig, Scenario
from tsad_drake.station_ik import solve_observation_poses
from tsad_drake.station_models import (
    FINGER_JOINTS,
    FINGER_OPEN,
    UR5E_JOINTS,
    X_SO,
    add_scene,
    filter_robot_collisions,
    labels_to_object_indices,
)
from tsad_drake.viewpoints import CameraConfig

#: UR5e "ready" configuration facing the shelf (elbow up, wrist camera on top), rad
HOME_Q = (-0.22, -0.89, 1.49, -0.6, 1.36, 1.57)
#: px, shift of the CameraInfo principal point that makes VTK render the intended pinhole
VTK_PIXEL_OFFSET = 0.5


@dc.dataclass
class StationConfig:
    """How the station is built: simulation step, robot placement, camera, observation-pose IK."""

    time_step: float = 0.001  #: s, discrete MultibodyPlant step
    #: m, along world +x from the robot base axis (world origin) to the shelf's front edge
    shelf_distance: float = 0.70
    shelf_lateral_offset: float = 0.0  #: m, along world +y, of the shelf frame origin
    camera: CameraConfig = dc.field(default_factory=CameraConfig)
    home_q: list[float] = dc.field(default_factory=lambda: list(HOME_Q))  #: rad, UR5e joints
    ik_seeds: int = 8  #: IK attempts per viewpoint (nearest solved view, home, perturbed homes)
    min_distance: float = 0.01  #: m, clearance of the arm and gripper at the observation poses
    ik_position_tolerance: float = 1e-4  #: m, per axis, camera position at a viewpoint
    ik_orientation_tolerance_deg: float = 0.05  #: deg, camera orientation at a viewpoint
    renderer_name: str = "vtk"  #: name of the VTK render engine in SceneGraph

    def X_WS(self, floor_height: float) -> RigidTransform:
        """Pose of the shelf frame S in the world (robot base) frame."""
        return RigidTransform([self.shelf_distance, self.shelf_lateral_offset, floor_height])


def drake_camera_config(camera: CameraConfig, renderer_name: str) -> DrakeCameraConfig:
    """Drake's `CameraConfig` of the wrist camera: it images exactly like our CameraConfig.

    Drake's VTK renderer draws a CameraInfo's principal point half a pixel up and left of where the
    CameraInfo puts it (measured on this machine: the image of CameraInfo(128, 128, fov_y) matches a
    pinhole with centre (63, 63), not the (63.5, 63.5) it reports; see Drake PR #10190). The
    principal point below is shifted by +0.5 px so that the rendered image is the pinhole of
    `CameraConfig.intrinsics()`, the one `viewpoints.raycast` draws; use those intrinsics, not the
    sensor's CameraInfo, to back-project depth. The camera rides on the gripper's camera body (the
    station adds the RgbdSensor there), so Drake's own mounting fields stay at their defaults.
    """
    cx, cy = camera.principal_point()
    return DrakeCameraConfig(
        width=camera.width, height=camera.height,
        focal=DrakeCameraConfig.FovDegrees(y=camera.fov_y_deg),
        center_x=cx + VTK_PIXEL_OFFSET, center_y=cy + VTK_PIXEL_OFFSET,
        clipping_near=camera.near, clipping_far=camera.far, z_near=camera.near, z_far=camera.far,
        renderer_name=renderer_name, rgb=True, depth=True, label=True, show_rgb=False)


class Station:
    """A built station and one reusable context; see MakeStation."""

    def __init__(self, diagram, plant, scene_graph, sensor: RgbdSensor, scenario: Scenario,
                 config: StationConfig, robot, gripper, object_bodies, X_WS: RigidTransform,
                 observation_q: dict[float, np.ndarray]):
        self.diagram = diagram
        self.plant = plant
        self.scene_graph = scene_graph
        self.sensor = sensor
        self.scenario = scenario
        self.config = config
        self.camera_config = config.camera
        self.robot = robot
        self.gripper = gripper
        self.object_bodies = object_bodies
        self.X_WS = X_WS
        self.observation_q = observation_q
        self.context = diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        self.sensor_context = sensor.GetMyContextFromRoot(self.context)
        self.arm_indices = [plant.GetJointByName(n, robot).position_start() for n in UR5E_JOINTS]
        self.finger_indices = [plant.GetJointByName(n, gripper).position_start()
                               for n in FINGER_JOINTS]
        self.camera_body = plant.GetBodyByName("camera_link", gripper)

    @property
    def camera(self) -> CameraConfig:
        """The wrist camera's config (alias of camera_config; its intrinsics() are the image's)."""
        return self.camera_config

    def set_arm_positions(self, q_arm: np.ndarray, finger: float = FINGER_OPEN) -> None:
        """Set the six UR5e joints (rad) and both fingers (m, each) in the station's context."""
        q = self.plant.GetPositions(self.plant_context)
        q[self.arm_indices] = q_arm
        q[self.finger_indices] = finger
        self.plant.SetPositions(self.plant_context, q)

    def set_objects(self, objects: list[ObjectConfig]) -> None:
        """Move the free bodies to these planar poses (same names and order as the scenario)."""
        if [o.name for o in objects] != [b.name() for b in self.object_bodies]:
            raise ValueError("set_objects needs the scenario's objects, same names and order")
        for obj, body in zip(objects, self.object_bodies, strict=True):
            self.plant.SetFloatingBaseBodyPoseInWorldFrame(self.plant_context, body,
                                                           self.X_WS @ X_SO(obj))
            self.plant.SetFreeBodySpatialVelocity(self.plant_context, body, SpatialVelocity())

    def camera_pose_in_shelf(self) -> np.ndarray:
        """4x4 X_SC of the camera optical frame for the arm positions in the context."""
        X_WC = self.plant.EvalBodyPoseInWorld(self.plant_context, self.camera_body)
        return (self.X_WS.inverse() @ X_WC).GetAsMatrix4()

    def render_current(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Depth, label and X_SC from the camera where the arm is now (see `render`)."""
        depth = self.sensor.depth_image_32F_output_port().Eval(self.sensor_context).data
        depth = np.array(depth[:, :, 0], dtype=np.float32)
        depth[depth <= 0.0] = np.inf  # Drake: 0 = closer than the near plane, inf = beyond far
        labels = self.sensor.label_image_output_port().Eval(self.sensor_context).data
        label = labels_to_object_indices(labels, len(self.object_bodies))
        label[~np.isfinite(depth)] = -1
        return depth, label, self.camera_pose_in_shelf()

    def render(self, theta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Move the arm to the observation pose of approach angle theta (rad) and render.

        Returns:
            depth (H, W) float32 metres along the optical axis (inf where nothing or out of range),
            label (H, W) int32 object index or -1, X_SC (4x4) the camera pose achieved in S.
        """
        self.set_arm_positions(self.observation_q[self._theta_key(theta)])
        return self.render_current()

    def publish(self) -> None:
        """Push the current context to the visualiser (if any)."""
        self.diagram.ForcedPublish(self.context)

    def _theta_key(self, theta: float) -> float:
        for key in self.observation_q:
            if abs(key - theta) < 1e-9:
                return key
        raise KeyError(f"no observation pose for theta = {np.degrees(theta):.3f} deg; "
                       f"the scenario's angles are {sorted(np.degrees(list(self.observation_q)))}")


def MakeStation(scenario: Scenario, meshcat: Meshcat | None = None,
                config: StationConfig | None = None) -> Station:
    """Build the diagram for `scenario` and solve its observation poses (raises if unreachable)."""
    config = config or StationConfig()
    X_WS = config.X_WS(scenario.shelf.floor_height)
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=config.time_step),
                                           builder)
    scene_graph.AddRenderer(config.renderer_name, MakeRenderEngineVtk(RenderEngineVtkParams()))

    models = add_scene(plant, scenario, X_WS, relabel_in=scene_graph)
    robot, gripper, object_bodies = models.robot, models.gripper, models.object_bodies
    for obj, body in zip(scenario.objects, object_bodies, strict=True):
        plant.SetDefaultFloatingBaseBodyPose(body, X_WS @ X_SO(obj))
    plant.Finalize()
    filter_robot_collisions(plant, scene_graph, robot, gripper)
    plant.SetDefaultPositions(robot, np.asarray(config.home_q, dtype=float))
    plant.SetDefaultPositions(gripper, [FINGER_OPEN, FINGER_OPEN])

    color_camera, depth_camera = drake_camera_config(config.camera,
                                                     config.renderer_name).MakeCameras()
    camera_body = plant.GetBodyByName("camera_link", gripper)
    sensor = builder.AddSystem(RgbdSensor(plant.GetBodyFrameIdOrThrow(camera_body.index()),
                                          RigidTransform(), color_camera, depth_camera))
    sensor.set_name("wrist_camera")
    builder.Connect(scene_graph.get_query_output_port(), sensor.query_object_input_port())
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    diagram = builder.Build()
    diagram.set_name("tsad_station")

    observation_q = solve_observation_poses(
        scenario, config.camera, RigidTransform(), X_WS, np.asarray(config.home_q),
        config.ik_seeds, config.min_distance, config.ik_position_tolerance,
        np.radians(config.ik_orientation_tolerance_deg))
    station = Station(diagram, plant, scene_graph, sensor, scenario, config, robot, gripper,
                      object_bodies, X_WS, observation_q)
    if meshcat is not None:
        station.publish()
    return station
