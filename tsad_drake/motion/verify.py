"""Motion verification of pick-and-place actions: keyframes, segments, dense collision re-check.

`plan_action` turns one action into IK keyframes (keyframes.py) and optimised segments
(trajectory.py) in the three phase models (scene.py), then re-checks every exported segment with
the phase's SceneGraphCollisionChecker, independent of the optimiser: every exported sample, and
the straight joint-space edge between consecutive samples at the checker's `edge_step`. The result
is `verified` or a named failure (which keyframe's IK failed, which segment failed to optimise, or
the time and body pair of a collision).

`verify_plan` runs a whole plan on the true scene (objects move as in the world model: the centre
goes to (x, y), the yaw turns by theta_place - theta_pick); `motion_check` answers one action for a
planner's closed loop.
"""

from __future__ import annotations

import copy
import dataclasses as dc
import time

import numpy as np
from pydrake.math import RigidTransform

from tsad_drake.geometry2d import convex_polygon_distance
from tsad_drake.motion.cartesian import LineError, line_path, time_path
from tsad_drake.motion.keyframes import (
    R_SG,
    KeyframeError,
    grasp_geometry,
    keyframe_targets,
    solve_keyframe,
)
from tsad_drake.motion.scene import Held, MotionConfig, MotionModel
from tsad_drake.motion.trajectory import (
    ARM_VELOCITY_LIMIT,
    SegmentError,
    linear_segment,
    optimise_segment,
    sample_trajectory,
)
from tsad_drake.planning.types import Action
from tsad_drake.scenario import CONTACT_TOLERANCE, ObjectConfig, Scenario
from tsad_drake.station import StationConfig
from tsad_drake.station_models import FINGER_OPEN, X_SO

#: m, tcp of the ready configuration in S (outside the shelf, facing it) with the station's
#: default 0.70 m shelf distance; every plan starts there
READY_TCP_S = (-0.15, 0.0, 0.15)
#: m, the ready tcp stays at least this far in front of the shelf when the robot stands nearer
READY_OUTSIDE = 0.05


def ready_tcp_S(X_WS: RigidTransform) -> np.ndarray:
    """The ready tcp position in S: where READY_TCP_S is for the default station, in front of
    the robot's base (a robot placed nearer the shelf keeps it there, at least READY_OUTSIDE in
    front of the shelf; nearer its base the arm cannot point the tool at the shelf)."""
    default_x = StationConfig().shelf_distance + READY_TCP_S[0]  # m, along world x
    x = min(default_x - float(X_WS.translation()[0]), -READY_OUTSIDE)
    return np.array([x, READY_TCP_S[1], READY_TCP_S[2]])


@dc.dataclass
class Segment:
    """One checked piece of motion: motion-plant positions (arm joints, then fingers) over time."""

    name: str  #: "<from keyframe>-><to keyframe>" or "preshape" / "close" / "open"
    times: np.ndarray  #: (N,) s, on the plan's time line
    q: np.ndarray  #: (N, 8) UR5e joints (rad) then finger joints (m)
    held: str | None  #: name of the object in the gripper, if any


@dc.dataclass
class ActionMotion:
    """The motion of one action: verified, or a named failure; scene before and after."""

    action: Action
    verified: bool
    failure: str
    segments: list[Segment]
    objects_before: list[ObjectConfig]  #: true objects when the action starts
    objects_after: list[ObjectConfig]  #: true objects when it ends (the held one moved)
    X_TO: RigidTransform | None  #: held object's pose in the tcp frame while carried
    keyframes: dict[str, np.ndarray]  #: name -> motion-plant positions of each solved keyframe
    planning_time_s: float

    @property
    def end_q(self) -> np.ndarray | None:
        return self.segments[-1].q[-1] if self.verified else None


class MotionFailure(RuntimeError):
    """A named reason why an action has no verified motion."""


def moved_object(obj: ObjectConfig, action: Action) -> ObjectConfig:
    """Where the world model puts the object: centre at (x, y), yaw turned by the angle change."""
    return dc.replace(obj, x=float(action.x), y=float(action.y),
                      yaw=float(obj.yaw + action.theta_place - action.theta_pick))


