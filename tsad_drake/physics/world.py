"""PhysicsWorld: the episode's World where every pick-and-place is a Drake contact simulation.

Each `execute(action)`:
  1. plans the action's motion (`motion.verify.plan_action`) against the objects as the robot
     believes them: the last observation's estimated centres, headings, footprints and heights,
     moved by the actions executed since (`aimed_at` = "perceived"); before any observation,
     against the true poses ("true"). No motion: a wasted action, nothing simulated;
  2. plays that motion through the PD-controlled joints of the simulated station (diagram.py),
     from the configuration where the previous action's command ended; the fingers close on
     the object and hold it by friction (or, `grasp_mode="weld"`, by a weld switched on once both
     fingers touch it);
  3. lets the scene settle `settle_s` and measures what physics left (outcome.py): which objects
     fell (tilt beyond `fall_tilt_deg` or off the shelf floor), which were disturbed (moved more
     than `disturb_m`), the moved object's placement error, grasp slip, whether it was lifted, and
     the arm's worst tracking error.

`observe()` renders the station's wrist camera (station.py) with every object at its simulated
pose (toppled ones lying), and runs the perception pipeline. The arm is shown at the observation
poses in the renderer's own context; the simulated arm stays where the last action left it.
`retrieve()` simulates the pick half of a motion on the target (approach, grasp, lift, retreat
out of the shelf); `retrievable()` is the 2-D corridor rule on the simulated poses (a lying object
by its projected footprint), a cheap check the episode reports.
"""

from __future__ import annotations

import copy
import dataclasses as dc
import math
import time
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform

from tsad_drake.execution.world import ActionOutcome, GeometricWorld, World, retrieval_angles
from tsad_drake.motion.causes import cause_label, failure_cause
from tsad_drake.motion.scene import MotionConfig
from tsad_drake.motion.verify import (
    ActionMotion,
    MotionFailure,
    plan_action,
    ready_q,
    retrieval_motion,
    transfer_segment,
)
from tsad_drake.perception.observe import PerceptionConfig
from tsad_drake.perception.sensor import SensorConfig
from tsad_drake.perception.types import PerceivedObject, PerceivedScene
from tsad_drake.physics.command import make_command
from tsad_drake.physics.config import PhysicsConfig
from tsad_drake.physics.diagram import SimParts, build_sim, continue_sim, touching
from tsad_drake.physics.outcome import (
    BodyPose,
    body_pose,
    displacement,
    fall_reason,
    relative_slip,
    yaw_error_deg,
)
from tsad_drake.planning.types import Action
from tsad_drake.scenario import ObjectConfig, Scenario
from tsad_drake.station import StationConfig
from tsad_drake.station_models import UR5E_JOINTS

#: segment after which the fingers hold the object, and the one after which it has been lifted
CLOSE_SEGMENT = "close"
LIFT_SEGMENT = "grasp->lift"
#: the segment that ends with the object at the place point, before the fingers open
PLACE_SEGMENT = "place_above->place"


#: m, smallest radius, side or height the motion level is given for a perceived object
MIN_BELIEVED_SIZE = 0.005


def believed_object(perceived: PerceivedObject, name: str) -> ObjectConfig:
    """An upright ObjectConfig from a perceived object: fitted footprint, height = highest point."""
    points = perceived.points
    shape = "cylinder" if perceived.shape == "cylinder" else "box"
    height = max(float(np.max(points[:, 2])) if len(points) else 0.1, MIN_BELIEVED_SIZE)
    # a degenerate fit (a sliver of points) takes the seen points' reach from the centre instead:
    # a radius for a cylinder, a side (twice the reach) for a box
    reach = (float(np.max(np.linalg.norm(points[:, :2] - [perceived.x, perceived.y], axis=1)))
             if len(points) else 0.0)
    fallback = max(reach if shape == "cylinder" else 2.0 * reach, MIN_BELIEVED_SIZE)
    footprint = [float(v) if float(v) >= MIN_BELIEVED_SIZE else fallback
                 for v in perceived.size[:1 if shape == "cylinder" else 2]]
    size = footprint + [height]
    return ObjectConfig(name=name, kind=shape if shape == "cylinder" else "rectangular",
                        shape=shape, size=size, x=float(perceived.x), y=float(perceived.y),
                        yaw=float(perceived.yaw))


