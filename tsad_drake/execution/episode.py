"""One target-retrieval episode: observe, plan, execute in the world model, repeat.

Closed loop (the paper's section IV-D): execute only the first sub-search's actions, observe again
and plan again, until the target comes out, the episode fails, or a limit is hit. Open loop:
execute the whole plan once. When the target is not seen (section VI-D), feasible random
relocations (seeded) are made until it is, counted apart as random actions.
"""

from __future__ import annotations

import dataclasses as dc
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from tsad_drake.execution.world import WorldModel
from tsad_drake.perception.types import PerceivedScene
from tsad_drake.planning.actions import random_action
from tsad_drake.planning.feasibility import angle_index, make_feasibility
from tsad_drake.planning.pick_veto import PickVeto
from tsad_drake.planning.plan_check import action_key, replay_plan
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.planning.types import Action, Plan, PlanningState
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
    relocations: int = 0
    falls: int = 0
    fallen: list[str] = dc.field(default_factory=list)
    failure_reason: str = ""
    planning_time_s: float = 0.0  #: s, summed over every planner call
    #: feasibility queries the network ran (cache misses) and the seconds spent on them
    #: (encoding and forward passes), summed over every round; 0 for the footprint models
    network_evaluations: int = 0
    network_seconds: float = 0.0
    theta_star_deg: float | None = None  #: retrieval angle of the last plan
    actions: list[dict] = dc.field(default_factory=list)  #: executed actions, in order
    rounds: list[dict] = dc.field(default_factory=list)  #: per plan: claim vs outcome, stats
    closed_loop: bool = True
    #: per action checked at the motion level: object, place_xy, verified, failure
    motion_checks: list[dict] = dc.field(default_factory=list)

    def to_json(self) -> dict:
        """A JSON-ready dict (the plan.json fields first)."""
        return dc.asdict(self)


def _round_record(plan: Plan, executed: int, world: WorldModel) -> dict:
    return {"planner": plan.planner, "claimed_success": plan.success,
            "claimed_actions": len(plan.actions), "executed_actions": executed,
            "failure_reason": plan.failure_reason, "planning_time_s": plan.planning_time_s,
            "theta_star_deg": None if plan.theta_star is None else math.degrees(plan.theta_star),
            "retrievable_after": world.retrieval_angle() is not None and not world.failure,
            "falls_after": len(world.fallen), "stats": _jsonable(plan.stats)}


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _true_name(world: WorldModel, sim: PlanningState, action: Action) -> str:
    """The true object an action on a perceived object grasps (by name, else nearest centre)."""
    try:
        world.object(action.object)
        return action.object
    except KeyError:
        obj = sim.objects[sim.index(action.object)]
        return world.nearest(obj.x, obj.y)


#: an action check: (current true scene, action naming a true object) -> (ok, reason); a reason
#: starting with "pick" says the object cannot be picked at theta_pick, whatever the placement
ActionCheck = Callable[[Scenario, Action], tuple[bool, str]]


def _execute(world: WorldModel, state: PlanningState, actions: list[Action],
             result: EpisodeResult, check: ActionCheck | None = None,
             reject: bool = False) -> tuple[int, Action | None]:
    """Apply `actions` in the world; returns how many were applied and the rejected one, if any.

    With `check`, every action is verified first (at the motion level) and the verdict recorded;
    with `reject`, a failing action is not executed and execution stops there.
    """
    sim = state
    for n, action in enumerate(actions):
        if world.done:
            return n, None
        name = _true_name(world, sim, action)
        true_action = dc.replace(action, object=name)
        if check is not None:
            ok, why = check(world.scenario(), true_action)
            result.motion_checks.append({**action_record(action, name), "verified": ok,
                                         "failure": why})
            if not ok and reject:
                return n, action
        world.apply(true_action)
        result.actions.append(action_record(action, name))
        sim = simulate_pick_place(sim, action)
    return len(actions), None