def _first_collision(model: MotionModel, times: np.ndarray, qs: np.ndarray) -> str | None:
    """None when every sample and every edge between samples is collision-free, else what hit."""
    checker = model.checker
    edges = checker.CheckEdgesCollisionFree([(qs[i], qs[i + 1]) for i in range(len(qs) - 1)])
    if edges and all(edges):  # an edge check includes its ends: the samples need no check
        return None
    # something hit: the first colliding sample, or the first point of an edge before it
    free = checker.CheckConfigsCollisionFree(list(qs))
    bad = [i for i, ok in enumerate(free) if not ok]
    limit = bad[0] if bad else len(qs) - 1
    for i, ok in enumerate(edges[:limit]):
        if not ok:
            steps = max(int(np.ceil(np.linalg.norm(qs[i + 1] - qs[i]) / checker.edge_step_size())), 1)
            for s in np.linspace(0.0, 1.0, steps + 1):
                q = qs[i] + s * (qs[i + 1] - qs[i])
                if not checker.CheckConfigCollisionFree(q):
                    return _describe(model, times[i] + s * (times[i + 1] - times[i]), q)
    if bad:
        return _describe(model, times[bad[0]], qs[bad[0]])
    return None


def _describe(model: MotionModel, t: float, q: np.ndarray) -> str:
    a, b, margin = model.closest_pair(q)
    return f"collision at t = {t:.3f} s between {a} and {b} ({margin * 1000:+.1f} mm from the bound)"


def check_segment(model: MotionModel, segment: Segment) -> str | None:
    """Dense re-check of an exported segment; None when collision-free, else the named failure."""
    hit = _first_collision(model, segment.times, segment.q)
    return None if hit is None else f"segment {segment.name}: {hit}"


def _arm_segment(model: MotionModel, name: str, q0: np.ndarray, q1: np.ndarray, t0: float
                 ) -> Segment:
    """Optimise, sample and densely check one arm segment; raises MotionFailure.

    With `lazy_collision` (default) the segment is first optimised without the minimum-distance
    constraints (milliseconds) and kept when the dense check passes; otherwise (or when not lazy)
    it is optimised with them, and the dense check decides again.
    """
    config = model.config
    held = _held_name(model)
    hit = "not tried"
    if config.lazy_collision:
        try:
            segment = _sampled(model, name, optimise_segment(model, q0, q1, False), t0, held)
            hit = _first_collision(model, segment.times - t0, segment.q)
            if hit is None:
                return segment
        except SegmentError as err:
            hit = str(err)
    try:
        segment = _sampled(model, name, optimise_segment(model, q0, q1), t0, held)
    except SegmentError as err:
        raise MotionFailure(f"segment {name} failed to optimise: {err}"
                            + ("" if hit == "not tried" else
                               f"; without the distance constraints: {hit}")) from None
    failure = check_segment(model, segment)
    if failure is not None:
        raise MotionFailure(failure)
    return segment


def _held_name(model: MotionModel) -> str | None:
    """Name of the object the phase model carries, if any (recorded on its segments)."""
    return None if model.held is None else model.held.obj.name


def _sampled(model: MotionModel, name: str, traj, t0: float, held: str | None) -> Segment:
    times, qs = sample_trajectory(traj, model.config.sample_step)
    return Segment(name, times + t0, qs, held)


def _gripper_segment(model: MotionModel, name: str, q0: np.ndarray, q1: np.ndarray, t0: float,
                     held: str | None) -> Segment:
    times, qs = linear_segment(q0, q1, model.config.gripper_duration, model.config.sample_step)
    segment = Segment(name, times + t0, qs, held)
    failure = check_segment(model, segment)
    if failure is not None:
        raise MotionFailure(failure)
    return segment


