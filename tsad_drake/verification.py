"""A plan from any planner verified at the motion level on the true scene (`tsad verify`).

`verify_plan` solves each action's motion exactly as `tsad plan --motion` does
(`motion.verify.verify_plan`: IK keyframes, optimised segments, dense collision re-check, one
continuous motion from the ready configuration) and names the cause of every refusal
(`motion.causes.failure_cause`: keyframe or segment, body pair, margin). It stops at the first
refused action, or with `keep_going` skips it (later actions see the scene without it: the arm
where it was, the object where it stood). With `retrieve_target` the target's retrieval (the pick
half of a motion on it: approach, grasp, lift, retreat out of the shelf) is verified last.

A world then executes the verified motions: `geometric` (the 2-D corridor rule judges each
action, `execution.world`) or `physics` (the Drake contact simulation plays each verified motion
open loop, `PhysicsWorld.execute_motion`, and measures what moved, fell or was disturbed, and the
placement error; the retrieval is simulated as `tsad plan --world physics` does it, planned on the
simulated scene).
"""

from __future__ import annotations

import copy
import dataclasses as dc
import math
import time
from collections.abc import Callable
from typing import Any

from tsad_drake.execution.record import outcome_json
from tsad_drake.execution.world import GeometricWorld, retrieval_angles
from tsad_drake.motion.causes import failure_cause
from tsad_drake.motion.verify import ActionMotion, ready_q, retrieval_motion
from tsad_drake.motion.verify import verify_plan as verify_motions
from tsad_drake.placement import placed_config
from tsad_drake.plan_format import action_json, check_actions
from tsad_drake.planning.types import Action
from tsad_drake.run_config import RunConfig, default_run_config
from tsad_drake.scenario import Scenario

#: what executes the verified motions (`--world`)
VERIFY_WORLDS = ("none", "geometric", "physics")
#: the report's format name and version
REPORT_FORMAT = "tsad-verify-report/1"
#: outcome fields the geometric world measures (the physics world fills every field)
GEOMETRIC_FIELDS = ("object", "moved", "fallen", "reason")


@dc.dataclass
class ActionVerdict:
    """One action's verification: its motion's verdict and what the world made of it."""

    index: int
    action: Action
    #: "verified", "refused" or "not checked" (after a refusal, without keep_going)
    status: str
    skipped: bool = False  #: refused and skipped: later actions were checked without it
    failure: str = ""  #: the named motion failure ("" when verified)
    cause: dict | None = None  #: `failure_cause(failure)` of a refusal
    planning_time_s: float = 0.0  #: s, wall-clock time of the action's motion planning
    outcome: dict | None = None  #: what the world did (world geometric or physics), else None
    segments: list[str] = dc.field(default_factory=list)  #: names of the verified segments

    @property
    def ok(self) -> bool:
        """Verified, and moved in the world when one executed it."""
        return self.status == "verified" and (self.outcome is None or bool(self.outcome["moved"]))

    def to_json(self) -> dict:
        return {"index": self.index, **action_json(self.action), "status": self.status,
                "verified": self.status == "verified", "skipped": self.skipped,
                "failure": self.failure, "cause": self.cause,
                "planning_time_s": round(self.planning_time_s, 4), "segments": self.segments,
                "world": self.outcome}


@dc.dataclass
class RetrievalVerdict:
    """The target's retrieval at the end of the plan: its motion and the world's attempt."""

    status: str  #: "verified", "refused" or "not checked" (an action was refused before it)
    theta: float | None = None  #: rad, the angle whose motion verified
    failure: str = ""  #: why no angle had a motion (each angle's failure, "; "-joined)
    cause: dict | None = None  #: the cause at the first angle tried
    tried: list[dict] = dc.field(default_factory=list)  #: per angle: theta_deg, failure
    planning_time_s: float = 0.0  #: s, over every angle tried
    outcome: dict | None = None  #: the world's retrieval (`retrieved`, its reason, measures)

    @property
    def ok(self) -> bool:
        return self.status == "verified" and (self.outcome is None
                                              or bool(self.outcome["retrieved"]))

    def to_json(self) -> dict:
        return {"status": self.status, "verified": self.status == "verified",
                "theta_deg": None if self.theta is None else round(math.degrees(self.theta), 6),
                "failure": self.failure, "cause": self.cause, "tried": self.tried,
                "planning_time_s": round(self.planning_time_s, 4), "world": self.outcome}


