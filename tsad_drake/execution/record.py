"""The episode record: what one episode did, typed, built once by the loop and serialised once.

`EpisodeRecord` is the plan.json document and the bench row: the loop (`execution.episode`) fills
it as the episode runs (actions, rounds, motion verdicts, physics outcomes), the composition root
(`pipeline`) hands it the settings it was run with (`EpisodeInfo`) and, for `tsad plan`, the
continuous-motion section and the config; `to_json` writes it, the one place its JSON is made.
The JSON keys are those plan.json and the bench rows have always had (docs/plan-format.md); the
figures derived from the record (motion-feasible share, seconds per iteration) are computed there.
"""

from __future__ import annotations

import dataclasses as dc
import math
from typing import Any

import numpy as np

from tsad_drake.execution.world import ActionOutcome
from tsad_drake.motion.causes import failure_cause, failure_phase
from tsad_drake.planning.types import Action, Plan

#: decimals angles and coordinates are written with
DECIMALS = 6


def _mean(values: list[float]) -> float | None:
    return sum(values) / len(values) if values else None


def outcome_json(outcome: ActionOutcome) -> dict:
    """What a physics world measured of one action, as plan.json writes it (figures rounded)."""
    record = dc.asdict(outcome)
    for key, value in record.items():
        if isinstance(value, float):
            record[key] = round(value, DECIMALS)
    return record


@dc.dataclass
class ActionRecord:
    """One pick-and-place as the episode executed it (angles in degrees, as plan.json)."""

    object: str  #: the name the planner used (a perceived segment's)
    true_object: str  #: the true object it grasped
    theta_pick_deg: float
    place_xy: tuple[float, float]
    theta_place_deg: float
    sub_search: int = 0
    physics: ActionOutcome | None = None  #: measured by a physics world, else None

    @classmethod
    def of(cls, action: Action, true_name: str = "",
           physics: ActionOutcome | None = None) -> ActionRecord:
        """The record of `action` (perceived names) on true object `true_name`."""
        return cls(action.object, true_name or action.object,
                   round(math.degrees(action.theta_pick), DECIMALS),
                   (round(action.x, DECIMALS), round(action.y, DECIMALS)),
                   round(math.degrees(action.theta_place), DECIMALS), action.sub_search, physics)

    @classmethod
    def from_json(cls, record: dict) -> ActionRecord:
        """A plan.json `actions` entry back (its physics outcome, if any, is not read)."""
        return cls(record["object"], record.get("true_object") or record["object"],
                   float(record["theta_pick_deg"]),
                   (float(record["place_xy"][0]), float(record["place_xy"][1])),
                   float(record["theta_place_deg"]), int(record.get("sub_search", 0)))

    def true_action(self) -> Action:
        """The action on the true object (radians), as the motion level and `tsad verify` take it."""
        return Action(self.true_object, math.radians(self.theta_pick_deg), self.place_xy[0],
                      self.place_xy[1], math.radians(self.theta_place_deg), self.sub_search)

    def to_json(self) -> dict:
        record = {"object": self.object, "true_object": self.true_object,
                  "theta_pick_deg": self.theta_pick_deg, "place_xy": list(self.place_xy),
                  "theta_place_deg": self.theta_place_deg, "sub_search": self.sub_search}
        if self.physics is not None:
            record["physics"] = outcome_json(self.physics)
        return record


@dc.dataclass(frozen=True)
class MotionVerdict:
    """The motion level's answer on one action: verified, or refused in its pick or place half."""

    verified: bool
    failure: str = ""  #: the named failure ("" when verified)

    @property
    def phase(self) -> str:
        """"pick" (the object cannot be taken at theta_pick), "place", or "" when verified."""
        return "" if self.verified else failure_phase(self.failure)


