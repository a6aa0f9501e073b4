"""Export: plan.json's `motion` section (with its schema check) and the scene as model directives.

The motion section is a list, one record per action (`MOTION_ACTION_KEYS`): the action, `verified`,
`failure`, `planning_time_s`, `position_names` and `segments`, each segment `{name, held, t, q}` with
`q` the FULL position vector of the scene plant (the station's layout: UR5e joints, finger joints,
then every object's free-body quaternion and position, in scenario order) at each time in `t`. A
segment's motion is the straight joint-space interpolation between consecutive samples: that is
what the verifier checked. `validate_motion_section` is the schema, as a function.
"""

from __future__ import annotations

import dataclasses as dc
import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
from pydrake.common.schema import Rotation, Transform
from pydrake.common.yaml import yaml_dump_typed
from pydrake.geometry import Meshcat, MeshcatVisualizer
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import AddFrame, AddModel, AddWeld, ModelDirective, ModelDirectives
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from tsad_drake.motion.verify import ActionMotion
from tsad_drake.outputs import OutputDir
from tsad_drake.scenario import ObjectConfig, Scenario, check_object_name
from tsad_drake.station import HOME_Q, StationConfig
from tsad_drake.station_models import (
    FINGER_JOINTS,
    FINGER_OPEN,
    GRIPPER_MOUNT_FRAME,
    GRIPPER_URL,
    UR5E_JOINTS,
    UR5E_URL,
    X_SO,
    add_scene,
    filter_robot_collisions,
)
from tsad_drake.viewpoints import shelf_prisms

MOTION_ACTION_KEYS = {"object": str, "theta_pick_deg": float, "place_xy": list,
                      "theta_place_deg": float, "verified": bool, "failure": str,
                      "planning_time_s": float, "position_names": list, "segments": list}
SEGMENT_KEYS = {"name": str, "held": (str, type(None)), "t": list, "q": list}
#: package of the generated scene files (package.xml beside scene.dmd.yaml)
SCENE_PACKAGE = "tsad_drake_scene"
#: frame added on the target's body: how the directives record which object is the target
TARGET_FRAME = "tsad_target"
#: file beside scene.dmd.yaml with what Drake models cannot hold: the scenario's planning settings
#: (name, seed, grid, gripper, approach angles, min_gap, occluded) and each object's kind
SETTINGS_FILE = "tsad_scene.yaml"


class SceneLayout:
    """The station's plant layout (robot, gripper, ground, shelf, free objects) for export/replay."""

    def __init__(self, scenario: Scenario, X_WS: RigidTransform | None = None,
                 meshcat: Meshcat | None = None):
        self.X_WS = X_WS if X_WS is not None else StationConfig().X_WS(scenario.shelf.floor_height)
        builder = DiagramBuilder()
        self.plant, self.scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
        plant = self.plant
        models = add_scene(plant, scenario, self.X_WS)
        self.robot, self.gripper, self.bodies = models.robot, models.gripper, models.objects
        plant.Finalize()
        filter_robot_collisions(plant, self.scene_graph, self.robot, self.gripper)
        self.visualizer = (MeshcatVisualizer.AddToBuilder(builder, self.scene_graph, meshcat)
                           if meshcat is not None else None)
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        self.motion_indices = [plant.GetJointByName(n).position_start()
                               for n in (*UR5E_JOINTS, *FINGER_JOINTS)]
        self.tcp = plant.GetFrameByName("tcp", self.gripper)

    def position_names(self) -> list[str]:
        return list(self.plant.GetPositionNames())

    def set_objects(self, objects: list[ObjectConfig]) -> None:
        for obj in objects:
            self.plant.SetFloatingBaseBodyPoseInWorldFrame(self.plant_context, self.bodies[obj.name],
                                                           self.X_WS @ X_SO(obj))

    def set_motion_q(self, q_motion: np.ndarray, held: str | None = None,
                     X_TO: RigidTransform | None = None) -> np.ndarray:
        """Set arm and fingers (and the held object by forward kinematics); the full q."""
        q = self.plant.GetPositions(self.plant_context)
        q[self.motion_indices] = q_motion
        self.plant.SetPositions(self.plant_context, q)
        if held is not None:
            X_WO = self.tcp.CalcPoseInWorld(self.plant_context) @ X_TO
            self.plant.SetFloatingBaseBodyPoseInWorldFrame(self.plant_context, self.bodies[held],
                                                           X_WO)
        return self.plant.GetPositions(self.plant_context)

    def held_X_TO(self, held: str) -> RigidTransform:
        """Held object's pose in the tcp frame for the positions now in the context."""
        X_WT = self.tcp.CalcPoseInWorld(self.plant_context)
        return X_WT.inverse() @ self.plant.EvalBodyPoseInWorld(self.plant_context,
                                                               self.bodies[held])

    def full_trajectories(self, motion: ActionMotion):
        """(segment, full q (N, nq)) of each segment, objects placed as the action moves them."""
        self.set_objects(motion.objects_before)
        out = []
        for segment in motion.segments:
            if segment.held is None and out and out[-1][0].held is not None:
                self.set_objects(motion.objects_after)
            rows = [self.set_motion_q(q, segment.held, motion.X_TO) for q in segment.q]
            out.append((segment, np.array(rows)))
        return out