def lying_footprint(obj: ObjectConfig, pose: BodyPose) -> ObjectConfig:
    """A box ObjectConfig covering the floor projection of a fallen object (its true footprint
    for the corridor rule): the smallest rectangle aligned with one of the body's axes."""
    h = obj.height
    if obj.shape == "cylinder":
        r = obj.size[0]
        a = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
        local = np.array([[r * math.cos(t), r * math.sin(t), z] for t in a for z in (-h / 2, h / 2)])
    else:
        sx, sy = obj.size[0] / 2, obj.size[1] / 2
        local = np.array([[i * sx, j * sy, k * h / 2] for i in (-1, 1) for j in (-1, 1)
                          for k in (-1, 1)])
    R = pose.X_SB.rotation().matrix()
    points = (pose.X_SB.translation()[None, :] + local @ R.T)
    xy = points[:, :2]
    best = None
    for axis in R.T:
        if np.hypot(axis[0], axis[1]) < 1e-3:
            continue
        yaw = math.atan2(axis[1], axis[0])
        c, s = math.cos(yaw), math.sin(yaw)
        u = xy @ np.array([c, s])
        v = xy @ np.array([-s, c])
        area = (u.max() - u.min()) * (v.max() - v.min())
        if best is None or area < best[0]:
            centre = np.array([(u.max() + u.min()) / 2, (v.max() + v.min()) / 2])
            best = (area, yaw, u.max() - u.min(), v.max() - v.min(),
                    centre[0] * c - centre[1] * s, centre[0] * s + centre[1] * c)
    if best is None:  # standing after all: keep the upright footprint
        return dc.replace(obj, x=pose.x, y=pose.y, yaw=pose.yaw)
    _, yaw, su, sv, x, y = best
    # an object that fell out of the shelf lies below its floor: it keeps a token slab there, so
    # that every consumer can still name it (a Drake Box with a height <= 0 aborts the process)
    top = max(float(points[:, 2].max()), MIN_BELIEVED_SIZE)
    return dc.replace(obj, shape="box", size=[float(su), float(sv), top], x=float(x), y=float(y),
                      yaw=float(yaw))