@dc.dataclass
class MotionCheck:
    """One action checked at the motion level before it was executed (or withheld)."""

    action: ActionRecord
    verdict: MotionVerdict

    def to_json(self) -> dict:
        record = {**self.action.to_json(), "verified": self.verdict.verified,
                  "phase": self.verdict.phase, "failure": self.verdict.failure}
        if not self.verdict.verified:
            record["cause"] = failure_cause(self.verdict.failure)
        return record


@dc.dataclass
class RoundRecord:
    """One planner call: what the plan claimed against what happened."""

    planner: str
    claimed_success: bool
    claimed_actions: int
    executed_actions: int
    failure_reason: str
    planning_time_s: float
    theta_star_deg: float | None
    retrievable_after: bool
    falls_after: int
    stats: dict

    @classmethod
    def of(cls, plan: Plan, executed: int, retrievable: bool, falls: int) -> RoundRecord:
        return cls(plan.planner, plan.success, len(plan.actions), executed, plan.failure_reason,
                   plan.planning_time_s,
                   None if plan.theta_star is None else math.degrees(plan.theta_star),
                   retrievable, falls, _jsonable(plan.stats))

    def to_json(self) -> dict:
        return dc.asdict(self)


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


@dc.dataclass
class PhysicsSummary:
    """One episode's figures from a physics world (`ActionRecord.physics` of every action)."""

    actions: int  #: actions with a measured outcome
    simulated: int  #: of those, simulated (not refused before the simulation)
    moved: int
    disturbed: int  #: objects displaced without falling, summed over the actions
    placement_error_mm: float | None
    slip_mm: float | None
    tracking_error_max_rad: float | None
    sim_seconds_per_action: float | None
    real_time_factor: float | None
    retrieval: ActionOutcome | None = None  #: the simulated target retrieval, if any

    @classmethod
    def of(cls, outcomes: list[ActionOutcome], retrieval: ActionOutcome | None = None
           ) -> PhysicsSummary:
        simulated = [m for m in outcomes if m.sim_seconds > 0]
        sim = sum(m.sim_seconds for m in simulated)
        wall = sum(m.wall_seconds for m in simulated)
        return cls(
            actions=len(outcomes), simulated=len(simulated),
            moved=sum(m.moved for m in outcomes),
            disturbed=sum(len(m.disturbed) for m in outcomes),
            placement_error_mm=_mean([m.placement_error_mm for m in simulated if m.moved]),
            slip_mm=_mean([m.slip_mm for m in simulated if m.lifted]),
            tracking_error_max_rad=max((m.tracking_error for m in simulated), default=None),
            sim_seconds_per_action=sim / len(simulated) if simulated else None,
            real_time_factor=sim / wall if wall else None, retrieval=retrieval)

    def to_json(self) -> dict:
        record = dc.asdict(dc.replace(self, retrieval=None))
        del record["retrieval"]
        if self.retrieval is not None:
            record["retrieval"] = outcome_json(self.retrieval)
        return record


@dc.dataclass(frozen=True)
class EpisodeInfo:
    """The settings an episode ran with, as its record names them (`pipeline` fills them in)."""

    ablation: str = "none"
    variant: str = "full"
    observer: str = "raycast"
    world: str = "geometric"
    sensor: str = "ideal"
    config_digest: str | None = None  #: `run_config.config_digest` of the effective config
    #: |R_theta*| on the true scene at the start (the scene's difficulty)
    initial_rearrangement_set_size: int | None = None


