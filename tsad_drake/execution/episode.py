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

from tsad_drake.execution.record import (
    ActionRecord,
    EpisodeInfo,
    EpisodeRecord,
    MotionCheck,
    MotionVerdict,
    PhysicsSummary,
    RoundRecord,
)
from tsad_drake.execution.world import World
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


#: an action check: (current true scene, action naming a true object) -> the motion level's
#: verdict (its `phase` says whether the object cannot be picked at theta_pick at all)
ActionCheck = Callable[[Scenario, Action], MotionVerdict]
#: the feasibility model of one round: (true scene, workspace) -> model (only the oracle reads
#: the true scene)
ModelFactory = Callable[[Scenario, Workspace], FeasibilityModel]


def _round_record(plan: Plan, executed: int, world: World) -> RoundRecord:
    return RoundRecord.of(plan, executed, world.retrievable() and not world.failure,
                          len(world.fallen))


def _execute(world: World, state: PlanningState, actions: list[Action],
             record: EpisodeRecord, check: ActionCheck | None = None,
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
            verdict = check(world.scenario(), true_action)
            record.motion_checks.append(MotionCheck(ActionRecord.of(action, name), verdict))
            if not verdict.verified and withhold:
                return n, action
        outcome = world.execute(true_action)
        record.actions.append(ActionRecord.of(action, name,
                                              outcome if world.measures_physics else None))
        sim = simulate_pick_place(sim, action)
    return len(actions), None


@dc.dataclass
class EpisodeConfig:
    """The closed loop's settings (the run's `episode` section): when an episode gives up, and
    how it plans, looks and acts again. The defaults are the paper's loop; TSAD's `full` variant
    turns its loop extras on (`planners.tsad.config.EPISODE_VARIANTS`)."""

    max_rejections: int = 8  #: consecutive motion-level rejections that end the episode
    #: relocations of a target's neighbour after a plan fails with nothing to execute, each
    #: followed by a new observation (0: the episode ends there)
    look_again: int = 0
    #: observations of the unchanged scene after a failed plan, before acting on it
    reobserve: int = 0
    #: observations of the unchanged scene after a plan that failed as unsolvable (the plan's
    #: stats say `unsolvable`: `planning.solvability`), before `look_again`
    reobserve_unsolvable: int = 0
    #: before asking a planner that does not check itself (`PlannerSpec.checks_solvability`),
    #: test whether any sequence can free the target (`planning.solvability`); when none can,
    #: the round fails at once with the reason (stats `unsolvable`)
    fail_fast: bool = True
    #: a planner with sub-searches still plans all of them in closed loop (and the loop executes
    #: the first), so the executed sub-plan is part of a complete plan; False asks for the first
    #: sub-search only (`PlannerSpec.sub_searches`)
    lookahead: bool = False
    #: keep the rest of the last plan while a new observation still admits it, instead of
    #: planning afresh every round (`PlannerSpec.reuse`)
    reuse_plans: bool = False


def run_episode(world: World, planner: PlannerSpec, model: ModelFactory, config: Any, seed: int,
                closed_loop: bool = True, episode: EpisodeConfig | None = None,
                max_actions: int = DEFAULT_MAX_ACTIONS,
                action_check: ActionCheck | None = None,
                feasibility_name: str = "", info: EpisodeInfo | None = None) -> EpisodeRecord:
    """Run one episode of `planner` in `world` (see the module docstring).

    Args:
        world: the true scene (never shown to the planner; the oracle model reads it).
        planner: the registry entry; its flags say which re-planning features apply.
        model: builds each round's feasibility model.
        config: the planner's config.
        seed: seeds the planner's and the random relocations' generator.
        closed_loop: execute the first sub-search only, then observe and plan again; a plan that
            stops short of the target is still executed when it has actions.
        episode: the loop's settings (`EpisodeConfig`: limits, looks again, plan reuse).
        max_actions: pick-and-places allowed in the episode, random ones included (>= 1).
        action_check: verifies each action before it is executed (motion planning); a planner
            with `exclusions` plans again without a refused action, others' verdicts are kept.
        feasibility_name: recorded name of the model.
        info: the settings the record names (`EpisodeInfo`; the composition root fills it in).
    """
    limits = episode or EpisodeConfig()
    if max_actions < 1:
        raise ValueError("max_actions must be at least 1")
    rng, start = np.random.default_rng(seed), world.scenario()
    workspace = make_workspace(start)
    policy = ReplanningPolicy(planner, config, closed_loop, start, limits.max_rejections,
                              limits.fail_fast, limits.lookahead, limits.reuse_plans)
    record = EpisodeRecord(start.name, seed, planner.name, feasibility_name, info or EpisodeInfo(),
                           closed_loop=closed_loop, motion_checked=action_check is not None)
    models: list[FeasibilityModel] = []  #: every round's model (one per observation)
    reason, unsolvable_looks = "", 0  # why the episode ends; looks again after unsolvable rounds
    while not world.done and not reason:
        if world.num_actions >= max_actions:
            reason = f"action limit {max_actions} reached"
            break
        state = state_from_perception(world.observe())
        models.append(model(world.scenario(), workspace))
        feasibility = policy.model(models[-1])
        if not state.target:
            action = random_action(feasibility, state, workspace, rng)
            if action is None:
                reason = "target unseen and nothing can be moved"
                break
            _execute(world, state, [action], record)
            record.random_actions += 1
            continue
        plan = policy.plan(state, feasibility, workspace, rng)
        if plan.timed_out:
            record.timed_out = True
            record.planning_time_s += plan.planning_time_s
            record.rounds.append(_round_record(plan, 0, world))
            reason = plan.failure_reason
            break
        if (not plan.success and plan.stats.get("unsolvable")
                and unsolvable_looks < limits.reobserve_unsolvable):
            record.planning_time_s += plan.planning_time_s
            record.rounds.append(_round_record(plan, 0, world))
            record.reobservations += 1
            unsolvable_looks += 1
            continue
        if not plan.success and record.reobservations < limits.reobserve:
            record.planning_time_s += plan.planning_time_s
            record.rounds.append(_round_record(plan, 0, world))
            record.reobservations += 1
            continue
        if not plan.success and not plan.actions and record.looks_again < limits.look_again:
            action = neighbour_action(feasibility, state, workspace, rng)
            if action is not None:
                record.planning_time_s += plan.planning_time_s
                record.rounds.append(_round_record(plan, 0, world))
                _execute(world, state, [action], record)
                record.looks_again += 1
                continue
        reason = _round(world, policy, plan, state, workspace, record, limits, max_actions,
                        action_check)
    record.network_evaluations = sum(m.evaluations for m in models)
    record.network_seconds = sum(m.network_seconds for m in models)
    return _finish(record, world, reason)


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
           workspace: Workspace, record: EpisodeRecord, limits: EpisodeConfig, max_actions: int,
           action_check: ActionCheck | None) -> str:
    """Execute one plan's round; returns why the episode ends ("" to go on)."""
    record.planning_time_s += plan.planning_time_s
    if plan.theta_star is not None:
        record.theta_star_deg = math.degrees(plan.theta_star)
    if not plan.success and not (policy.closed_loop and plan.actions):
        record.rounds.append(_round_record(plan, 0, world))
        return f"planning failed: {plan.failure_reason}"
    if not plan.actions:
        world.retrieve()
        record.rounds.append(_round_record(plan, 0, world))
        return "" if world.success else "target not retrievable although the plan claimed it"
    todo = policy.this_round(plan)[:max_actions - world.num_actions]
    executed, rejected = _execute(world, state, todo, record, action_check,
                                  policy.withholds_rejected)
    record.rounds.append(_round_record(plan, executed, world))
    policy.executed(todo, executed, world.scenario())
    if rejected is not None:
        pick = record.motion_checks[-1].verdict.phase == "pick"
        if policy.rejected(rejected, pick, workspace):
            return f"no motion-feasible action after {limits.max_rejections} rejections"
        return ""
    if not policy.closed_loop and not world.done and not world.retrieve():
        return "target not retrievable after the plan"
    return ""


def search_count(stats: dict) -> int:
    """A planner call's counted search work from its stats (see `EpisodeRecord.search_iterations`)."""
    for key in ("iterations_total", "nodes", "gp3_iterations"):
        if key in stats:
            return int(stats[key])
    return 0


def _finish(record: EpisodeRecord, world: World, reason: str) -> EpisodeRecord:
    record.search_iterations = sum(search_count(r.stats) for r in record.rounds
                                   if not r.stats.get("reused"))
    outcome = world.outcome(reason)
    record.success = outcome.success
    record.num_actions = outcome.num_actions - record.random_actions
    record.relocations = outcome.relocations
    record.falls = outcome.falls
    record.fallen = list(world.fallen)
    record.failure_reason = outcome.reason
    if world.measures_physics:
        record.physics = PhysicsSummary.of([a.physics for a in record.actions
                                            if a.physics is not None], world.retrieval)
    return record