class PhysicsWorld(World):
    """The true scene as a Drake contact simulation (see the module docstring).

    Args:
        scenario: the true scene at the start (objects at rest, standing).
        config: simulation, control and judging settings.
        segmentation: how `observe()` segments ("label" or "cluster").
        motion: the motion planner's settings.
        station: the station layout (robot base, shelf placement, camera).
        perception: the perception pipeline's settings (default: the ideal sensor's).
        sensor: the depth sensor model applied to every render (default: ideal).
        noise_seed: seed of the sensor's random effects (each observation draws afresh).
    """

    measures_physics = True

    def __init__(self, scenario: Scenario, config: PhysicsConfig | None = None,
                 segmentation: str = "label", motion: MotionConfig | None = None,
                 station: StationConfig | None = None,
                 perception: PerceptionConfig | None = None,
                 sensor: SensorConfig | None = None, noise_seed: int = 0) -> None:
        super().__init__()
        self.perception_config = perception or PerceptionConfig()
        self.sensor = sensor or SensorConfig()
        self.noise_seed = noise_seed
        self._observations = 0
        self.config = config or PhysicsConfig()
        self.motion_config = motion or MotionConfig()
        self.station_config = station or StationConfig()
        self.segmentation = segmentation
        self._start = copy.deepcopy(scenario)
        self.X_WS = self.station_config.X_WS(scenario.shelf.floor_height)
        #: motion-plant positions (6 arm joints, 2 fingers) where the next command starts
        self.ready = ready_q(scenario, scenario.objects, self.motion_config, self.X_WS)
        self.q_command = self.ready.copy()
        self.sim: SimParts = build_sim(scenario, self.q_command, self.config, self.station_config)
        self._station = None  # the rendering station, built on the first observe()
        #: the objects as the robot believes them (from the last observation, moved by every
        #: executed action as the plan moved them); None: aim at the truth
        self._believed: list[ObjectConfig] | None = None
        self.outcomes: list[ActionOutcome] = []  #: every executed action's outcome, in order
        self.motions: list[ActionMotion] = []  #: the motion each action was planned as
        self.retrieval: ActionOutcome | None = None  #: the simulated target retrieval, if any
        #: (time, plant positions) every monitor step of every simulated motion: the replay
        self.trace: list[tuple[float, np.ndarray]] = [
            (0.0, self.sim.plant.GetPositions(self.sim.plant_context).copy())]
        self._arm = [self.sim.plant.GetJointByName(n, self.sim.models.robot).position_start()
                     for n in UR5E_JOINTS]

    def write_replay(self, out_path) -> Path:
        """A Meshcat recording of everything simulated so far (`trace`), as an offline page."""
        from tsad_drake.motion.replay import write_trace_html

        return write_trace_html(self._start, self.X_WS, self.trace, out_path)

    # -- reading the simulated state -----------------------------------------------------------
    def poses(self) -> dict[str, BodyPose]:
        """Every object's simulated pose in the shelf frame, by name."""
        plant, context = self.sim.plant, self.sim.plant_context
        X_SW = self.X_WS.inverse()
        return {name: body_pose(X_SW @ plant.EvalBodyPoseInWorld(context, body))
                for name, body in self.sim.models.objects.items()}

    def _X_TO(self, name: str) -> RigidTransform:
        plant, context = self.sim.plant, self.sim.plant_context
        X_WT = plant.GetFrameByName("tcp", self.sim.models.gripper).CalcPoseInWorld(context)
        return X_WT.inverse() @ plant.EvalBodyPoseInWorld(context, self.sim.models.objects[name])

    # -- the World interface -------------------------------------------------------------------
    def observe(self) -> PerceivedScene:
        from tsad_drake.perception.observe import observe
        from tsad_drake.station import MakeStation

        if self._station is None:
            self._station = MakeStation(self._start, config=self.station_config)
        station = self._station
        plant, context = self.sim.plant, self.sim.plant_context
        for body in station.object_bodies:
            X_WB = plant.EvalBodyPoseInWorld(context, self.sim.models.objects[body.name()])
            station.plant.SetFreeBodyPose(station.plant_context, body, X_WB)
        scene = observe(station, segmentation=self.segmentation, sensor=self.sensor,
                        config=self.perception_config,
                        noise_seed=[self.noise_seed, self._observations]).scene
        self._observations += 1
        self.believe(scene)
        return scene

    def scenario(self) -> Scenario:
        """The true scene now: standing objects at their simulated planar poses; a fallen one
        (listed in `fallen`) as the box covering its floor projection."""
        scenario = copy.deepcopy(self._start)
        poses = self.poses()
        objects = []
        for obj in scenario.objects:
            pose = poses[obj.name]
            if obj.name in self.fallen and fall_reason(obj, pose, scenario.shelf, self.config):
                objects.append(lying_footprint(obj, pose))
            else:
                objects.append(dc.replace(obj, x=pose.x, y=pose.y, yaw=pose.yaw))
        scenario.objects = objects
        return scenario

    def true_name(self, name: str, x: float, y: float) -> str:
        if name in self.sim.models.objects:
            return name
        poses = self.poses()
        return min(poses, key=lambda n: math.hypot(poses[n].x - x, poses[n].y - y))

    def retrievable(self) -> bool:
        """The corridor rule on the simulated poses (a cheap check; `retrieve` simulates)."""
        return GeometricWorld(self.scenario()).retrievable()

    def retrieve(self) -> bool:
        """Simulate taking the target out: approach, grasp, lift and retreat out of the shelf at
        the first angle with a motion on the believed scene (the corridor rule's clear angle on
        the believed scene first, then by |theta|). False, and no action counted, when no angle
        has a motion; a simulated attempt counts one action and succeeds when the target leaves
        the shelf in the gripper (`retrieval` holds its outcome)."""
        if self.done:
            return self.success
        target = self._start.target
        objects, aimed_at = self.believed_objects(target)
        motion, refused = self._retrieval_motion(objects, target)
        if motion is None:
            self.failure = self.failure or ("no retrieval motion: every angle refused on the "
                                            f"believed scene ({refused})")
            return False
        self.num_actions += 1
        before = self.poses()
        outcome = ActionOutcome(target, False, aimed_at=aimed_at,
                                planning_seconds=motion.planning_time_s)
        seen = self._play(target, motion, outcome)
        after = self.poses()
        fallen_before = len(self.fallen)
        self._judge_neighbours(target, before, after, outcome)
        pose = after[target]
        lift = seen[LIFT_SEGMENT][1].z - before[target].z
        outcome.lifted = lift >= self.config.lift_min
        outcome.slip_mm, outcome.slip_deg = relative_slip(seen[CLOSE_SEGMENT][0],
                                                          self._X_TO(target))
        if pose.x >= 0.0 or pose.z - before[target].z < self.config.lift_min:
            outcome.reason = (f"the target was not carried out of the shelf (it is at x = "
                              f"{pose.x * 1000:.0f} mm, {(pose.z - before[target].z) * 1000:.0f}"
                              f" mm above where it stood)")
            if fall_reason(self._start.object(target), pose, self._start.shelf, self.config):
                self._knock(target)
            self.failure = self.failure or f"retrieval failed: {outcome.reason}"
        else:
            outcome.moved = True
            self.success = True
        outcome.fallen = self.fallen[fallen_before:]
        self.q_command = motion.segments[-1].q[-1]
        self.retrieval = outcome
        return self.success

    def _retrieval_motion(self, objects: list[ObjectConfig], target: str
                          ) -> tuple[ActionMotion | None, str]:
        """The pick half (through the retreat) of a motion taking the target, or None and why
        each angle was refused (where and which bodies)."""
        scene = dc.replace(copy.deepcopy(self._start), objects=copy.deepcopy(objects))
        refused = []
        for theta in retrieval_angles(scene):
            motion = retrieval_motion(self._start, objects, target, theta, self.q_command,
                                      self.motion_config, self.X_WS)
            if motion.verified:
                return motion, ""
            cause = failure_cause(motion.failure)
            parts = [f"{math.degrees(theta):.0f} deg", cause["where"],
                     " vs ".join(cause["bodies"]) or cause_label(cause)]
            refused.append(" ".join(p for p in parts if p))
        return None, "; ".join(refused)

    def execute(self, action: Action) -> ActionOutcome:
        if self.done:
            return ActionOutcome(action.object, False, reason="the episode is over")
        if action.object not in self.sim.models.objects:
            raise KeyError(f"no true object named {action.object!r}")
        self.num_actions += 1
        objects, aimed_at = self.believed_objects(action.object)
        believed = next(o for o in objects if o.name == action.object)
        true = self.poses()[action.object]
        aim_error_mm = 1000.0 * math.hypot(believed.x - true.x, believed.y - true.y)
        motion = self._plan(objects, action)
        self.motions.append(motion)
        if aimed_at == "perceived" and motion.verified:
            self._believed = motion.objects_after  # the robot believes it put the object there
        if not motion.verified:
            outcome = ActionOutcome(action.object, False, reason=f"no motion: {motion.failure}",
                                    aimed_at=aimed_at, planning_seconds=motion.planning_time_s)
        else:
            outcome = self._simulate(action, motion, aimed_at)
            self.q_command = motion.end_q
        outcome.aim_error_mm = aim_error_mm
        self.outcomes.append(outcome)
        return outcome

    def execute_motion(self, action: Action, motion: ActionMotion) -> ActionOutcome:
        """Simulate a motion of `action` planned elsewhere (`tsad verify`: verified on the plan's
        scene), open loop: it must be verified and start where the arm's command ended (the
        ready configuration, or the end of the previous motion). `aim_error_mm` is the distance
        from the centre the motion was planned on to the simulated one."""
        if self.done:
            return ActionOutcome(action.object, False, reason="the episode is over")
        if action.object not in self.sim.models.objects:
            raise KeyError(f"no true object named {action.object!r}")
        if not motion.verified:
            raise ValueError("only a verified motion can be simulated")
        if not np.allclose(motion.segments[0].q[0], self.q_command, atol=1e-6):
            raise ValueError("the motion does not start where the arm is")
        self.num_actions += 1
        planned = next(o for o in motion.objects_before if o.name == action.object)
        true = self.poses()[action.object]
        self.motions.append(motion)
        outcome = self._simulate(action, motion, "plan")
        self.q_command = motion.end_q
        outcome.aim_error_mm = 1000.0 * math.hypot(planned.x - true.x, planned.y - true.y)
        self.outcomes.append(outcome)
        return outcome

    # -- executing -----------------------------------------------------------------------------
    def believe(self, scene: PerceivedScene | None) -> None:
        """Set what the robot believes is there (`observe()` does; None: aim at the truth).

        Every perceived object is kept under the true name it maps to (label segmentation: its
        own), as an upright object with the fitted footprint; objects not seen are left out.
        """
        if scene is None:
            self._believed = None
            return
        believed: dict[str, ObjectConfig] = {}
        for p in scene.objects:
            name = self.true_name(p.name, p.x, p.y)
            if name not in believed:
                believed[name] = believed_object(p, name)
        self._believed = list(believed.values())

    def believed_objects(self, picked: str) -> tuple[list[ObjectConfig], str]:
        """The objects the motion is planned against, and "perceived" or "true": the believed
        ones when the picked object is among them, else (and before any observation) the truth."""
        if self._believed is not None and picked in {o.name for o in self._believed}:
            return copy.deepcopy(self._believed), "perceived"
        return self.scenario().objects, "true"

    def _plan(self, objects: list[ObjectConfig], action: Action) -> ActionMotion:
        """The action's motion from where the arm is; when none is found from there, a move back
        to the ready configuration followed by the motion from ready (where the episode's motion
        check plans from)."""
        motion = plan_action(self._start, objects, action, self.q_command, self.motion_config,
                             self.X_WS)
        if motion.verified or np.allclose(self.q_command, self.ready):
            return motion
        from_ready = plan_action(self._start, objects, action, self.ready, self.motion_config,
                                 self.X_WS)
        if not from_ready.verified:
            return motion
        try:
            home = transfer_segment(self._start, objects, self.q_command, self.ready,
                                    "return->ready", self.motion_config, self.X_WS)
        except MotionFailure:
            return motion
        for segment in from_ready.segments:
            segment.times = segment.times + home.times[-1]
        from_ready.segments.insert(0, home)
        from_ready.planning_time_s += motion.planning_time_s
        return from_ready

    def _simulate(self, action: Action, motion: ActionMotion, aimed_at: str) -> ActionOutcome:
        """Play the motion in the simulator and measure the outcome."""
        before = self.poses()
        outcome = ActionOutcome(action.object, False, aimed_at=aimed_at,
                                planning_seconds=motion.planning_time_s)
        seen = self._play(action.object, motion, outcome)
        self._judge(action, before, self.poses(), seen, outcome)
        return outcome

    def _play(self, name: str, motion: ActionMotion, outcome: ActionOutcome
              ) -> dict[str, tuple[RigidTransform, BodyPose]]:
        """Play `motion` (holding object `name`), then settle; fills the outcome's tracking,
        weld and timing fields; returns the held object's pose in the tcp frame and its pose at
        the end of each marked segment the motion has."""
        config = self.config
        start = self.sim.context.get_time()
        command = make_command(motion, start, config.squeeze)
        self.sim.player.set_trajectory(command.trajectory)
        marks = {s: command.segment_ends[s] for s in (CLOSE_SEGMENT, LIFT_SEGMENT, PLACE_SEGMENT)
                 if s in command.segment_ends}
        seen: dict[str, tuple[RigidTransform, BodyPose]] = {}
        worst, worst_joint = 0.0, ""
        end = command.end + config.settle_s
        wall = time.perf_counter()
        t = start
        while t < end - 1e-9:
            pending = [m for m in marks.values() if m > t + 1e-9]
            t = min([t + config.monitor_step, end, *pending])
            self.sim.simulator.AdvanceTo(t)
            self.trace.append((t, self.sim.plant.GetPositions(self.sim.plant_context).copy()))
            q = self.trace[-1][1][self._arm]
            error = np.abs(q - self.sim.player.desired(t)[:6])
            if error.max() > worst:
                worst, worst_joint = float(error.max()), UR5E_JOINTS[int(np.argmax(error))]
            for mark_name, mark in marks.items():
                if mark_name not in seen and t >= mark - 1e-9:
                    seen[mark_name] = (self._X_TO(name), self.poses()[name])
                    if config.grasp_mode == "weld" and mark_name == CLOSE_SEGMENT:
                        outcome.welded = self._weld(name, command.trajectory)
                    if outcome.welded and mark_name == PLACE_SEGMENT:
                        self.sim.plant.SetConstraintActiveStatus(self.sim.plant_context,
                                                                 self.sim.weld, False)
        outcome.wall_seconds = time.perf_counter() - wall
        outcome.sim_seconds = t - start
        outcome.tracking_error, outcome.tracking_joint = worst, worst_joint
        return seen

    def _weld(self, name: str, command) -> bool:
        """Weld the object to the gripper where it is, if both fingers touch it (weld mode)."""
        plant, context = self.sim.plant, self.sim.plant_context
        gripper = self.sim.models.gripper
        body = self.sim.models.objects[name]
        if not all(touching(plant, context, plant.GetBodyByName(f, gripper), body)
                   for f in ("left_finger", "right_finger")):
            return False
        base = plant.GetBodyByName("gripper_base", gripper)
        X_GO = plant.EvalBodyPoseInWorld(context, base).inverse() @ plant.EvalBodyPoseInWorld(
            context, body)
        self.sim = continue_sim(self.sim, self._start, self.config, self.station_config,
                                (name, X_GO), command)
        return True

    def _judge_neighbours(self, picked: str, before: dict[str, BodyPose],
                          after: dict[str, BodyPose], outcome: ActionOutcome) -> None:
        """Knock over the non-picked objects that fell; list the disturbed ones in `outcome`."""
        for obj in self._start.objects:
            if obj.name == picked or obj.name in self.fallen:
                continue
            if fall_reason(obj, after[obj.name], self._start.shelf, self.config):
                self._knock(obj.name)
            elif displacement(before[obj.name], after[obj.name]) > self.config.disturb_m:
                outcome.disturbed.append(obj.name)

    def _judge(self, action: Action, before: dict[str, BodyPose], after: dict[str, BodyPose],
               seen: dict, outcome: ActionOutcome) -> None:
        """Fill `outcome` from the poses before and after, and the marks seen in transport."""
        config, shelf = self.config, self._start.shelf
        fallen_before = len(self.fallen)
        self._judge_neighbours(action.object, before, after, outcome)
        obj = self._start.object(action.object)
        pose = after[obj.name]
        lift = seen[LIFT_SEGMENT][1].z - before[obj.name].z
        outcome.lifted = lift >= config.lift_min
        outcome.slip_mm, outcome.slip_deg = relative_slip(seen[CLOSE_SEGMENT][0],
                                                          seen[PLACE_SEGMENT][0])
        outcome.placement_error_mm = 1000.0 * math.hypot(pose.x - action.x, pose.y - action.y)
        intended = before[obj.name].yaw + action.theta_place - action.theta_pick
        outcome.placement_error_deg = yaw_error_deg(obj, pose.yaw, intended)
        fell = fall_reason(obj, pose, shelf, config)
        if fell and obj.name not in self.fallen:
            self._knock(obj.name)
        outcome.fallen = self.fallen[fallen_before:]
        untracked = outcome.tracking_error > config.tracking_tolerance
        if fell:
            outcome.reason = f"the object fell ({fell})"
        elif not outcome.lifted:
            outcome.reason = f"the grasp failed to lift it ({lift * 1000:.0f} mm)"
        elif outcome.placement_error_mm > config.place_tolerance * 1000.0:
            outcome.reason = (f"placed {outcome.placement_error_mm:.0f} mm from the place point")
        else:
            outcome.moved = True
            self.relocations += 1
        if untracked:
            note = (f"the controller could not track the trajectory ({worst_deg(outcome)} deg "
                    f"at {outcome.tracking_joint})")
            outcome.reason = f"{outcome.reason}; {note}" if outcome.reason else note
        if self._start.target in outcome.fallen and not self.failure:
            self.failure = "target fell"

    def _knock(self, name: str) -> None:
        if name not in self.fallen:
            self.fallen.append(name)


def worst_deg(outcome: ActionOutcome) -> str:
    """The tracking error in degrees, one decimal."""
    return f"{math.degrees(outcome.tracking_error or 0.0):.1f}"
