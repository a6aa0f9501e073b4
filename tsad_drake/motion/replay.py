"""Replays of a motion plan: an offline Meshcat recording, and an independent collision replay.

`write_replay_html` records the whole plan in a Meshcat listening on localhost only (StartRecording,
set poses, StopRecording, PublishRecording) and saves `StaticHtml()`, a self-contained page that
opens offline; carried objects ride with the gripper.

`replay_collisions` re-checks a plan.json `motion` section by itself: it interpolates each
verified segment's samples `oversample` times finer than the checker's edge step, recomputes the
held object from forward kinematics, and asks SceneGraph for penetrating pairs that involve the
arm, the gripper or the held object (gripper-held-object pairs ignored). It shares nothing with the
planner's collision models but the scene layout.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat, MeshcatParams
from pydrake.math import RigidTransform

from tsad_drake.motion.export import SceneLayout
from tsad_drake.motion.scene import MotionConfig
from tsad_drake.motion.verify import ActionMotion
from tsad_drake.outputs import atomic_write_text
from tsad_drake.planning.types import Action
from tsad_drake.scenario import Scenario

#: m, penetration depth below which a contact is a touch (objects resting on the floor)
TOUCH_DEPTH = 1e-5


def write_replay_html(scenario: Scenario, actions: list[Action], motions: list[ActionMotion],
                      out_path: str | Path, meshcat: Meshcat | None = None,
                      X_WS: RigidTransform | None = None) -> Path:
    """Record every action's motion (failed ones: the object jumps where the world model puts it);
    `X_WS`: the shelf's pose in the world (default: the default station's)."""
    del actions  # the motions carry their actions; kept for the lead's call signature
    meshcat = meshcat or Meshcat(MeshcatParams(host="localhost"))
    layout = SceneLayout(scenario, X_WS, meshcat=meshcat)
    frames, t_end = [], 0.0
    layout.set_objects(scenario.objects)
    for motion in motions:
        if not motion.verified:
            layout.set_objects(motion.objects_after)
            t_end += 0.5
            frames.append((t_end, layout.plant.GetPositions(layout.plant_context).copy()))
            continue
        for segment, q_full in layout.full_trajectories(motion):
            frames += zip(segment.times, q_full, strict=True)
            t_end = float(segment.times[-1])
    return _record(layout, meshcat, frames, out_path)


def write_trace_html(scenario: Scenario, X_WS: RigidTransform,
                     trace: list[tuple[float, np.ndarray]], out_path: str | Path,
                     meshcat: Meshcat | None = None) -> Path:
    """Record a simulated run (`trace`: time and plant positions of the station's layout, as
    `PhysicsWorld.trace` holds them) and save it as an offline page."""
    meshcat = meshcat or Meshcat(MeshcatParams(host="localhost"))
    layout = SceneLayout(scenario, X_WS, meshcat=meshcat)
    if trace and len(trace[0][1]) != layout.plant.num_positions():
        raise ValueError(f"the trace has {len(trace[0][1])} positions, the scene's plant "
                         f"{layout.plant.num_positions()}")
    return _record(layout, meshcat, trace, out_path)


def _record(layout: SceneLayout, meshcat: Meshcat, frames, out_path: str | Path) -> Path:
    """Publish `frames` ((time, full plant positions), in order) as a Meshcat recording and save
    it as a self-contained page."""
    layout.visualizer.StartRecording(True)
    for t, q in frames:
        layout.plant.SetPositions(layout.plant_context, q)
        _frame(layout, float(t))
    layout.visualizer.StopRecording()
    layout.visualizer.PublishRecording()
    return atomic_write_text(out_path, meshcat.StaticHtml())


def _frame(layout: SceneLayout, t: float) -> None:
    layout.context.SetTime(t)
    layout.diagram.ForcedPublish(layout.context)


def replay_collisions(scenario: Scenario, section: list[dict], oversample: int = 5,
                      edge_step: float | None = None) -> list[str]:
    """Collisions found replaying a `motion` section (plan.json) densely; empty when none.

    Each edge between consecutive samples is cut into ceil(|dq| / edge_step) * oversample
    steps (|dq| over the arm and finger joints, as the checker measures it).
    """
    edge_step = edge_step or MotionConfig().edge_step
    layout = SceneLayout(scenario)
    inspector = layout.scene_graph.model_inspector()
    plant = layout.plant
    robot_bodies = {plant.get_body(i).name() for m in (layout.robot, layout.gripper)
                    for i in plant.GetBodyIndices(m)}
    gripper_bodies = {plant.get_body(i).name() for i in plant.GetBodyIndices(layout.gripper)}
    gripper_bodies.add("wrist_3_link")
    names = layout.position_names()
    if section and section[0]["position_names"] != names:
        return ["position_names do not match this scenario's plant"]
    found = []
    for k, record in enumerate(section):
        if not record["verified"]:
            continue
        for seg in record["segments"]:
            q = np.asarray(seg["q"], dtype=float)
            held = seg["held"]
            X_TO = None
            if held is not None:
                plant.SetPositions(layout.plant_context, q[0])
                X_TO = layout.held_X_TO(held)
            for i in range(len(q) - 1):
                dq = q[i + 1][layout.motion_indices] - q[i][layout.motion_indices]
                steps = max(int(np.ceil(np.linalg.norm(dq) / edge_step)), 1) * oversample
                for s in np.linspace(0.0, 1.0, steps + 1)[(1 if i else 0):]:
                    plant.SetPositions(layout.plant_context, q[i])
                    layout.set_motion_q(q[i][layout.motion_indices] + s * dq, held, X_TO)
                    hit = _penetration(layout, inspector, robot_bodies, gripper_bodies, held)
                    if hit:
                        t = seg["t"][i] + s * (seg["t"][i + 1] - seg["t"][i])
                        found.append(f"motion[{k}] {seg['name']} t = {t:.3f} s: {hit}")
                        break
    return found


def _penetration(layout: SceneLayout, inspector, robot_bodies: set[str],
                 gripper_bodies: set[str], held: str | None) -> str:
    query = layout.scene_graph.get_query_output_port().Eval(
        layout.scene_graph.GetMyContextFromRoot(layout.context))
    for pair in query.ComputePointPairPenetration():
        if pair.depth <= TOUCH_DEPTH:
            continue
        a = layout.plant.GetBodyFromFrameId(inspector.GetFrameId(pair.id_A)).name()
        b = layout.plant.GetBodyFromFrameId(inspector.GetFrameId(pair.id_B)).name()
        moving = robot_bodies | ({held} if held else set())
        if a not in moving and b not in moving:
            continue
        if held and {a, b} & {held} and {a, b} & gripper_bodies:
            continue
        return f"{a} and {b} penetrate by {pair.depth * 1000:.2f} mm"
    return ""