@dc.dataclass
class VerificationReport:
    """What `verify_plan` found (`to_json()`: report.json)."""

    scenario: str  #: the scenario's name
    world: str  #: "none", "geometric" or "physics"
    keep_going: bool
    retrieve_target: bool  #: the plan asks for the target's retrieval
    actions: list[ActionVerdict]
    retrieval: RetrievalVerdict | None  #: None when the plan does not retrieve the target
    success: bool  #: every action verified (and moved in the world), the retrieval too if asked
    failure_reason: str  #: the first problem, "" on success
    verification_time_s: float  #: s, wall-clock time of the whole verification
    #: the verified motions in order (the retrieval's last), on one time line; not in the JSON
    motions: list[ActionMotion] = dc.field(default_factory=list, repr=False)
    #: the physics world that ran (its `write_replay`), else None; not in the JSON
    physics_world: Any = dc.field(default=None, repr=False)

    @property
    def planning_times(self) -> list[float]:
        """s, each checked action's motion planning time."""
        return [v.planning_time_s for v in self.actions if v.status != "not checked"]

    def to_json(self) -> dict:
        return {"format": REPORT_FORMAT, "scenario": self.scenario, "world": self.world,
                "keep_going": self.keep_going, "success": self.success,
                "failure_reason": self.failure_reason,
                "num_actions": len(self.actions),
                "verified_actions": sum(v.status == "verified" for v in self.actions),
                "skipped_actions": [v.index for v in self.actions if v.skipped],
                "note": ("refused actions were skipped: the actions after each were checked on "
                         "the scene without it" if any(v.skipped for v in self.actions) else ""),
                "actions": [v.to_json() for v in self.actions],
                "retrieve_target": self.retrieve_target,
                "retrieval": None if self.retrieval is None else self.retrieval.to_json(),
                "verification_time_s": round(self.verification_time_s, 4),
                "motion_planning_time_s": round(sum(self.planning_times), 4)}


def _verdicts(actions: list[Action], motions: list[ActionMotion], keep_going: bool
              ) -> list[ActionVerdict]:
    verdicts = []
    for i, action in enumerate(actions):
        if i >= len(motions):
            verdicts.append(ActionVerdict(i, action, "not checked"))
            continue
        m = motions[i]
        verdicts.append(ActionVerdict(i, action, "verified" if m.verified else "refused",
                                      skipped=keep_going and not m.verified, failure=m.failure,
                                      cause=None if m.verified else failure_cause(m.failure),
                                      planning_time_s=m.planning_time_s,
                                      segments=[seg.name for seg in m.segments]))
    return verdicts


def _verify_retrieval(scenario: Scenario, motions: list[ActionMotion], theta: float | None,
                      config: RunConfig, X_WS) -> tuple[RetrievalVerdict, ActionMotion | None]:
    """The retrieval's motion after the plan's verified motions, at `theta` (None: the angles of
    `retrieval_angles` in turn, the first with a motion wins)."""
    objects, q, t = copy.deepcopy(scenario.objects), None, 0.0
    for m in motions:  # the scene and the arm after the plan (refused actions skipped)
        if m.verified:
            objects, q, t = m.objects_after, m.end_q, float(m.segments[-1].times[-1])
    if q is None:
        q = ready_q(scenario, objects, config.motion, X_WS)
    scene = dc.replace(copy.deepcopy(scenario), objects=copy.deepcopy(objects))
    angles = [theta] if theta is not None else retrieval_angles(scene)
    verdict = RetrievalVerdict("refused")
    for angle in angles:
        motion = retrieval_motion(scenario, objects, scenario.target, angle, q, config.motion,
                                  X_WS)
        verdict.planning_time_s += motion.planning_time_s
        if motion.verified:
            for segment in motion.segments:
                segment.times = segment.times + t
            verdict.status, verdict.theta = "verified", angle
            return verdict, motion
        verdict.tried.append({"theta_deg": round(math.degrees(angle), 6),
                              "failure": motion.failure})
        if verdict.cause is None:
            verdict.cause = failure_cause(motion.failure)
    verdict.failure = "; ".join(f"{r['theta_deg']:g} deg: {r['failure']}" for r in verdict.tried)
    return verdict, None


def _geometric(scenario: Scenario, verdicts: list[ActionVerdict],
               retrieval: RetrievalVerdict | None) -> None:
    """Execute the verified actions (and the retrieval) in the geometric world."""
    world = GeometricWorld(scenario)
    for v in verdicts:
        if v.status == "verified":
            outcome = outcome_json(world.execute(v.action))
            v.outcome = {k: outcome[k] for k in GEOMETRIC_FIELDS}
    if retrieval is not None and retrieval.status == "verified":
        retrieved = world.retrieve()
        retrieval.outcome = {"retrieved": retrieved, "reason": "" if retrieved else (
            world.failure or "the corridor rule finds no clear angle for the target")}