def _configuration(world: WorldModel) -> frozenset:
    """Every object's position in the true scene, to the millimetre. Not its yaw: an object
    picked and put back where it stood, turned, is no progress either. A move whose pick runs
    the arm into a side wall changes nothing at all (held-out scenario 2 seed 43: obj4's
    perceived corridor at -10 degrees misses the wall by 0.17 mm, the true one touches it)."""
    return frozenset((o.name, round(o.x, 3), round(o.y, 3)) for o in world.scenario().objects)


def _cycle(history: list[tuple[frozenset, int]], world: WorldModel,
           executed: list[Action]) -> list[tuple[str, float, float]]:
    """The relocations to exclude when the last round brought the scene back to a configuration
    it was in before (no progress, and planning on the same observation would repeat it): every
    relocation executed since then. Appends the configuration to `history`.

    The network's scenario 2 seed 18 moved obj2 back and forth between two cells until the action
    limit, each observation predicting that the next move clears the target."""
    now = _configuration(world)
    earlier = next((n for config, n in history if config == now), None)
    history.append((now, len(executed)))
    if earlier is None:
        return []
    return [action_key(a) for a in executed[earlier:]]


def _reused(pending: Plan, state: PlanningState, feasibility, workspace,
            excluded: frozenset[tuple[str, float, float]] = frozenset()) -> Plan | None:
    """The rest of the last plan when the new observation still admits it and none of its
    relocations has been excluded since (`excluded`, see `action_key`), else None."""
    start = time.perf_counter()
    if any(action_key(a) in excluded for a in pending.actions):
        return None
    actions = replay_plan(state, pending.actions, pending.theta_star, feasibility, workspace)
    if actions is None:
        return None
    stats = {**pending.stats, "reused": True}
    return dc.replace(pending, actions=actions, planning_time_s=time.perf_counter() - start,
                      stats=stats)