class _ActionPlanner:
    """The state of one action's planning (keyframes, segments, time line)."""

    def __init__(self, shelf, X_WS: RigidTransform, objects: list[ObjectConfig], action: Action,
                 config: MotionConfig):
        self.shelf, self.X_WS, self.config, self.action = shelf, X_WS, config, action
        self.objects = objects
        names = [o.name for o in objects]
        if action.object not in names:
            raise MotionFailure(f"no object named {action.object!r} in the scene")
        self.obj = objects[names.index(action.object)]
        self.keyframes: dict[str, np.ndarray] = {}
        self.segments: list[Segment] = []
        self.X_TO: RigidTransform | None = None
        self.after = [moved_object(o, action) if o.name == action.object else o for o in objects]

    def keyframe(self, model: MotionModel, name: str, X_ST: RigidTransform, previous: np.ndarray,
                 finger: float) -> np.ndarray:
        try:
            q = solve_keyframe(model, self.X_WS @ X_ST, previous[model.arm_indices], finger)
        except KeyframeError as err:
            raise MotionFailure(f"keyframe {name}: {err}") from None
        self.keyframes[name] = q
        return q

    def move(self, model: MotionModel, start: str, end: str, q0: np.ndarray,
             X_ST: RigidTransform, finger: float, line: bool = True) -> np.ndarray:
        """Append the segment from q0 to keyframe `end` (tcp at X_ST); returns where it ends.

        With `line` (a move inside the shelf) and `straight_lines`, the tcp follows the straight
        line to X_ST (`cartesian.py`) and the line's end becomes the keyframe; only when the line
        cannot be followed or collides is the keyframe solved by IK from q0 and the segment
        optimised to it (so a line move costs no IK).
        """
        t0 = self.end
        name = f"{start}->{end}"
        if line and self.config.straight_lines:
            segment = _line_segment(model, name, q0, self.X_WS @ X_ST, t0)
            if segment is not None:
                self.segments.append(segment)
                self.keyframes[end] = segment.q[-1].copy()
                return segment.q[-1].copy()
        q1 = self.keyframe(model, end, X_ST, q0, finger)
        try:
            self.segments.append(_arm_segment(model, name, q0, q1, t0))
        except MotionFailure as err:
            if line or not self.config.straight_lines:
                raise
            q1 = self.keyframes[end] = self._backed_off(model, name, q0, X_ST, finger, err)
        return q1

    def _backed_off(self, model: MotionModel, name: str, q0: np.ndarray, X_ST: RigidTransform,
                    finger: float, failure: MotionFailure) -> np.ndarray:
        """A move in front of the shelf the optimiser could not give directly (it sweeps the
        fingers past an object near the front edge while the tool turns): back the tcp out along
        its own axis by `back_off` (where the arm can), move to the same distance behind the
        target pose, and go in along the target's axis, both ends straight lines. Raises the
        original failure if that fails too; returns where the in-line ends (the keyframe)."""
        back = self.config.back_off

        def backed(X_WT: RigidTransform) -> RigidTransform:
            return RigidTransform(X_WT.rotation(), X_WT.translation()
                                  - back * X_WT.rotation().matrix()[:, 2])

        X_W1 = self.X_WS @ X_ST
        out = _line_segment(model, f"{name} (out)", q0, backed(model.X_WT(q0)), self.end)
        if out is not None:  # none where the arm cannot draw back further (the ready pose)
            self.segments.append(out)
            q0 = out.q[-1]
        try:
            q_in = solve_keyframe(model, backed(X_W1), q0[model.arm_indices], finger)
            self.segments.append(_arm_segment(model, f"{name} (across)", q0, q_in, self.end))
        except (KeyframeError, MotionFailure):
            raise failure from None
        into = _line_segment(model, f"{name} (in)", q_in, X_W1, self.end)
        if into is None:
            raise failure
        self.segments.append(into)
        return into.q[-1].copy()

    def run(self, q_start: np.ndarray) -> None:
        config, action, obj = self.config, self.action, self.obj
        targets = keyframe_targets(obj, action.theta_pick, action.x, action.y, action.theta_place,
                                   config)
        closed = grasp_geometry(obj, action.theta_pick, config).finger
        if closed > FINGER_OPEN:
            raise MotionFailure(f"object {obj.name} is {2 * closed * 1000:.0f} mm wide across the "
                                f"gripper at theta_pick: wider than its stroke")
        pick = MotionModel(self.shelf, self.X_WS, self.objects, config, near=obj.name)
        opening = min(FINGER_OPEN, closed + config.preshape_gap)  # pre-shaped fingers
        q_shaped = q_start.copy()  # the fingers pre-shape before the arm moves in
        q_shaped[pick.finger_indices] = opening
        if not np.allclose(q_shaped, q_start):
            self.segments.append(_gripper_segment(pick, "preshape", q_start, q_shaped, 0.0, None))
        q_pre = self.move(pick, "start", "pre_grasp", q_shaped, targets["pre_grasp"], opening,
                          line=False)
        q_grasp = self.move(pick, "pre_grasp", "grasp", q_pre, targets["grasp"], opening)

        X_WO = self.X_WS @ X_SO(obj) @ RigidTransform([0.0, 0.0, config.lift_gap])
        self.X_TO = pick.X_WT(q_grasp).inverse() @ X_WO
        carry = MotionModel(self.shelf, self.X_WS, self.objects, config, Held(obj, self.X_TO))
        # objects touching the picked one may stay in contact while it rises and leaves
        touching = touching_neighbours(obj, self.objects, config.held_clearance)
        carry.set_held_padding(touching, -CONTACT_TOLERANCE)
        closed_q = q_grasp.copy()
        closed_q[carry.finger_indices] = closed
        self.segments.append(_gripper_segment(carry, "close", q_grasp, closed_q, t0=self.end,
                                              held=obj.name))
        names = ("grasp", "lift", "retreat", "pre_place", "place_above", "place")
        current = closed_q
        for a, b in zip(names[:-1], names[1:], strict=True):
            current = self.move(carry, a, b, current, targets[b], closed,
                                line=(a, b) != ("retreat", "pre_place"))
            if b == "retreat":  # out of the shelf: the held object keeps its clearance again
                carry.set_held_padding(touching, config.held_clearance)
        place = MotionModel(self.shelf, self.X_WS, self.after, config, near=obj.name)
        q_released = current.copy()
        q_released[place.finger_indices] = opening
        self.segments.append(_gripper_segment(carry, "open", current, q_released, t0=self.end,
                                              held=obj.name))
        self.move(place, "place", "post_place", q_released, targets["post_place"], opening)

    @property
    def end(self) -> float:
        """s, where the time line of the segments so far ends."""
        return self.segments[-1].times[-1] if self.segments else 0.0