def motion_section(scenario: Scenario, motions: list[ActionMotion],
                   layout: SceneLayout | None = None) -> list[dict]:
    """plan.json's `motion` list for these motions (see the module docstring)."""
    layout = layout or SceneLayout(scenario)
    names = layout.position_names()
    records = []
    for motion in motions:
        a = motion.action
        segments = [{"name": seg.name, "held": seg.held,
                     "t": [round(float(t), 6) for t in seg.times],
                     "q": np.round(q, 7).tolist()}
                    for seg, q in layout.full_trajectories(motion)]
        records.append({"object": a.object, "theta_pick_deg": math.degrees(a.theta_pick),
                        "place_xy": [float(a.x), float(a.y)],
                        "theta_place_deg": math.degrees(a.theta_place),
                        "verified": bool(motion.verified), "failure": motion.failure,
                        "planning_time_s": round(float(motion.planning_time_s), 4),
                        "position_names": names, "segments": segments})
    return records


def validate_motion_section(section) -> list[str]:
    """Schema check of a `motion` list; returns the problems found (empty when it is valid)."""
    if not isinstance(section, list):
        return ["motion must be a list"]
    errors = []
    for i, rec in enumerate(section):
        where = f"motion[{i}]"
        if not isinstance(rec, dict):
            errors.append(f"{where} must be an object")
            continue
        errors += _check_keys(rec, MOTION_ACTION_KEYS, where)
        if errors:
            continue
        if rec["verified"] == bool(rec["failure"]):
            errors.append(f"{where}: verified must be true exactly when failure is empty")
        if rec["verified"] and not rec["segments"]:
            errors.append(f"{where}: a verified action needs segments")
        n = len(rec["position_names"])
        last_t = -math.inf
        for j, seg in enumerate(rec["segments"]):
            sw = f"{where}.segments[{j}]"
            seg_errors = _check_keys(seg, SEGMENT_KEYS, sw) if isinstance(seg, dict) else [
                f"{sw} must be an object"]
            if seg_errors:
                errors += seg_errors
                continue
            t = seg["t"]
            if len(t) < 2 or len(seg["q"]) != len(t):
                errors.append(f"{sw}: needs at least 2 samples and one q row per time")
            elif any(b < a for a, b in zip(t[:-1], t[1:], strict=True)) or t[0] < last_t - 1e-9:
                errors.append(f"{sw}: times must not decrease")
            elif any(len(row) != n or not all(math.isfinite(v) for v in row) for row in seg["q"]):
                errors.append(f"{sw}: every q row needs {n} finite numbers")
            if t:
                last_t = t[-1]
    return errors


def _check_keys(record: dict, keys: dict, where: str) -> list[str]:
    errors = [f"{where}: missing {k}" for k in keys if k not in record]
    for k, kind in keys.items():
        if k in record and not (isinstance(record[k], kind) or (kind is float and isinstance(
                record[k], int) and not isinstance(record[k], bool))):
            errors.append(f"{where}.{k}: wrong type {type(record[k]).__name__}")
    return errors


# -- model directives ----------------------------------------------------------------------------
def _shape_sdf(shape: str, size) -> str:
    if shape == "cylinder":
        return f"<cylinder><radius>{float(size[0])!r}</radius><length>{float(size[1])!r}</length></cylinder>"
    return f"<box><size>{float(size[0])!r} {float(size[1])!r} {float(size[2])!r}</size></box>"


def _link_sdf(name: str, mass: float, parts: list[tuple[str, tuple, tuple, str]]) -> str:
    """A link with one collision and one visual per (name, pose xyz, size-or-radius, shape)."""
    body = [f"  <link name={quoteattr(name)}>", f"    <inertial><mass>{float(mass)!r}</mass>"
            "<inertia><ixx>0.001</ixx><iyy>0.001</iyy><izz>0.001</izz></inertia></inertial>"]
    for part, xyz, size, shape in parts:
        pose = f"<pose>{float(xyz[0])!r} {float(xyz[1])!r} {float(xyz[2])!r} 0 0 0</pose>"
        geometry = f"<geometry>{_shape_sdf(shape, size)}</geometry>"
        body.append(f"    <collision name={quoteattr(part)}>{pose}{geometry}</collision>")
        body.append(f"    <visual name={quoteattr(part + '_visual')}>{pose}{geometry}</visual>")
    body.append("  </link>")
    return ('<?xml version="1.0"?>\n<sdf version="1.9">\n<model name={}>\n{}\n</model>\n'
            '</sdf>\n').format(quoteattr(name), "\n".join(body))


