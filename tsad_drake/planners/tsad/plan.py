"""TSAD: Tree Search with Approaching Direction (the paper's section IV).

Stage 1 picks the retrieval angle theta* (`optimal_angle`, GP3's idea) and its smallest
rearrangement set R = R_{theta*,s}. Stage 2 runs sequential sub-MCTS: each searches pick-and-place
actions {n, x, y} from its root until a state s' with (1) some object of R no longer in R_{theta*,s'}
and (2) no object outside R in it; s' is the next root, until R is empty.

Each sub-MCTS: selection by Q = V(s') + c sqrt(2 ln N(s) / N(s')), expansion of an untried action,
a random-policy rollout to d_max with feasibility checks, backpropagation of
V(s) = max[R(s), max_child V(s') - alpha] with R(s) = r_t + w_o r_o + w_e r_e, and extraction of
the plan along the highest-value children. theta_pick and theta_place come from the feasibility
model (`actions.py`); next states from the point-cloud simulation.

Beyond the paper (each a field of `TSADConfig.extras`; see its comments; `TSADExtras.paper()`
switches every one off): a complete plan is shortened by dropping or merging actions while
`plan_check.replay_plan` still accepts it (and split into sub-searches afresh), a
sub-search that finds no terminal state makes the search back up to the previous sub-search's
next-best terminal state (`backtrack_width`), failed attempts are repeated (`restarts`) and at
other angles (`angle_fallbacks`), and theta* may come from a greedy ranking (`angle_search`). The
plan's stats count each extra's uses under `extras_used` (every field of `EXTRAS`, 0 when unused).
"""

from __future__ import annotations

import dataclasses as dc
from collections import Counter
from collections.abc import Callable

import numpy as np

from tsad_drake.planners.gp3 import gp3_optimal_angle
from tsad_drake.planners.tsad.config import EXTRAS, TSADConfig, with_extras
from tsad_drake.planners.tsad.sub_search import EmptyCells, SubSearch
from tsad_drake.planning.actions import (
    choose_theta_pick,
)
from tsad_drake.planning.baseline_common import Budget, reachable_angles, timed_out_plan
from tsad_drake.planning.interface import FeasibilityModel, angle_index
from tsad_drake.planning.plan_check import (
    certified_prefix,
    regroup,
    replay_plan,
    shorten_plan,
)
from tsad_drake.planning.solvability import unsolvable_reason
from tsad_drake.planning.types import Action, Plan, PlanningState, Workspace


def _without(state: PlanningState, names: set[str]) -> PlanningState:
    return PlanningState(tuple(o for o in state.objects if o.name not in names), state.target)


def removal_cost(state: PlanningState, feasibility: FeasibilityModel, k: int,
                 max_removals: int) -> int | None:
    """Objects a monotone (remove-only, GP3-style) sequence takes out to clear the target at angle k.

    Greedy: a pickable member of R first, else a pickable object that blocks a member of R.
    None when no such sequence of at most `max_removals` exists.
    """
    removed: set[str] = set()
    current = state
    while len(removed) <= max_removals:
        t = current.target_index
        blocking = sorted(feasibility.blockers(current, t)[k])
        if not blocking:
            return len(removed)
        movable = [i for i in blocking if feasibility.pickable(current, i).any()]
        if not movable:
            in_the_way = set()
            for i in blocking:
                for row in feasibility.blockers(current, i):
                    in_the_way |= row
            movable = [j for j in sorted(in_the_way - {t})
                       if feasibility.pickable(current, j).any()]
        if not movable:
            return None
        removed.add(current.objects[movable[0]].name)
        current = _without(state, removed)
    return None


def ranked_angles(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
                  max_removals: int = 8) -> list[float]:
    """Reachable retrieval angles, best first by (removable?, monotone removal cost, |R|, |theta|)."""
    t = state.target_index
    reach = reachable_angles(feasibility, state, t, workspace)
    blockers = feasibility.blockers(state, t)
    keyed = []
    for k, theta in enumerate(workspace.approach_angles):
        if reach[k]:
            cost = removal_cost(state, feasibility, k, max_removals)
            keyed.append(((cost is None, cost or 0, len(blockers[k]), abs(theta)), float(theta)))
    return [theta for _, theta in sorted(keyed)]


def optimal_angle(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
                  max_removals: int = 8) -> float | None:
    """theta*: the reachable angle whose smallest rearrangement set is smallest and removable.

    GP3's idea with a greedy monotone removal in place of its tree search; angles whose set cannot
    be removed come last. None when the target cannot be grasped at any angle (too wide, a wall).
    Replaceable by the GP3 search (same signature).
    """
    ranked = ranked_angles(state, feasibility, workspace, max_removals)
    return ranked[0] if ranked else None