def touching_neighbours(obj: ObjectConfig, objects: list[ObjectConfig], within: float
                        ) -> list[str]:
    """Names of the objects whose footprints come within `within` (m) of `obj`'s: those it is
    lifted and carried out along (a scenario lets objects touch, `CONTACT_TOLERANCE`)."""
    poly = obj.footprint()
    return [o.name for o in objects
            if o.name != obj.name and convex_polygon_distance(poly, o.footprint()) < within]


def _line_segment(model: MotionModel, name: str, q0: np.ndarray, X_W1: RigidTransform,
                  t0: float) -> Segment | None:
    """The straight-line move from q0 to the tcp pose X_W1, densely checked; None when the line
    cannot be followed or collides (the caller optimises instead)."""
    config = model.config
    try:
        path = line_path(model, q0, X_W1, config.line_step)
    except LineError:
        return None
    times, qs = time_path(path, model.arm_indices, ARM_VELOCITY_LIMIT * config.velocity_scale,
                          config.min_duration, config.sample_step)
    if _first_collision(model, times, qs) is not None:
        return None
    held = _held_name(model)
    return Segment(name, times + t0, qs, held)


def plan_action(scenario: Scenario, objects: list[ObjectConfig], action: Action,
                q_start: np.ndarray, config: MotionConfig | None = None,
                X_WS: RigidTransform | None = None) -> ActionMotion:
    """Keyframes, segments and dense check of one action from q_start (motion-plant positions).

    Never raises for a motion failure: the result carries `verified` False and the reason.
    """
    config = config or MotionConfig()
    X_WS = X_WS if X_WS is not None else StationConfig().X_WS(scenario.shelf.floor_height)
    start = time.perf_counter()
    planner = None
    failure = ""
    try:
        planner = _ActionPlanner(scenario.shelf, X_WS, objects, action, config)
        planner.run(np.asarray(q_start, dtype=float))
    except MotionFailure as err:
        failure = str(err)
    after = planner.after if planner is not None else list(objects)
    return ActionMotion(action, not failure, failure,
                        planner.segments if planner is not None and not failure else [],
                        list(objects), after, planner.X_TO if planner is not None else None,
                        planner.keyframes if planner is not None else {},
                        time.perf_counter() - start)


def transfer_segment(scenario: Scenario, objects: list[ObjectConfig], q0: np.ndarray,
                     q1: np.ndarray, name: str, config: MotionConfig | None = None,
                     X_WS: RigidTransform | None = None) -> Segment:
    """An optimised, densely checked arm move from q0 to q1 (motion-plant positions, nothing held)
    among `objects`, timed from 0; raises MotionFailure."""
    config = config or MotionConfig()
    X_WS = X_WS if X_WS is not None else StationConfig().X_WS(scenario.shelf.floor_height)
    model = MotionModel(scenario.shelf, X_WS, objects, config)
    return _arm_segment(model, name, np.asarray(q0, dtype=float), np.asarray(q1, dtype=float),
                        0.0)


