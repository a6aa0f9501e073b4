"""Import: a Drake model-directives scene of boxes and cylinders back into a Scenario.

`load_scene_directives(path)` parses the directives with Drake (`ProcessModelDirectives` into a
MultibodyPlant; `package://` URIs resolve to this project's models and to the package.xml beside
the file) and reads the scene off the plant: the shelf from the `shelf` model's five panels (their
boxes give depth, width, height and wall thickness) and its weld (the floor height), each other
free body with one box or cylinder collision shape as an object (size, mass, default pose), the
target from the body carrying the frame `export.TARGET_FRAME`. The robot, gripper and ground are
skipped. What Drake models do not hold (planning settings, object kinds) comes from
`export.SETTINGS_FILE` beside the file when it is there (defaults otherwise; a kind is then
inferred from the shape). Bad input raises UsageError with one line.
"""

from __future__ import annotations

import dataclasses as dc
import math
from pathlib import Path

import numpy as np
from pydrake.geometry import Box, Cylinder, SceneGraph
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import LoadModelDirectives, ProcessModelDirectives
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex

from tsad_drake.errors import ScenarioError, UsageError, first_line
from tsad_drake.motion.export import SCENE_PACKAGE, SETTINGS_FILE, TARGET_FRAME
from tsad_drake.scenario import ObjectConfig, Scenario, ShelfConfig, validate
from tsad_drake.station import StationConfig
from tsad_drake.station_models import make_parser

#: model instances of the station that are not scene objects
STATION_MODELS = ("WorldModelInstance", "DefaultModelInstance", "ur5e", "gripper_2f85", "ground",
                  "shelf")
SHELF_PANELS = ("floor", "back", "left", "right", "top")
#: m, how far the shelf's weld may lie from where the station puts a shelf
PLACEMENT_TOLERANCE = 1e-6


class _Scene:
    """The directives parsed into a plant (with its scene graph, for the collision shapes)."""

    def __init__(self, path: Path):
        self.path = path
        self.plant = MultibodyPlant(0.0)
        self.scene_graph = SceneGraph()
        self.plant.RegisterAsSourceForSceneGraph(self.scene_graph)
        parser = make_parser(self.plant)
        package = path.parent / "package.xml"
        if package.is_file() and not parser.package_map().Contains(SCENE_PACKAGE):
            parser.package_map().AddPackageXml(str(package))
        try:
            ProcessModelDirectives(LoadModelDirectives(str(path)), self.plant, parser)
            self.plant.Finalize()
        except Exception as err:  # Drake's parse errors: RuntimeErrors with long messages
            raise UsageError(f"cannot load the model directives {path}: {first_line(err)}"
                             ) from None
        self.context = self.plant.CreateDefaultContext()

    def shapes(self, body) -> list[tuple[str, object, RigidTransform]]:
        """(name, shape, pose in the body frame) of each of the body's collision geometries."""
        inspector = self.scene_graph.model_inspector()
        return [(inspector.GetName(g).split("::")[-1], inspector.GetShape(g),
                 inspector.GetPoseInFrame(g))
                for g in self.plant.GetCollisionGeometriesForBody(body)]

    def fail(self, message: str) -> None:
        raise UsageError(f"{self.path}: {message}")