def run_episode(scenario: Scenario, planner: Callable[..., Plan], feasibility_name: str,
                observe: Callable[[Scenario], PerceivedScene], config: Any, seed: int,
                closed_loop: bool = True, max_actions: int = DEFAULT_MAX_ACTIONS,
                planner_name: str = "", action_check: ActionCheck | None = None,
                max_rejections: int = 8) -> EpisodeResult:
    """Run one episode of `planner` on `scenario` (see the module docstring).

    Args:
        scenario: the true scene (never shown to the planner; the oracle model reads it).
        planner: `plan(state, feasibility, workspace, config, rng) -> Plan`.
        feasibility_name: "oracle" | "geometric" (| "net").
        observe: the current true scene -> what the robot perceives.
        config: the planner's config.
        seed: seeds the planner's and the random relocations' generator.
        closed_loop: execute the first sub-search only, then observe and plan again; a planner
            with a `max_sub_searches` config field is asked for that one sub-search only, and a
            plan that stops short of the target is still executed when it has actions. A
            planner whose config has `reuse_plans` set keeps the rest of its last plan while the
            new observation still admits it (`planning.plan_check`).
        max_actions: pick-and-places allowed in the episode, random ones included (>= 1).
        planner_name: recorded name (default: the first plan's `planner` field).
        action_check: verifies each action before it is executed (motion planning). A planner
            whose config has `excluded_actions` plans again with a rejected action excluded (at
            most `max_rejections` times in a row); for other planners the verdict is only recorded.
        max_rejections: consecutive rejections after which the episode fails.
    """
    if max_actions < 1:
        raise ValueError("max_actions must be at least 1")
    rng = np.random.default_rng(seed)
    if closed_loop and hasattr(config, "max_sub_searches") and not getattr(config, "lookahead", False):
        # the paper plans only the first sub-search per observation in closed loop
        config = dc.replace(config, max_sub_searches=1)
    world = WorldModel(scenario)
    workspace = make_workspace(scenario)
    result = EpisodeResult(scenario.name, seed, planner_name, feasibility_name,
                           closed_loop=closed_loop)
    reason = ""
    can_exclude = hasattr(config, "excluded_actions")
    #: relocations (object, x, y) motion planning rejected, for the rest of the episode: cleared
    #: after each executed action, a refusal came back a round later (after an unrelated move)
    #: and cost an action each time
    excluded: list[tuple[str, float, float]] = []
    #: (object, angle index) picks motion planning rejected, until the next executed action
    vetoes: set[tuple[str, int]] = set()
    in_a_row = 0  #: rejections since the last executed action
    #: (true configuration, actions executed so far) after each round that executed actions
    history = [(_configuration(world), 0)]
    #: the executed actions as planned (perceived names, the exact cell centres: a key made from
    #: a rounded record can round the other way; 0.25375 m is a tie at 4 decimals)
    done: list[Action] = []
    reuse_plans = closed_loop and getattr(config, "reuse_plans", False)
    pending: Plan | None = None  #: the unexecuted sub-searches of the last plan (reuse_plans)
    models = []  #: the feasibility model of every round (one per observation)
    while not world.done:
        if world.num_actions >= max_actions:
            reason = f"action limit {max_actions} reached"
            break
        truth = world.scenario()
        state = state_from_perception(observe(truth))
        feasibility = make_feasibility(feasibility_name, truth, workspace)
        models.append(feasibility)
        if vetoes:
            feasibility = PickVeto(feasibility, vetoes)
        if not state.target:
            action = random_action(feasibility, state, workspace, rng)
            if action is None:
                reason = "target unseen and nothing can be moved"
                break
            _execute(world, state, [action], result)
            result.random_actions += 1
            continue
        if can_exclude:
            config = dc.replace(config, excluded_actions=tuple(excluded))
        plan = (_reused(pending, state, feasibility, workspace, frozenset(excluded))
                if pending else None)
        if plan is None:
            plan = planner(state, feasibility, workspace, config, rng)
        pending = None
        result.planning_time_s += plan.planning_time_s
        result.planner = result.planner or plan.planner
        if plan.theta_star is not None:
            result.theta_star_deg = math.degrees(plan.theta_star)
        if not plan.success and not (closed_loop and plan.actions):
            reason = f"planning failed: {plan.failure_reason}"
            result.rounds.append(_round_record(plan, 0, world))
            break
        if not plan.actions:
            world.retrieve()
            result.rounds.append(_round_record(plan, 0, world))
            if not world.success:
                reason = "target not retrievable although the plan claimed it"
            break
        todo = plan.actions
        if closed_loop:
            first = plan.actions[0].sub_search
            todo = [a for a in plan.actions if a.sub_search == first]
            rest = plan.actions[len(todo):]
            if reuse_plans and plan.success and rest:
                pending = dc.replace(plan, actions=rest)
        todo = todo[:max_actions - world.num_actions]
        executed, rejected = _execute(world, state, todo, result, action_check, can_exclude)
        result.rounds.append(_round_record(plan, executed, world))
        if executed and can_exclude:
            done.extend(todo[:executed])
            excluded.extend(_cycle(history, world, done))
        if executed < len(todo):
            pending = None
        if executed:
            vetoes, in_a_row = set(), 0
        if rejected is not None:
            in_a_row += 1
            if result.motion_checks[-1]["failure"].startswith("pick"):
                # the object cannot be taken at that angle: rule the pick out, not the object
                k = angle_index(workspace.approach_angles, rejected.theta_pick)
                vetoes.add((rejected.object, k))
            else:
                excluded.append(action_key(rejected))
            if in_a_row > max_rejections:
                reason = f"no motion-feasible action after {max_rejections} rejections"
                break
            continue
        if not closed_loop and not world.done:
            if not world.retrieve():
                reason = "target not retrievable after the plan"
            break
    result.network_evaluations = sum(getattr(m, "evaluations", 0) for m in models)
    result.network_seconds = sum(getattr(m, "network_seconds", 0.0) for m in models)
    outcome = world.outcome(reason)
    result.success = outcome.success
    result.num_actions = outcome.num_actions - result.random_actions
    result.relocations = outcome.relocations
    result.falls = outcome.falls
    result.fallen = list(world.fallen)
    result.failure_reason = outcome.reason
    return result