def _physics(scenario: Scenario, verdicts: list[ActionVerdict], motions: list[ActionMotion],
             retrieval: RetrievalVerdict | None, config: RunConfig):
    """Play the verified motions (and simulate the retrieval) in the physics world."""
    from tsad_drake.physics.world import PhysicsWorld

    world = PhysicsWorld(scenario, config.world, "label", config.motion, config.station,
                         config.perception, config.sensor, 0)
    for v in verdicts:
        if v.status == "verified":
            v.outcome = outcome_json(world.execute_motion(v.action, motions[v.index]))
    if retrieval is not None and retrieval.status == "verified":
        retrieved = world.retrieve()
        record = outcome_json(world.retrieval) if world.retrieval is not None else {}
        retrieval.outcome = {**record, "retrieved": retrieved,
                             "reason": "" if retrieved else world.failure}
    return world


def _failure_reason(verdicts: list[ActionVerdict], retrieval: RetrievalVerdict | None,
                    target: str) -> str:
    for v in verdicts:
        if v.status == "refused":
            return f"action {v.index + 1} ({v.action.object}) refused: {v.failure}"
        if v.outcome is not None and target in v.outcome["fallen"]:
            return f"action {v.index + 1} ({v.action.object}) knocked the target over"
        if v.outcome is not None and not v.outcome["moved"]:
            return (f"action {v.index + 1} ({v.action.object}) not moved in the world: "
                    f"{v.outcome['reason']}")
    if retrieval is not None:
        if retrieval.status != "verified":
            return f"no retrieval motion for the target: {retrieval.failure}"
        if retrieval.outcome is not None and not retrieval.outcome["retrieved"]:
            return f"the world did not retrieve the target: {retrieval.outcome['reason']}"
    return ""


def verify_plan(scenario: Scenario, actions: list[Action], world: str = "none",
                retrieve_target: bool = False, theta_retrieve: float | None = None,
                keep_going: bool = False, config: RunConfig | None = None,
                progress: Callable[[int, ActionMotion], None] | None = None
                ) -> VerificationReport:
    """Verify a plan at the motion level on `scenario` and execute it in `world` (see the module
    docstring).

    Args:
        scenario: the true scene.
        actions: the relocations, on true objects (radians, shelf frame).
        world: "none" (motion level only), "geometric" or "physics".
        retrieve_target: also verify (and execute) the target's retrieval after the actions.
        theta_retrieve: rad, the retrieval angle; None: any angle (the clear one first).
        keep_going: skip a refused action instead of stopping there.
        config: motion, station and physics settings (default: `default_run_config()`, what
            `tsad plan` runs with); the station is placed for the shelf (`placement`).
        progress: called with (index, motion) after each action's motion planning.

    Returns:
        The report (`to_json()` is report.json). Raises PlanFormatError (a ValueError) for an
        unknown object or a placement outside the shelf, ValueError for an unknown world,
        PlacementError when the arm cannot reach the whole shelf from any base pose.
    """
    if world not in VERIFY_WORLDS:
        raise ValueError(f"unknown world {world!r}: use one of {', '.join(VERIFY_WORLDS)}")
    check_actions(scenario, actions)
    config = placed_config(scenario, config or default_run_config())
    start = time.perf_counter()
    X_WS = config.station.X_WS(scenario.shelf.floor_height)
    motions = verify_motions(scenario, actions, config.motion, X_WS, progress,
                             on_failure="skip" if keep_going else "stop")
    verdicts = _verdicts(actions, motions, keep_going)
    retrieval, retrieval_move = None, None
    if retrieve_target:
        if all(v.status == "verified" or v.skipped for v in verdicts):
            retrieval, retrieval_move = _verify_retrieval(scenario, motions, theta_retrieve,
                                                          config, X_WS)
        else:
            retrieval = RetrievalVerdict("not checked")
    physics_world = None
    if world == "geometric":
        _geometric(scenario, verdicts, retrieval)
    elif world == "physics":
        physics_world = _physics(scenario, verdicts, motions, retrieval, config)
    verified = [m for m in motions if m.verified] + ([retrieval_move] if retrieval_move else [])
    reason = _failure_reason(verdicts, retrieval, scenario.target)
    return VerificationReport(scenario.name, world, keep_going, retrieve_target, verdicts,
                              retrieval, not reason, reason, time.perf_counter() - start,
                              verified, physics_world)