def choose_theta_star(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
               config: TSADConfig, rng: np.random.Generator, stats: dict) -> float | None:
    """TSAD's stage 1 by `config.extras.angle_search`: GP3's order search or the greedy ranking."""
    if config.extras.angle_search == "gp3":
        return gp3_optimal_angle(state, feasibility, workspace, rng=rng, stats=stats)[0]
    if config.extras.angle_search != "greedy":
        raise ValueError(f"angle_search must be 'greedy' or 'gp3', not {config.extras.angle_search!r}")
    return optimal_angle(state, feasibility, workspace, config.max_removals)


def plan_tsad(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
              config: TSADConfig, rng: np.random.Generator) -> Plan:
    """TSAD's plan for taking `state.target` out (a failure result, never an exception or a hang)."""
    budget = Budget(config.iteration_budget, config.safety_stop_s)
    extras: Counter[str] = Counter({name: 0 for name in EXTRAS})
    angle_stats: dict = {}
    name = "tsad" if config.use_ro and config.use_re else (
        "tsad-no-ro" if config.use_re else "tsad-no-re" if config.use_ro else "tsad-no-ro-no-re")

    def result(theta: float | None, actions: list[Action], success: bool, reason: str = "",
               **stats) -> Plan:
        return Plan(name, theta, actions, success, reason, budget.elapsed,
                    {**stats, **angle_stats, "extras_used": extras})

    if not state.target or state.target not in [o.name for o in state.objects]:
        return result(None, [], False, "target not observed")
    t = state.target_index
    pick_now = choose_theta_pick(feasibility, state, t, workspace, 0.0)
    if pick_now is not None:
        return result(pick_now, [], True, rearrangement_set_sizes=[0])
    if config.extras.fail_fast:
        why = unsolvable_reason(state, feasibility)
        if why:
            extras["fail_fast"] += 1
            return result(None, [], False, why, unsolvable=True)
    draft_iterations = 0
    if config.extras.draft_search and feasibility.rollout_model() is not feasibility:
        drafted = _draft(state, feasibility, workspace, config, rng, result, extras, angle_stats)
        if drafted is not None:
            return drafted
        draft_iterations = angle_stats["draft"]["iterations"]
    first = choose_theta_star(state, feasibility, workspace, config, rng, angle_stats)
    if angle_stats.get("gp3_timed_out"):
        budget.timed_out = True
        return timed_out_plan(name, budget, {**angle_stats, "extras_used": extras})
    if first is None:
        return result(None, [], False, "target cannot be grasped at any approach angle"
                      if config.extras.angle_search == "greedy" else "GP3 found no retrieval angle")
    candidates = [first]
    if config.extras.angle_fallbacks > 0:
        ranked = ranked_angles(state, feasibility, workspace, config.max_removals)
        candidates += [theta for theta in ranked if theta != first][:config.extras.angle_fallbacks]
    best = None  #: the failed attempt that got furthest
    found: Plan | None = None  #: the first complete plan, shortened
    #: per attempt: the pass over the angles, the angle's rank, the iterations it used
    attempts: list[dict] = []
    cap = config.extras.attempt_iterations
    for attempt in range(max(config.extras.restarts, 1)):
        for j, angle in enumerate(candidates):
            extras["restarts"] += attempt > 0
            extras["angle_fallbacks"] += j > 0
            part = budget if cap is None else budget.part(cap * 2 ** attempt)
            plan = _sequential_sub_search(state, feasibility, workspace, config, rng, angle,
                                          part, result, extras)
            attempts.append({"attempt": attempt, "angle_rank": j, "iterations": part.iterations})
            extras["attempt_iterations"] += (not plan.success and part.exhausted()
                                             and not budget.exhausted())
            if plan.success:
                if config.extras.shorten:
                    searched = len(plan.actions)
                    plan.actions = shorten_plan(state, plan.actions, angle, feasibility,
                                                workspace, frozenset(config.excluded_actions))
                    plan.stats["actions_before_shortening"] = searched
                    extras["shorten"] += searched - len(plan.actions)
                #: where the plan came from: the attempt (0, or a restart) and the rank of its
                #: angle among the candidates (0: theta*, then the angle fallbacks)
                plan.stats["found_at"] = {"attempt": attempt, "angle_rank": j}
                found = plan
                break
            if best is None or len(plan.actions) > len(best.actions):
                best = plan
            if budget.exhausted():
                break
        if found is not None or budget.exhausted():
            break
    if budget.timed_out:
        return timed_out_plan(name, budget, {**angle_stats, "iterations_total": budget.iterations,
                                             "extras_used": dict(extras)})
    chosen = found or best
    chosen.stats["iterations_total"] = budget.iterations + draft_iterations
    chosen.stats["attempts"] = attempts
    chosen.stats["extras_used"] = dict(extras)
    chosen.planning_time_s = budget.elapsed  # every attempt, not just the chosen one
    return chosen


