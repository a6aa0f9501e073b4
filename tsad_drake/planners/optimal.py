"""Reference planner `optimal`: IDA* over pick-and-places on a feasibility model (meant: oracle).

The heuristic h(s) = min over reachable angles of |R_theta,s| is admissible: one pick-and-place moves
one object, so it takes at most one object out of every R_theta. The search is pruned to relevant
objects (those in some R_theta of the target and, transitively, those blocking them) and, per moved
object, to a small set of candidate cells (those that block the fewest target angles, then leave the
most empty cells). Within that pruned action set the first plan found is the shortest; `stats` says
whether the search finished (`optimal_finished`) or ran out of its node or time budget.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from tsad_drake.planning.actions import choose_theta_pick
from tsad_drake.planning.baseline_common import (
    Budget,
    CellScorer,
    preferred_angle,
    reachable_angles,
    target_clear,
    timed_out_plan,
)
from tsad_drake.planning.interface import FeasibilityModel
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.types import Action, Plan, PlanningState, Workspace


@dc.dataclass
class OptimalConfig:
    """Exhaustive-search budget and pruning."""

    max_nodes: int = 20_000  #: expanded nodes over all IDA* iterations
    #: s, wall-clock safety stop: `max_nodes` ends the search; a search the clock stops is a
    #: failure (`timed_out`)
    safety_stop_s: float = 300.0
    max_relocations: int = 8  #: deepest bound tried (relocations, the retrieval not counted)
    cells_per_object: int = 6  #: candidate cells per moved object


class _Search:
    def __init__(self, feasibility: FeasibilityModel, workspace: Workspace,
                 config: OptimalConfig) -> None:
        self.feasibility, self.workspace, self.config = feasibility, workspace, config
        self.budget = Budget(config.max_nodes, config.safety_stop_s)
        self._children: dict[tuple, list[tuple[Action, PlanningState]]] = {}
        self._h: dict[tuple, float] = {}
        self.scorer = CellScorer(workspace)

    def blocking_sets(self, state: PlanningState, index: int) -> list[frozenset[int]]:
        """R_theta of object `index` at the angles it is reachable at."""
        reach = reachable_angles(self.feasibility, state, index, self.workspace)
        sets = self.feasibility.blockers(state, index)
        return [b for k, b in enumerate(sets) if reach[k]]

    def h(self, state: PlanningState) -> float:
        key = state.key()
        if key not in self._h:
            sets = self.blocking_sets(state, state.target_index)
            self._h[key] = float(min((len(b) for b in sets), default=math.inf))
        return self._h[key]

    def relevant(self, state: PlanningState) -> list[int]:
        """Objects in some R_theta of the target, and those blocking them (transitively)."""
        t = state.target_index
        found = set().union(*self.blocking_sets(state, t)) - {t}
        frontier = list(found)
        while frontier:
            i = frontier.pop()
            for j in set().union(*self.blocking_sets(state, i)) - found - {t}:
                found.add(j)
                frontier.append(j)
        return sorted(found)

    def children(self, state: PlanningState) -> list[tuple[Action, PlanningState]]:
        key = state.key()
        if key in self._children:
            return self._children[key]
        out = []
        ws = self.workspace
        for i in self.relevant(state):
            theta_pick = choose_theta_pick(self.feasibility, state, i, ws)
            if theta_pick is None:
                continue
            options = self.feasibility.place_options(state, i, theta_pick)
            counts = self.scorer.after_moves(state, i, theta_pick, options)
            ranked = []
            for c, count in counts.items():
                x, y = ws.cell_centres[c]
                blocks = self.scorer.corridor_blocks(state, i, x, y, float(options[c]) - theta_pick)
                ranked.append((blocks, -count, c))
            ranked.sort()
            name = state.objects[i].name
            for _, _, c in ranked[:self.config.cells_per_object]:
                x, y = ws.cell_centres[c]
                action = Action(name, theta_pick, float(x), float(y), float(options[c]))
                out.append((action, simulate_pick_place(state, action)))
        self._children[key] = out
        return out

    def dfs(self, state: PlanningState, g: int, bound: int, path: list[Action],
            seen: dict[tuple, int]) -> list[Action] | None:
        h = self.h(state)
        if g + h > bound:
            return None
        if target_clear(self.feasibility, state).any():
            return list(path)
        if g >= bound or self.budget.exhausted():
            return None
        self.budget.tick()
        for action, after in self.children(state):
            key = after.key()
            if seen.get(key, math.inf) <= g + 1:
                continue
            seen[key] = g + 1
            path.append(action)
            found = self.dfs(after, g + 1, bound, path, seen)
            path.pop()
            if found is not None:
                return found
        return None


def plan_optimal(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
                 config: OptimalConfig | None = None, rng: np.random.Generator | None = None
                 ) -> Plan:
    """The fewest relocations after which the target can be picked (IDA*, within the budget).

    `rng` is unused (the search is deterministic); it is accepted for the common planner signature.
    """
    config = config or OptimalConfig()
    search = _Search(feasibility, workspace, config)
    stats: dict = {"optimal_finished": False, "nodes": 0}
    h0 = search.h(state)
    found = None
    bound = int(h0) if math.isfinite(h0) else config.max_relocations + 1
    while found is None and bound <= config.max_relocations and not search.budget.exhausted():
        found = search.dfs(state, 0, bound, [], {state.key(): 0})
        stats["bound"] = bound
        bound += 1
    stats["nodes"] = search.budget.iterations
    elapsed = search.budget.elapsed
    if search.budget.timed_out:
        return timed_out_plan("optimal", search.budget, stats)
    if found is None:
        reason = ("search budget exhausted" if search.budget.exhausted()
                  else f"no plan within {config.max_relocations} relocations")
        return Plan("optimal", None, [], False, reason, elapsed, stats)
    final = state
    for action in found:
        final = simulate_pick_place(final, action)
    theta = preferred_angle(workspace, target_clear(feasibility, final))
    stats["optimal_finished"] = True
    stats["optimal_actions"] = len(found) + 1  # relocations plus the retrieval
    return Plan("optimal", theta, found, True, "", elapsed, stats)