def ready_q(scenario: Scenario, objects: list[ObjectConfig], config: MotionConfig | None = None,
            X_WS: RigidTransform | None = None) -> np.ndarray:
    """Motion-plant positions of the ready configuration (tcp at READY_TCP_S facing the shelf)."""
    config = config or MotionConfig()
    X_WS = X_WS if X_WS is not None else StationConfig().X_WS(scenario.shelf.floor_height)
    model = MotionModel(scenario.shelf, X_WS, objects, config)
    return solve_keyframe(model, X_WS @ RigidTransform(R_SG(0.0), ready_tcp_S(X_WS)),
                          np.asarray(config.home_q), FINGER_OPEN)


#: what `verify_plan` does after an action without a motion
ON_FAILURE = ("move", "skip", "stop")


def verify_plan(scenario: Scenario, actions: list[Action], config: MotionConfig | None = None,
                X_WS: RigidTransform | None = None,
                progress=None, on_failure: str = "move") -> list[ActionMotion]:
    """Plan and verify each action in turn on the true scene (see the module docstring).

    Actions must name true objects. After a failed action, with `on_failure` "move" (default),
    the arm restarts from the ready configuration and the object is still moved (as the symbolic
    world model moves it); "skip": the action is skipped (the arm stays where it was, the object
    where it stood); "stop": no later action is planned (the failed one is the last motion
    returned). `progress(i, motion)`, if given, is called after each action.
    """
    if on_failure not in ON_FAILURE:
        raise ValueError(f"on_failure must be one of {', '.join(ON_FAILURE)}, got {on_failure!r}")
    config = config or MotionConfig()
    X_WS = X_WS if X_WS is not None else StationConfig().X_WS(scenario.shelf.floor_height)
    objects = copy.deepcopy(scenario.objects)
    ready = ready_q(scenario, objects, config, X_WS)
    q, t = ready, 0.0
    motions = []
    for i, action in enumerate(actions):
        motion = plan_action(scenario, objects, action, q, config, X_WS)
        for segment in motion.segments:
            segment.times = segment.times + t
        if motion.verified:
            q, t = motion.end_q, motion.segments[-1].times[-1]
            objects = motion.objects_after
        elif on_failure == "move":
            q, objects = ready, motion.objects_after
        motions.append(motion)
        if progress is not None:
            progress(i, motion)
        if not motion.verified and on_failure == "stop":
            break
    return motions


#: the segment that ends with the object lifted out of the shelf (the end of a retrieval)
RETREAT_SEGMENT = "lift->retreat"


def retrieval_motion(scenario: Scenario, objects: list[ObjectConfig], target: str, theta: float,
                     q_start: np.ndarray, config: MotionConfig | None = None,
                     X_WS: RigidTransform | None = None) -> ActionMotion:
    """Taking `target` out of the shelf at approach angle `theta` from q_start: the pick half of
    a pick-and-place of the target (approach, grasp, lift, retreat out of the shelf), planned as
    the whole action (placed back where it stands, so the same keyframes are solved) and cut
    after the retreat. Never raises for a motion failure (`verified` False, the reason named)."""
    target_obj = next((o for o in objects if o.name == target), None)
    if target_obj is None:
        raise ValueError(f"no object named {target!r} among the objects")
    action = Action(target, theta, target_obj.x, target_obj.y, theta)
    motion = plan_action(scenario, objects, action, q_start, config, X_WS)
    if motion.verified:
        names = [s.name for s in motion.segments]
        motion = dc.replace(motion, segments=motion.segments[:names.index(RETREAT_SEGMENT) + 1],
                            objects_after=list(objects))
    return motion


def motion_check(scenario: Scenario, action: Action, config: MotionConfig | None = None,
                 X_WS: RigidTransform | None = None) -> tuple[bool, str]:
    """Can the arm carry out `action` in `scenario` (true objects) from the ready pose?

    Returns (True, "") or (False, the named failure). For a planner's closed loop: reject the
    action and plan again without it.
    """
    config = config or MotionConfig()
    X_WS = X_WS if X_WS is not None else StationConfig().X_WS(scenario.shelf.floor_height)
    motion = plan_action(scenario, scenario.objects, action,
                         ready_q(scenario, scenario.objects, config, X_WS), config, X_WS)
    return motion.verified, motion.failure