def _draft(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
           config: TSADConfig, rng: np.random.Generator, result: Callable[..., Plan],
           extras: Counter[str], angle_stats: dict) -> Plan | None:
    """`TSADExtras.draft_search`: the round searched on `feasibility.rollout_model()` and its
    plan certified on `feasibility` (each action re-derived, the target pickable at the end).
    The certified plan; a failure when the draft's search found none (its certified first
    actions, the draft's reason); None when `feasibility` rejects the draft's plan or the draft
    ends as unsolvable where `feasibility` did not (search on it instead).
    `angle_stats["draft"]` records the draft (its iterations count in the round's)."""
    cheap = feasibility.rollout_model()
    draft = plan_tsad(state, cheap, workspace, with_extras(config, draft_search=False), rng)
    iterations = draft.stats.get("iterations_total", 0)
    extras.update(draft.stats.get("extras_used", {}))
    extras["draft_search"] += 1
    record = angle_stats["draft"] = {"model": cheap.name, "success": draft.success,
                                     "iterations": iterations, "actions": len(draft.actions),
                                     "certified": False}
    inherited = {key: value for key, value in draft.stats.items() if key != "extras_used"}
    if draft.timed_out:
        return dc.replace(draft, stats={**inherited, **angle_stats, "extras_used": extras})
    if not draft.success:
        if draft.stats.get("unsolvable"):  # the model itself found the state solvable (its
            return None                    # fail_fast ran first): only a search on it can tell
        checked = certified_prefix(state, draft.actions, feasibility, workspace)
        record["certified_actions"] = len(checked)
        return result(draft.theta_star, checked, False,
                      f"{draft.failure_reason} (draft on the {cheap.name} model)", **inherited)
    redone = replay_plan(state, draft.actions, draft.theta_star, feasibility, workspace,
                         groups=False)
    labelled = None if redone is None else regroup(state, redone, draft.theta_star,
                                                   feasibility, workspace)
    if labelled is None:
        return None
    record["certified"] = True
    return result(draft.theta_star, labelled, True, **inherited)


def _sequential_sub_search(state: PlanningState, feasibility: FeasibilityModel,
                           workspace: Workspace, config: TSADConfig, rng: np.random.Generator,
                           theta_star: float, budget: Budget,
                           result: Callable[..., Plan], extras: Counter[str]) -> Plan:
    """Stage 2 of TSAD for one retrieval angle: sub-MCTS after sub-MCTS until R is empty.

    When a sub-search finds no terminal state, the search backs up to the previous sub-search
    and continues from its next-best terminal state (`TSADExtras.backtrack_width`), depth first;
    the furthest failed attempt is returned when every branch fails.
    """
    t = state.target_index
    k = angle_index(workspace.approach_angles, theta_star)
    empty_cells = EmptyCells(workspace)
    initial_empty = empty_cells(state)
    iterations: list[int] = []
    nodes: list[int] = []
    furthest: list[Plan] = []  #: the failed attempt with the most actions

    def stats(sizes: list[int]) -> dict:
        return dict(rearrangement_set_sizes=sizes, iterations=iterations, nodes=nodes)

    def fail(actions: list[Action], sizes: list[int], reason: str) -> None:
        if not furthest or len(actions) > len(furthest[0].actions):
            furthest[:] = [result(theta_star, actions, False, reason, **stats(list(sizes)))]

    def descend(current: PlanningState, sub: int, actions: list[Action],
                sizes: list[int]) -> Plan | None:
        if not feasibility.blockers(current, current.target_index)[k]:
            if not feasibility.pickable(current, current.target_index)[k]:
                fail(actions, sizes, "target still not pickable at theta*")
                return None
            return result(theta_star, actions, True, **stats(sizes))
        if sub >= config.max_sub_searches:
            fail(actions, sizes, "sub-search limit reached")
            return None
        if config.extras.fail_fast and sub > 0:  # a dead end the sub-searches so far walked into
            why = unsolvable_reason(current, feasibility)
            if why:
                extras["fail_fast"] += 1
                fail(actions, sizes, f"sub-search {sub}: {why}")
                return None
        search = SubSearch(current, k, feasibility, workspace, config, rng, empty_cells,
                           initial_empty, frozenset(config.excluded_actions))
        search.run(budget)
        extras.update(search.extras)
        iterations.append(search.iterations)
        nodes.append(search.nodes)
        branches = search.alternatives(max(config.extras.backtrack_width, 1))
        if not branches:
            why = "search budget spent" if budget.exhausted() else "no terminal state found"
            fail(actions, sizes, f"sub-search {sub}: {why}")
            return None
        for j, (sub_actions, reached) in enumerate(branches):
            extras["backtrack_width"] += j > 0
            plan = descend(reached, sub + 1,
                           actions + [dc.replace(a, sub_search=sub) for a in sub_actions],
                           sizes + [len(feasibility.blockers(reached, reached.target_index)[k])])
            if plan is not None:
                return plan
            if budget.exhausted():
                break
        return None

    plan = descend(state, 0, [], [len(feasibility.blockers(state, t)[k])])
    return plan if plan is not None else furthest[0]