def load_scene_directives(path: str | Path) -> Scenario:
    """The Scenario a `scene.dmd.yaml` describes (see the module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise UsageError(f"model directives file not found: {path}")
    scene = _Scene(path)
    plant = scene.plant
    settings = _settings(path.parent / SETTINGS_FILE)
    X_WS, shelf = _shelf(scene)
    kinds = {o.name: o.kind for o in settings.objects}
    objects, target = [], ""
    for index in range(plant.num_model_instances()):
        instance = ModelInstanceIndex(index)
        name = plant.GetModelInstanceName(instance)
        if name in STATION_MODELS:
            continue
        objects.append(_object(scene, instance, name, X_WS, kinds.get(name)))
        if plant.HasFrameNamed(TARGET_FRAME, instance):
            target = objects[-1].name
    if not objects:
        scene.fail("no objects (free bodies besides the robot, gripper, ground and shelf)")
    if not target:
        scene.fail(f"no target recorded (no object carries the frame {TARGET_FRAME!r}, which "
                   "`tsad plan --motion` adds to the target)")
    scenario = dc.replace(settings, shelf=shelf, objects=objects, target=target)
    try:
        validate(scenario)
    except ScenarioError as err:
        raise ScenarioError(f"the scene in {path} is not a valid scenario: {err}") from None
    return scenario


def _settings(path: Path) -> Scenario:
    """The SETTINGS_FILE beside the directives (a Scenario whose objects hold names and kinds
    only), or the defaults."""
    if not path.is_file():
        return Scenario(name="imported")
    from pydrake.common.yaml import yaml_load_typed

    try:
        return yaml_load_typed(schema=Scenario, filename=str(path))
    except Exception as err:
        raise UsageError(f"malformed scene settings {path}: {first_line(err)}") from None


def _shelf(scene: _Scene) -> tuple[RigidTransform, ShelfConfig]:
    """The shelf frame's pose in the world and the shelf, from the `shelf` model's panels."""
    plant = scene.plant
    if not plant.HasModelInstanceNamed("shelf"):
        scene.fail("no model named 'shelf'")
    instance = plant.GetModelInstanceByName("shelf")
    bodies = plant.GetBodyIndices(instance)
    panels = {name: shape for b in bodies for name, shape, _ in scene.shapes(plant.get_body(b))
              if isinstance(shape, Box)}
    missing = [p for p in SHELF_PANELS if p not in panels]
    if len(bodies) != 1 or missing:
        scene.fail(f"the shelf model needs one body with the box panels {', '.join(SHELF_PANELS)}"
                   f" (missing: {', '.join(missing) or 'none'})")
    floor, top = panels["floor"], panels["top"]
    t = float(floor.height())  # the floor panel's thickness (Box: width x, depth y, height z)
    top_z = next(pose.translation()[2] for name, _, pose in scene.shapes(plant.get_body(bodies[0]))
                 if name == "top")
    X_WS = plant.EvalBodyPoseInWorld(scene.context, plant.get_body(bodies[0]))
    shelf = ShelfConfig(depth=float(floor.width()) - t, width=float(floor.depth()) - 2 * t,
                        height=float(top_z - top.height() / 2), wall_thickness=t,
                        floor_height=float(X_WS.translation()[2]))
    expected = StationConfig().X_WS(shelf.floor_height)
    if not X_WS.IsNearlyEqualTo(expected, PLACEMENT_TOLERANCE):
        scene.fail(f"the shelf is welded at {np.round(X_WS.translation(), 4).tolist()} (turned "
                   f"or moved), where the station cannot put it (at "
                   f"{np.round(expected.translation(), 4).tolist()}, unturned)")
    return X_WS, shelf


def _object(scene: _Scene, instance, name: str, X_WS: RigidTransform, kind: str | None
            ) -> ObjectConfig:
    """One scene object: a single free body with one box or cylinder collision shape."""
    plant = scene.plant
    bodies = plant.GetBodyIndices(instance)
    body = plant.get_body(bodies[0]) if len(bodies) == 1 else None
    shapes = scene.shapes(body) if body is not None else []
    if body is None or not body.is_floating_base_body() or len(shapes) != 1:
        scene.fail(f"model {name!r} is not an object: an object is one free body with one "
                   "collision shape")
    _, shape, X_BG = shapes[0]
    if isinstance(shape, Box):
        kind_shape, size = "box", [float(shape.width()), float(shape.depth()), float(shape.height())]
    elif isinstance(shape, Cylinder):
        kind_shape, size = "cylinder", [float(shape.radius()), float(shape.length())]
    else:
        scene.fail(f"model {name!r} has an unknown model kind: a {type(shape).__name__} "
                   "(objects are boxes and cylinders)")
    if not X_BG.IsNearlyEqualTo(RigidTransform(), PLACEMENT_TOLERANCE):
        scene.fail(f"model {name!r}: its shape is offset in its body frame (objects are "
                   "centred on their bodies)")
    X_SO = X_WS.inverse() @ plant.GetDefaultFloatingBaseBodyPose(body)
    R = X_SO.rotation().matrix()
    if R[2, 2] < 1.0 - 1e-9:
        scene.fail(f"model {name!r} does not stand upright")
    p = X_SO.translation()
    if abs(p[2] - size[-1] / 2) > PLACEMENT_TOLERANCE:
        scene.fail(f"model {name!r} does not stand on the shelf floor (its centre is "
                   f"{p[2] * 1000:.1f} mm above it, half its height is {size[-1] * 500:.1f} mm)")
    if kind is None:
        kind = ("cylinder" if kind_shape == "cylinder" else "square_pillar"
                if abs(size[0] - size[1]) < 1e-9 else "rectangular")
    return ObjectConfig(name=body.name(), kind=kind, shape=kind_shape, size=size,
                        x=float(p[0]), y=float(p[1]), yaw=math.atan2(R[1, 0], R[0, 0]),
                        mass=float(body.default_mass()))