def write_scene_directives(scenario: Scenario, out_dir: str | Path | OutputDir,
                           X_WS: RigidTransform | None = None) -> Path:
    """Write `scene.dmd.yaml` (+ package.xml, shelf/ground/object SDFormat files and the
    settings Drake cannot hold, SETTINGS_FILE) into out_dir (`import_dmd` reads it back).

    Load it with stock pydrake: a PackageMap holding the project's models/package.xml and
    out_dir/package.xml (package `tsad_drake_scene`), then ProcessModelDirectives(
    LoadModelDirectives(path), plant, parser). The objects are free bodies with their scenario
    poses as default free-body poses; the arm starts at HOME_Q, the fingers open. Object names
    must be safe identifiers (`scenario.check_object_name`, ScenarioError otherwise); they become
    file names through `OutputDir` (a name that would leave out_dir is refused) and are quoted in
    the SDFormat text (the YAML is Drake's `ModelDirectives` written by `yaml_dump_typed`).
    """
    for k, obj in enumerate(scenario.objects):  # also for scenarios that were never validated
        check_object_name(f"objects[{k}].name", obj.name)
    if not isinstance(out_dir, OutputDir):
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        out_dir = OutputDir(out_dir)
    out = out_dir
    X_WS = X_WS if X_WS is not None else StationConfig().X_WS(scenario.shelf.floor_height)
    out.write_text("package.xml",
        f'<?xml version="1.0"?>\n<package format="2">\n  <name>{SCENE_PACKAGE}</name>\n'
        "  <version>0.1.0</version>\n  <description>Generated tsad_drake scene</description>\n"
        '  <maintainer email="tsad-drake@example.com">tsad_drake</maintainer>\n'
        "  <license>BSD-3-Clause</license>\n</package>\n")
    panels = [(name, (p.x, p.y, (p.z0 + p.z1) / 2), (*p.size, p.z1 - p.z0), "box")
              for name, p in zip(("floor", "back", "left", "right", "top"),
                                 shelf_prisms(scenario.shelf), strict=True)]
    out.write_text("shelf.sdf", _link_sdf("shelf", 10.0, panels))
    out.write_text("ground.sdf", _link_sdf("ground", 1.0, [
        ("ground", (0.0, 0.0, -0.01), (4.0, 4.0, 0.02), "box")]))
    out.write_text(SETTINGS_FILE, yaml_dump_typed(dc.replace(scenario, objects=[
        ObjectConfig(name=o.name, kind=o.kind, shape=o.shape, mass=o.mass)
        for o in scenario.objects])))
    out.write_text("scene.dmd.yaml", yaml_dump_typed(scene_directives(scenario, X_WS, {
        obj.name: out.write_text(f"{obj.name}.sdf", _link_sdf(obj.name, obj.mass, [
            (obj.name, (0.0, 0.0, 0.0), tuple(obj.size), obj.shape)])).name
        for obj in scenario.objects})))
    return out.path("scene.dmd.yaml")


def scene_directives(scenario: Scenario, X_WS: RigidTransform,
                     object_files: dict[str, str]) -> ModelDirectives:
    """Drake's ModelDirectives of the scene: the arm at HOME_Q with the fingers open, welded
    ground and shelf, each object a free body at its scenario pose (`object_files`: object name
    -> SDFormat file name in the scene package), and the frame TARGET_FRAME on the target."""
    def model(name: str, file: str, **kwargs) -> ModelDirective:
        return ModelDirective(add_model=AddModel(name=name, file=file, **kwargs))

    def weld(parent: str, child: str, translation=(0.0, 0.0, 0.0)) -> ModelDirective:
        X_PC = Transform(translation=[float(v) for v in translation])
        return ModelDirective(add_weld=AddWeld(parent=parent, child=child, X_PC=X_PC))

    scene = f"package://{SCENE_PACKAGE}"
    directives = [
        model("ur5e", UR5E_URL, default_joint_positions={
            j: [float(q)] for j, q in zip(UR5E_JOINTS, HOME_Q, strict=True)}),
        weld("world", "ur5e::base_link"),
        model("gripper_2f85", GRIPPER_URL,
              default_joint_positions={j: [float(FINGER_OPEN)] for j in FINGER_JOINTS}),
        weld("ur5e::tool0", f"gripper_2f85::{GRIPPER_MOUNT_FRAME}"),
        model("ground", f"{scene}/ground.sdf"), weld("world", "ground::ground"),
        model("shelf", f"{scene}/shelf.sdf"), weld("world", "shelf::shelf", X_WS.translation()),
    ]
    for obj in scenario.objects:
        X_WO = X_WS @ X_SO(obj)
        pose = Transform(base_frame="world", translation=[float(v) for v in X_WO.translation()],
                         rotation=Rotation(value=Rotation.Rpy(deg=[0.0, 0.0, math.degrees(obj.yaw)])))
        directives.append(model(obj.name, f"{scene}/{object_files[obj.name]}",
                                default_free_body_pose={obj.name: pose}))
    directives.append(ModelDirective(add_frame=AddFrame(
        name=f"{scenario.target}::{TARGET_FRAME}",
        X_PF=Transform(base_frame=f"{scenario.target}::{scenario.target}"))))
    return ModelDirectives(directives=directives)
