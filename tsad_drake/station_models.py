"""Plant contents for the station: parser with the shipped package, UR5e + gripper, shelf, objects.

Each `add_*` function adds one thing to a MultibodyPlant (before Finalize); `add_scene` adds them all
in one fixed order, so the station, the observation-pose IK and the motion export build the same plant
(same position vector). The robot models come from
`models/package.xml` (`package://tsad_drake/...`); the shelf and the objects are built from the
Scenario in code (boxes and cylinders), with the shelf panels taken from `viewpoints.shelf_prisms` so
that Drake's geometry and the NumPy ray caster describe the very same shelf.

Render labels: object i carries RenderLabel(i + 1); the robot, the gripper and the shelf carry
RenderLabel.kDontCare; empty pixels read RenderLabel.kEmpty. `labels_to_object_indices` converts a
label image to the ray caster's convention (object index, -1 otherwise).
"""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path

import numpy as np
from pydrake.geometry import (
    AddContactMaterial,
    Box,
    CollisionFilterDeclaration,
    Cylinder,
    GeometryInstance,
    GeometrySet,
    IllustrationProperties,
    PerceptionProperties,
    ProximityProperties,
    RenderLabel,
    Rgba,
    Role,
    SceneGraph,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex, RigidBody, SpatialInertia, UnitInertia

from tsad_drake.scenario import ObjectConfig, Scenario, ShelfConfig
from tsad_drake.viewpoints import BACKGROUND_LABEL, shelf_prisms


def models_dir() -> Path:
    """The robot models (`package.xml`, `urdf/`): `tsad_drake/models` in an installed wheel (the
    wheel maps the repository's `models/` there), else `models/` beside the package in a checkout."""
    package = Path(__file__).resolve().parent
    installed = package / "models"
    return installed if (installed / "package.xml").is_file() else package.parent / "models"


#: models/package.xml (package name `tsad_drake`)
PACKAGE_XML = models_dir() / "package.xml"
UR5E_URL = "package://tsad_drake/urdf/ur5e/ur5e.urdf"
GRIPPER_URL = "package://tsad_drake/urdf/gripper/gripper_2f85.urdf"
#: the gripper model's frame that is welded to the UR5e's tool0 (its tool extension's arm end)
GRIPPER_MOUNT_FRAME = "tool_adapter"

#: joint names of the arm, in the order of `Station.observation_q`
UR5E_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
               "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
FINGER_JOINTS = ("left_finger_joint", "right_finger_joint")
FINGER_OPEN = 0.0425  #: m, each finger's travel when fully open (2F-85: 85 mm stroke)
#: label of everything that is not an object (robot, gripper, shelf)
RESERVED_LABEL = RenderLabel.kDontCare

SHELF_RGBA = Rgba(0.72, 0.58, 0.42, 1.0)
OBJECT_RGBA = Rgba(0.3, 0.6, 0.3, 1.0)
TARGET_RGBA = Rgba(0.85, 0.2, 0.2, 1.0)
FRICTION = CoulombFriction(static_friction=0.6, dynamic_friction=0.5)


def make_parser(plant: MultibodyPlant) -> Parser:
    """A Parser that resolves `package://tsad_drake/...` to this repository's models folder."""
    parser = Parser(plant)
    if not parser.package_map().Contains("tsad_drake"):
        parser.package_map().AddPackageXml(str(PACKAGE_XML))
    return parser


def _proximity() -> ProximityProperties:
    props = ProximityProperties()
    AddContactMaterial(friction=FRICTION, properties=props)
    return props


def _register_primitive(plant: MultibodyPlant, body: RigidBody, X_BG: RigidTransform, shape,
                        name: str, rgba: Rgba, label: RenderLabel | None) -> None:
    """Collision + illustration geometry, and perception with `label` (None: not rendered)."""
    plant.RegisterCollisionGeometry(body, X_BG, shape, name, _proximity())
    instance = GeometryInstance(X_BG, shape, name + "_visual")
    illustration = IllustrationProperties()
    illustration.AddProperty("phong", "diffuse", rgba)
    instance.set_illustration_properties(illustration)
    if label is not None:
        perception = PerceptionProperties()
        perception.AddProperty("phong", "diffuse", rgba)
        perception.AddProperty("label", "id", label)
        instance.set_perception_properties(perception)
    plant.RegisterVisualGeometry(body, instance)


def add_robot(plant: MultibodyPlant, parser: Parser, X_WB: RigidTransform
              ) -> tuple[ModelInstanceIndex, ModelInstanceIndex]:
    """UR5e welded at X_WB (base_link), the 2F-85 gripper on its tool extension welded at tool0;
    returns (robot, gripper)."""
    robot = parser.AddModelsFromUrl(UR5E_URL)[0]
    gripper = parser.AddModelsFromUrl(GRIPPER_URL)[0]
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base_link", robot), X_WB)
    plant.WeldFrames(plant.GetFrameByName("tool0", robot),
                     plant.GetFrameByName(GRIPPER_MOUNT_FRAME, gripper), RigidTransform())
    return robot, gripper


def add_ground(plant: MultibodyPlant) -> None:
    """The floor the robot stands on (top face at world z = 0; a thin box because signed distance
    to a half space is not supported): collision and illustration, never rendered."""
    _register_primitive(plant, plant.world_body(), RigidTransform([0.0, 0.0, -0.01]),
                        Box(4.0, 4.0, 0.02), "ground", Rgba(0.9, 0.9, 0.9, 1.0), label=None)


def add_shelf(plant: MultibodyPlant, shelf: ShelfConfig, X_WS: RigidTransform
              ) -> ModelInstanceIndex:
    """The shelf's five panels as boxes on one body welded at X_WS (frame S, see scenario.py)."""
    instance = plant.AddModelInstance("shelf")
    body = plant.AddRigidBody("shelf", instance, SpatialInertia.SolidBoxWithMass(
        10.0, shelf.depth, shelf.width, shelf.height))
    plant.WeldFrames(plant.world_frame(), body.body_frame(), X_WS)
    names = ("floor", "back", "left", "right", "top")
    for name, prism in zip(names, shelf_prisms(shelf), strict=True):
        sx, sy = prism.size
        X_SP = RigidTransform([prism.x, prism.y, (prism.z0 + prism.z1) / 2])
        _register_primitive(plant, body, X_SP, Box(sx, sy, prism.z1 - prism.z0), name,
                            SHELF_RGBA, RESERVED_LABEL)
    return instance


def object_shape(obj: ObjectConfig):
    """Drake shape of an upright object (its frame at the geometric centre).

    A size or height <= 0 raises ValueError here: Drake's shapes abort the process on it."""
    dims = obj.size[:1 if obj.shape == "cylinder" else 2] + [obj.height]
    if min(dims) <= 0.0:
        raise ValueError(f"object {obj.name!r} has a size or height <= 0 ({dims})")
    if obj.shape == "cylinder":
        return Cylinder(obj.size[0], obj.height)
    return Box(obj.size[0], obj.size[1], obj.height)


def X_SO(obj: ObjectConfig) -> RigidTransform:
    """Pose of the object's body frame (geometric centre) in the shelf frame S."""
    return RigidTransform(RotationMatrix.MakeZRotation(obj.yaw), [obj.x, obj.y, obj.height / 2])


def add_object(plant: MultibodyPlant, obj: ObjectConfig, index: int, is_target: bool
               ) -> RigidBody:
    """One free body (model instance and body both named obj.name) labelled index + 1."""
    instance = plant.AddModelInstance(obj.name)
    if obj.shape == "cylinder":
        unit = UnitInertia.SolidCylinder(obj.size[0], obj.height, [0.0, 0.0, 1.0])
    else:
        unit = UnitInertia.SolidBox(obj.size[0], obj.size[1], obj.height)
    inertia = SpatialInertia(obj.mass, np.zeros(3), unit)
    body = plant.AddRigidBody(obj.name, instance, inertia)
    _register_primitive(plant, body, RigidTransform(), object_shape(obj), obj.name,
                        TARGET_RGBA if is_target else OBJECT_RGBA, RenderLabel(index + 1))
    return body


def relabel_model(plant: MultibodyPlant, scene_graph: SceneGraph,
                  instances: list[ModelInstanceIndex], label: RenderLabel) -> None:
    """Give every rendered geometry of these (parsed) model instances the render label `label`.

    The parser labels geometry with its body index, which could collide with object labels.
    """
    inspector = scene_graph.model_inspector()
    source_id = plant.get_source_id()
    for instance in instances:
        for body_index in plant.GetBodyIndices(instance):
            for geometry_id in plant.GetVisualGeometriesForBody(plant.get_body(body_index)):
                old = inspector.GetPerceptionProperties(geometry_id)
                if old is None:
                    continue
                new = PerceptionProperties(old)
                new.UpdateProperty("label", "id", label)
                scene_graph.RemoveRole(source_id, geometry_id, Role.kPerception)
                scene_graph.AssignRole(source_id, geometry_id, new)


@dc.dataclass(frozen=True)
class SceneModels:
    """What `add_scene` put into the plant: the model instances and the objects' free bodies."""

    robot: ModelInstanceIndex
    gripper: ModelInstanceIndex
    shelf: ModelInstanceIndex
    #: object name -> free body, in scenario order (left out of the hash: a dict is unhashable)
    objects: dict[str, RigidBody] = dc.field(hash=False)

    @property
    def object_bodies(self) -> list[RigidBody]:
        """The objects' free bodies in scenario order."""
        return list(self.objects.values())


def add_scene(plant: MultibodyPlant, scenario: Scenario, X_WS: RigidTransform,
              X_WB: RigidTransform | None = None, objects: bool = True,
              relabel_in: SceneGraph | None = None) -> SceneModels:
    """Add robot, ground, shelf, then the objects, in this fixed order (one q layout for every plant).

    X_WB places the robot base (default: the world origin), X_WS the shelf frame. `objects=False`
    leaves the objects out; `relabel_in` (the rendering station's SceneGraph) gives the robot and
    gripper RESERVED_LABEL right after they are parsed. The caller finalizes the plant.
    """
    robot, gripper = add_robot(plant, make_parser(plant),
                               X_WB if X_WB is not None else RigidTransform())
    if relabel_in is not None:
        relabel_model(plant, relabel_in, [robot, gripper], RESERVED_LABEL)
    add_ground(plant)
    shelf = add_shelf(plant, scenario.shelf, X_WS)
    bodies = {obj.name: add_object(plant, obj, i, obj.name == scenario.target)
              for i, obj in enumerate(scenario.objects)} if objects else {}
    return SceneModels(robot, gripper, shelf, bodies)


def filter_robot_collisions(plant: MultibodyPlant, scene_graph: SceneGraph,
                            robot: ModelInstanceIndex, gripper: ModelInstanceIndex) -> None:
    """Exclude the contacts that are part of the design (call after Finalize).

    The gripper is bolted to wrist_3 (their geometries touch at the flange) and its own parts
    (fingers, palm, camera) are not checked against each other; the base stands on the ground.
    """
    gripper_bodies = [plant.get_body(i) for i in plant.GetBodyIndices(gripper)]
    wrist = plant.GetBodyByName("wrist_3_link", robot)
    manager = scene_graph.collision_filter_manager()
    manager.Apply(CollisionFilterDeclaration().ExcludeWithin(
        plant.CollectRegisteredGeometries([wrist, *gripper_bodies])))
    ground = [g for g in plant.GetCollisionGeometriesForBody(plant.world_body())
              if scene_graph.model_inspector().GetName(g).endswith("ground")]
    if ground:
        base = plant.CollectRegisteredGeometries([plant.GetBodyByName("base_link", robot)])
        manager.Apply(CollisionFilterDeclaration().ExcludeBetween(GeometrySet(ground), base))


def labels_to_object_indices(label_image: np.ndarray, num_objects: int) -> np.ndarray:
    """Drake label image -> (H, W) int32 object index, BACKGROUND_LABEL (-1) elsewhere."""
    raw = np.asarray(label_image).reshape(label_image.shape[0], label_image.shape[1])
    raw = raw.astype(np.int32)
    is_object = (raw >= 1) & (raw <= num_objects)
    return np.where(is_object, raw - 1, BACKGROUND_LABEL).astype(np.int32)