@dc.dataclass
class EpisodeRecord:
    """Everything an episode did: the plan.json document and the bench row (`to_json`)."""

    scenario: str
    seed: int
    planner: str
    feasibility: str
    info: EpisodeInfo = dc.field(default_factory=EpisodeInfo)
    success: bool = False
    num_actions: int = 0  #: planned pick-and-places executed plus the final retrieval
    random_actions: int = 0  #: random relocations while the target was unseen
    looks_again: int = 0  #: relocations after a failed plan (`EpisodeConfig.look_again`)
    reobservations: int = 0  #: observations again after a failed plan (`EpisodeConfig.reobserve`)
    relocations: int = 0
    falls: int = 0
    fallen: list[str] = dc.field(default_factory=list)
    failure_reason: str = ""
    #: a planner call reached its wall-clock safety stop: the episode ended there, a failure
    #: whose outcome depends on the machine (`Budget`); never set when the counts end searches
    timed_out: bool = False
    planning_time_s: float = 0.0  #: s, summed over every planner call
    #: feasibility queries the network ran (cache misses) and the seconds spent on them
    #: (encoding and forward passes), summed over every round; 0 for the footprint models
    network_evaluations: int = 0
    network_seconds: float = 0.0
    #: the search's counted work over every round (TSAD: sub-MCTS iterations; ROTS, optimal:
    #: expanded nodes; GP3: order-search iterations), the unit its budget is counted in
    search_iterations: int = 0
    theta_star_deg: float | None = None  #: retrieval angle of the last plan
    actions: list[ActionRecord] = dc.field(default_factory=list)  #: executed actions, in order
    rounds: list[RoundRecord] = dc.field(default_factory=list)  #: per planner call
    closed_loop: bool = True
    #: whether actions were checked at the motion level before execution (`motion_checks`)
    motion_checked: bool = False
    motion_checks: list[MotionCheck] = dc.field(default_factory=list)
    physics: PhysicsSummary | None = None  #: a physics world's figures; None elsewhere
    # -- `tsad plan` only ----------------------------------------------------------------------
    #: the executed actions verified again as one continuous motion (`motion.export`)
    motion: list[dict] | None = None
    settings: dict | None = None  #: the episode's settings by name (`pipeline.EpisodeSettings`)
    config: dict | None = None  #: every setting (`run_config.run_config_record`)
    threads: int | None = None  #: CPU threads the run used

    def motion_feasible_share(self) -> float | None:
        """Share of the checked actions the motion level verified (None: none checked)."""
        checks = self.motion_checks
        return sum(c.verdict.verified for c in checks) / len(checks) if checks else None

    def to_json(self) -> dict:
        """The record as JSON (plan.json fields first; the `tsad plan` sections when set)."""
        row: dict[str, Any] = {
            "scenario": self.scenario, "seed": self.seed, "planner": self.planner,
            "feasibility": self.feasibility, "success": self.success,
            "num_actions": self.num_actions, "random_actions": self.random_actions,
            "looks_again": self.looks_again, "reobservations": self.reobservations,
            "relocations": self.relocations, "falls": self.falls, "fallen": list(self.fallen),
            "failure_reason": self.failure_reason, "timed_out": self.timed_out,
            "planning_time_s": self.planning_time_s,
            "network_evaluations": self.network_evaluations,
            "network_seconds": self.network_seconds, "search_iterations": self.search_iterations,
            "theta_star_deg": (None if self.theta_star_deg is None
                               else round(float(self.theta_star_deg), DECIMALS)),
            "actions": [a.to_json() for a in self.actions],
            "rounds": [r.to_json() for r in self.rounds], "closed_loop": self.closed_loop,
            "motion_checks": [c.to_json() for c in self.motion_checks]}
        if self.motion_checked:
            row["motion_feasible_share"] = self.motion_feasible_share()
        #: s per counted unit of search work (the budget's unit: `search_iterations`)
        row["planning_time_per_iteration_s"] = (self.planning_time_s / self.search_iterations
                                                if self.search_iterations else None)
        row.update(dc.asdict(self.info))
        if self.physics is not None:
            row["physics"] = self.physics.to_json()
        first = self.rounds[0].stats if self.rounds else {}
        if "optimal_finished" in first:  # whether `optimal` proved its plan shortest
            row["optimal_finished"] = bool(first["optimal_finished"])
        plan_only = {"motion": self.motion, "settings": self.settings, "config": self.config,
                     "threads": self.threads}
        row.update({k: v for k, v in plan_only.items() if v is not None})
        return row
