"""One target-retrieval episode: observe, plan, execute in the world, repeat.

Closed loop (the paper's section IV-D): execute only the first sub-search's actions, observe again
and plan again, until the target comes out, the episode fails, or a limit is hit. Open loop:
execute the whole plan once. When the target is not seen (section VI-D), feasible random
relocations (seeded) are made until it is, counted apart as random actions. What the loop
remembers between rounds is the planner's business (`planning.replanning`); the world is any
`World` (`execution.world`).
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from tsad_drake.execution.world import ActionOutcome, World
from tsad_drake.motion.causes import failure_cause
from tsad_drake.planning.actions import random_action
from tsad_drake.planning.interface import FeasibilityModel
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.registry import PlannerSpec
from tsad_drake.planning.replanning import ReplanningPolicy
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.planning.types import Action, Plan, PlanningState, Workspace
from tsad_drake.scenario import Scenario

#: default limit on pick-and-places in one episode (random ones included)
DEFAULT_MAX_ACTIONS = 20


def action_record(action: Action, true_name: str = "") -> dict:
    """An action as plan.json writes it (degrees for angles)."""
    return {"object": action.object, "true_object": true_name or action.object,
            "theta_pick_deg": round(math.degrees(action.theta_pick), 6),
            "place_xy": [round(action.x, 6), round(action.y, 6)],
            "theta_place_deg": round(math.degrees(action.theta_place), 6),
            "sub_search": action.sub_search}


def physics_record(outcome: ActionOutcome) -> dict:
    """What a physics world measured of one action, as plan.json writes it (figures rounded)."""
    record = dc.asdict(outcome)
    for key, value in record.items():
        if isinstance(value, float):
            record[key] = round(value, 6)
    return record


@dc.dataclass
class EpisodeResult:
    """Everything an episode did and what `plan.json` needs."""

    scenario: str
    seed: int
    planner: str
    feasibility: str
    success: bool = False
    num_actions: int = 0  #: planned pick-and-places executed plus the final retrieval
    random_actions: int = 0  #: random relocations while the target was unseen
    looks_again: int = 0  #: relocations after a failed plan (`EpisodeLimits.look_again`)
    reobservations: int = 0  #: observations again after a failed plan (`EpisodeLimits.reobserve`)
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
    actions: list[dict] = dc.field(default_factory=list)  #: executed actions, in order
    rounds: list[dict] = dc.field(default_factory=list)  #: per plan: claim vs outcome, stats
    closed_loop: bool = True
    #: per action checked at the motion level: object, place_xy, verified, failure
    motion_checks: list[dict] = dc.field(default_factory=list)

    def to_json(self) -> dict:
        """A JSON-ready dict (the plan.json fields first)."""
        return dc.asdict(self)


def _round_record(plan: Plan, executed: int, world: World) -> dict:
    return {"planner": plan.planner, "claimed_success": plan.success,
            "claimed_actions": len(plan.actions), "executed_actions": executed,
            "failure_reason": plan.failure_reason, "planning_time_s": plan.planning_time_s,
            "theta_star_deg": None if plan.theta_star is None else math.degrees(plan.theta_star),
            "retrievable_after": world.retrievable() and not world.failure,
            "falls_after": len(world.fallen), "stats": _jsonable(plan.stats)}


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


#: an action check: (current true scene, action naming a true object) -> (ok, reason); a reason
#: starting with "pick" says the object cannot be picked at theta_pick, whatever the placement
ActionCheck = Callable[[Scenario, Action], tuple[bool, str]]
#: the feasibility model of one round: (true scene, workspace) -> model (only the oracle reads
#: the true scene)
ModelFactory = Callable[[Scenario, Workspace], FeasibilityModel]


def _execute(world: World, state: PlanningState, actions: list[Action],
             result: EpisodeResult, check: ActionCheck | None = None,
             withhold: bool = False) -> tuple[int, Action | None]:
    """Execute `actions` in the world; returns how many were executed and the refused one, if any.

    With `check`, every action is verified first (at the motion level) and the verdict recorded;
    with `withhold`, a refused action is not executed and execution stops there.
    """
    sim = state
    for n, action in enumerate(actions):
        if world.done:
            return n, None
        obj = sim.objects[sim.index(action.object)]
        name = world.true_name(action.object, obj.x, obj.y)
        true_action = dc.replace(action, object=name)
        if check is not None:
            ok, why = check(world.scenario(), true_action)
            record = {**action_record(action, name), "verified": ok, "failure": why}
            if not ok:
                record["cause"] = failure_cause(why)
            result.motion_checks.append(record)
            if not ok and withhold:
                return n, action
        outcome = world.execute(true_action)
        record = action_record(action, name)
        if world.measures_physics:
            record["physics"] = physics_record(outcome)
        result.actions.append(record)
        sim = simulate_pick_place(sim, action)
    return len(actions), None


@dc.dataclass
class EpisodeLimits:
    """When an episode gives up."""

    max_actions: int = DEFAULT_MAX_ACTIONS  #: pick-and-places, random ones included (>= 1)
    max_rejections: int = 8  #: consecutive motion-level rejections
    #: relocations of a target's neighbour after a plan fails with nothing to execute, each
    #: followed by a new observation (`TSADConfig.look_again`; 0: the episode ends there)
    look_again: int = 0
    #: observations of the unchanged scene after a failed plan, before acting on it
    #: (`TSADConfig.reobserve`)
    reobserve: int = 0
    #: observations of the unchanged scene after a plan that failed as unsolvable (the plan's
    #: stats say `unsolvable`: `planning.solvability`), before `look_again`
    #: (`TSADConfig.reobserve_unsolvable`)
    reobserve_unsolvable: int = 0
    #: before asking a planner that does not check itself (`PlannerSpec.checks_solvability`),
    #: test whether any sequence can free the target (`planning.solvability`); when none can,
    #: the round fails at once with the reason (stats `unsolvable`)
    fail_fast: bool = True


def run_episode(world: World, planner: PlannerSpec, model: ModelFactory, config: Any, seed: int,
                closed_loop: bool = True, limits: EpisodeLimits | None = None,
                action_check: ActionCheck | None = None,
                feasibility_name: str = "") -> EpisodeResult:
    """Run one episode of `planner` in `world` (see the module docstring).

    Args:
        world: the true scene (never shown to the planner; the oracle model reads it).
        planner: the registry entry; its flags say which re-planning features apply.
        model: builds each round's feasibility model.
        config: the planner's config.
        seed: seeds the planner's and the random relocations' generator.
        closed_loop: execute the first sub-search only, then observe and plan again; a plan that
            stops short of the target is still executed when it has actions.
        limits: action and rejection limits.
        action_check: verifies each action before it is executed (motion planning); a planner
            with `exclusions` plans again without a refused action, for the others the verdict
            is only recorded.
        feasibility_name: recorded name of the model.
    """
    limits = limits or EpisodeLimits()
    if limits.max_actions < 1:
        raise ValueError("max_actions must be at least 1")
    rng = np.random.default_rng(seed)
    start = world.scenario()
    workspace = make_workspace(start)
    policy = ReplanningPolicy(planner, config, closed_loop, start, limits.max_rejections,
                              limits.fail_fast)
    result = EpisodeResult(start.name, seed, planner.name, feasibility_name,
                           closed_loop=closed_loop)
    models: list[FeasibilityModel] = []  #: every round's model (one per observation)
    reason = ""
    unsolvable_looks = 0  #: observations again after unsolvable rounds
    while not world.done and not reason:
        if world.num_actions >= limits.max_actions:
            reason = f"action limit {limits.max_actions} reached"
            break
        state = state_from_perception(world.observe())
        models.append(model(world.scenario(), workspace))
        feasibility = policy.model(models[-1])
        if not state.target:
            action = random_action(feasibility, state, workspace, rng)
            if action is None:
                reason = "target unseen and nothing can be moved"
                break
            _execute(world, state, [action], result)
            result.random_actions += 1
            continue
        plan = policy.plan(state, feasibility, workspace, rng)
        if plan.timed_out:
            result.timed_out = True
            result.planning_time_s += plan.planning_time_s
            result.rounds.append(_round_record(plan, 0, world))
            reason = plan.failure_reason
            break
        if (not plan.success and plan.stats.get("unsolvable")
                and unsolvable_looks < limits.reobserve_unsolvable):
            result.planning_time_s += plan.planning_time_s
            result.rounds.append(_round_record(plan, 0, world))
            result.reobservations += 1
            unsolvable_looks += 1
            continue
        if not plan.success and result.reobservations < limits.reobserve:
            result.planning_time_s += plan.planning_time_s
            result.rounds.append(_round_record(plan, 0, world))
            result.reobservations += 1
            continue
        if not plan.success and not plan.actions and result.looks_again < limits.look_again:
            action = neighbour_action(feasibility, state, workspace, rng)
            if action is not None:
                result.planning_time_s += plan.planning_time_s
                result.rounds.append(_round_record(plan, 0, world))
                _execute(world, state, [action], result)
                result.looks_again += 1
                continue
        reason = _round(world, policy, plan, state, workspace, result, limits, action_check)
    result.network_evaluations = sum(m.evaluations for m in models)
    result.network_seconds = sum(m.network_seconds for m in models)
    return _finish(result, world, reason)


#: how many of the target's nearest neighbours a look-again relocation chooses from
LOOK_AGAIN_NEIGHBOURS = 3


def neighbour_action(feasibility: FeasibilityModel, state: PlanningState, workspace: Workspace,
                     rng: np.random.Generator) -> Action | None:
    """A random feasible relocation of one of the target's `LOOK_AGAIN_NEIGHBOURS` nearest
    neighbours (the objects most likely merged into it, cut from it or hiding it), else of any
    object; None when nothing can be moved."""
    target = state.objects[state.index(state.target)]
    others = sorted((i for i, o in enumerate(state.objects) if o.name != state.target),
                    key=lambda i: math.hypot(state.objects[i].x - target.x,
                                             state.objects[i].y - target.y))
    return (random_action(feasibility, state, workspace, rng,
                          among=others[:LOOK_AGAIN_NEIGHBOURS])
            or random_action(feasibility, state, workspace, rng))


def _round(world: World, policy: ReplanningPolicy, plan: Plan, state: PlanningState,
           workspace: Workspace, result: EpisodeResult, limits: EpisodeLimits,
           action_check: ActionCheck | None) -> str:
    """Execute one plan's round; returns why the episode ends ("" to go on)."""
    result.planning_time_s += plan.planning_time_s
    if plan.theta_star is not None:
        result.theta_star_deg = math.degrees(plan.theta_star)
    if not plan.success and not (policy.closed_loop and plan.actions):
        result.rounds.append(_round_record(plan, 0, world))
        return f"planning failed: {plan.failure_reason}"
    if not plan.actions:
        world.retrieve()
        result.rounds.append(_round_record(plan, 0, world))
        return "" if world.success else "target not retrievable although the plan claimed it"
    todo = policy.this_round(plan)[:limits.max_actions - world.num_actions]
    executed, rejected = _execute(world, state, todo, result, action_check,
                                  policy.withholds_rejected)
    result.rounds.append(_round_record(plan, executed, world))
    policy.executed(todo, executed, world.scenario())
    if rejected is not None:
        pick = result.motion_checks[-1]["failure"].startswith("pick")
        if policy.rejected(rejected, pick, workspace):
            return f"no motion-feasible action after {limits.max_rejections} rejections"
        return ""
    if not policy.closed_loop and not world.done and not world.retrieve():
        return "target not retrievable after the plan"
    return ""


def search_count(stats: dict) -> int:
    """A planner call's counted search work from its stats (see `EpisodeResult.search_iterations`)."""
    for key in ("iterations_total", "nodes", "gp3_iterations"):
        if key in stats:
            return int(stats[key])
    return 0


def _finish(result: EpisodeResult, world: World, reason: str) -> EpisodeResult:
    result.search_iterations = sum(search_count(r["stats"]) for r in result.rounds
                                   if not r["stats"].get("reused"))
    outcome = world.outcome(reason)
    result.success = outcome.success
    result.num_actions = outcome.num_actions - result.random_actions
    result.relocations = outcome.relocations
    result.falls = outcome.falls
    result.fallen = list(world.fallen)
    result.failure_reason = outcome.reason
    return result
