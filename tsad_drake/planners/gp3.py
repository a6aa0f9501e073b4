"""GP3 (the paper's ref [10]): grasp-order MCTS that removes objects without choosing placements.

Stage 1 (`gp3_optimal_angle`) searches over removal orders: an action removes an object the
feasibility model says can be picked; a node is terminal when the target can be picked at some
angle. The shortest order found (reward discount^removals) gives theta* and the order; TSAD uses
this theta*. Stage 2 (`plan_gp3`) turns the order into pick-and-places as the TSAD paper describes:
each removed object goes to the grid cell that leaves the most empty cells after placement. It fails
when an object has nowhere to go (no free space) or the placements block a later pick or the target.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from tsad_drake.planning.actions import choose_theta_pick
from tsad_drake.planning.baseline_common import (
    Budget,
    CellScorer,
    park,
    preferred_angle,
    reachable_angles,
    target_clear,
    timed_out_plan,
)
from tsad_drake.planning.interface import FeasibilityModel, angle_index
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.types import Action, Plan, PlanningState, Workspace


@dc.dataclass
class GP3Config:
    """Grasp-order MCTS and placement settings."""

    iterations: int = 400  #: MCTS iterations (selection, expansion, rollout, backpropagation)
    #: s, wall-clock safety stop of the order search: `iterations` ends it; a search the clock
    #: stops is a failure (`timed_out`)
    safety_stop_s: float = 60.0
    exploration: float = 1.0  #: c, UCB exploration coefficient
    discount: float = 0.8  #: reward = discount^removals at a terminal node, 0 at a dead end
    max_depth: int = 9  #: removals per simulated episode
    #: skip cells where the placed object would block the target at theta*; False is the rule as
    #: the TSAD paper states it (the cell leaving the most empty cells, nothing else), which is
    #: how GP3 fails when free space is scarce
    avoid_target_corridor: bool = False


@dc.dataclass
class _Node:
    order: tuple[str, ...]  #: names removed so far, in order
    state: PlanningState  #: the shelf with those objects removed
    actions: list[int]  #: indices of objects that can be removed next
    terminal: bool  #: the target can be picked
    children: dict[int, _Node] = dc.field(default_factory=dict)
    visits: int = 0
    value_sum: float = 0.0


class _OrderSearch:
    """MCTS over removal orders; keeps the shortest order that frees the target."""

    def __init__(self, state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
                 config: GP3Config, rng: np.random.Generator) -> None:
        self.feasibility, self.workspace, self.config, self.rng = feasibility, workspace, config, rng
        self._cache: dict[frozenset, tuple[PlanningState, list[int], bool]] = {}
        self.best: tuple[str, ...] | None = None
        self.best_state: PlanningState | None = None
        self.root = self._node((), state)

    def _expand_info(self, order: tuple[str, ...], state: PlanningState
                     ) -> tuple[list[int], bool]:
        key = frozenset(order)
        if key not in self._cache:
            terminal = bool(target_clear(self.feasibility, state).any())
            actions = [] if terminal else self._removable(state, order)
            self._cache[key] = (state, actions, terminal)
        _, actions, terminal = self._cache[key]
        return actions, terminal

    def _removable(self, state: PlanningState, order: tuple[str, ...]) -> list[int]:
        t = state.target_index
        return [i for i, o in enumerate(state.objects)
                if i != t and o.name not in order and self.feasibility.pickable(state, i).any()]

    def _node(self, order: tuple[str, ...], state: PlanningState) -> _Node:
        actions, terminal = self._expand_info(order, state)
        node = _Node(order, state, actions, terminal)
        if terminal:
            self._record(order, state)
        return node

    def _record(self, order: tuple[str, ...], state: PlanningState) -> None:
        if self.best is None or len(order) < len(self.best):
            self.best, self.best_state = order, state

    def _relevant(self, state: PlanningState, actions: list[int]) -> list[int]:
        """Removable objects that block the target at some reachable angle (rollout preference)."""
        t = state.target_index
        reach = reachable_angles(self.feasibility, state, t, self.workspace)
        blocking = set()
        for k, b in enumerate(self.feasibility.blockers(state, t)):
            if reach[k]:
                blocking |= b
        return [i for i in actions if i in blocking] or actions

    def _reward(self, removals: int) -> float:
        return self.config.discount ** removals

    def iterate(self) -> None:
        node, path = self.root, [self.root]
        while not node.terminal and node.actions and len(node.children) == len(node.actions):
            node = max(node.children.values(), key=lambda ch, n=node: self._ucb(n, ch))
            path.append(node)
        if not node.terminal and node.actions and len(node.order) < self.config.max_depth:
            untried = [i for i in node.actions if i not in node.children]
            i = int(self.rng.choice(untried))
            child = self._node(node.order + (node.state.objects[i].name,), park(node.state, i))
            node.children[i] = child
            node = child
            path.append(node)
        reward = self._rollout(node)
        for n in path:
            n.visits += 1
            n.value_sum += reward

    def _ucb(self, parent: _Node, child: _Node) -> float:
        if child.visits == 0:
            return math.inf
        mean = child.value_sum / child.visits
        return mean + self.config.exploration * math.sqrt(2 * math.log(parent.visits) / child.visits)

    def _rollout(self, node: _Node) -> float:
        order, state = node.order, node.state
        actions, terminal = node.actions, node.terminal
        while not terminal and actions and len(order) < self.config.max_depth:
            i = int(self.rng.choice(self._relevant(state, actions)))
            order, state = order + (state.objects[i].name,), park(state, i)
            actions, terminal = self._expand_info(order, state)
            if terminal:
                self._record(order, state)
        return self._reward(len(order)) if terminal else 0.0


def _valid_order(state: PlanningState, order: tuple[str, ...],
                 feasibility: FeasibilityModel) -> PlanningState | None:
    """The state after removing `order` one by one, None if some object cannot be picked in turn."""
    for name in order:
        i = state.index(name)
        if not feasibility.pickable(state, i).any():
            return None
        state = park(state, i)
    return state if target_clear(feasibility, state).any() else None


def _shorten(state: PlanningState, order: tuple[str, ...],
             feasibility: FeasibilityModel) -> tuple[str, ...]:
    """Drop removals the order does not need (greedy, first to last)."""
    k = 0
    while k < len(order):
        shorter = order[:k] + order[k + 1:]
        if _valid_order(state, shorter, feasibility) is not None:
            order = shorter
        else:
            k += 1
    return order


def gp3_optimal_angle(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
                      config: GP3Config | None = None, rng: np.random.Generator | None = None,
                      stats: dict | None = None) -> tuple[float | None, tuple[str, ...]]:
    """GP3's theta* and grasp order: the fewest removals after which the target can be picked.

    Args:
        stats: filled with search statistics when given.

    Returns:
        (theta_star, order): theta_star in rad (None when no order was found within the budget)
        and the names to remove, in order.
    """
    config = config or GP3Config()
    rng = rng if rng is not None else np.random.default_rng(0)
    search = _OrderSearch(state, feasibility, workspace, config, rng)
    budget = Budget(config.iterations, config.safety_stop_s)
    while not search.root.terminal and not budget.exhausted():
        search.iterate()
        budget.tick()
        if search.best is not None and len(search.best) <= 1:
            break  # one removal (or none) cannot be beaten
    stats = stats if stats is not None else {}
    stats.update(gp3_iterations=budget.iterations, gp3_time_s=budget.elapsed)
    if budget.timed_out:
        stats["gp3_timed_out"] = True
        return None, ()
    if search.best is None:
        return None, ()
    order = _shorten(state, search.best, feasibility)
    final = _valid_order(state, order, feasibility)
    theta = preferred_angle(workspace, target_clear(feasibility, final))
    stats["gp3_order"] = list(order)
    return theta, order


def _place_order(state: PlanningState, order: tuple[str, ...], theta_star: float,
                 feasibility: FeasibilityModel, workspace: Workspace, config: GP3Config
                 ) -> tuple[PlanningState, list[Action], str]:
    """Move each object of `order` to the cell leaving the most empty cells; reason on failure."""
    actions: list[Action] = []
    empty = CellScorer(workspace)
    k_star = angle_index(workspace.approach_angles, theta_star)
    for name in order:
        i = state.index(name)
        theta_pick = choose_theta_pick(feasibility, state, i, workspace)
        if theta_pick is None:
            return state, actions, f"{name} cannot be picked after the earlier placements"
        options = feasibility.place_options(state, i, theta_pick)
        counts = empty.after_moves(state, i, theta_pick, options)
        best: tuple[int, int] | None = None
        for c, count in sorted(counts.items()):
            x, y = workspace.cell_centres[c]
            after = simulate_pick_place(state, Action(name, theta_pick, x, y, float(options[c])))
            if config.avoid_target_corridor and i in feasibility.blockers(
                    after, after.target_index)[k_star]:
                continue
            if best is None or count > best[1]:
                best = (c, count)
        if best is None:
            return state, actions, f"no free space to place {name}"
        c = best[0]
        x, y = workspace.cell_centres[c]
        action = Action(name, theta_pick, float(x), float(y), float(options[c]), sub_search=1)
        actions.append(action)
        state = simulate_pick_place(state, action)
    return state, actions, ""


def plan_gp3(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
             config: GP3Config | None = None, rng: np.random.Generator | None = None) -> Plan:
    """GP3's plan: the grasp order from MCTS, each object placed where most empty cells remain."""
    config = config or GP3Config()
    budget = Budget(1, config.safety_stop_s)
    stats: dict = {}
    theta_star, order = gp3_optimal_angle(state, feasibility, workspace, config, rng, stats)
    if stats.get("gp3_timed_out"):
        budget.timed_out = True
        return timed_out_plan("gp3", budget, stats)
    if theta_star is None:
        return Plan("gp3", None, [], False, "no grasp order frees the target within the budget",
                    budget.elapsed, stats)
    final, actions, reason = _place_order(state, order, theta_star, feasibility, workspace, config)
    stats["placed"] = len(actions)
    if reason:
        return Plan("gp3", None, actions, False, reason, budget.elapsed, stats)
    clear = target_clear(feasibility, final)
    k_star = angle_index(workspace.approach_angles, theta_star)
    theta = theta_star if clear[k_star] else preferred_angle(workspace, clear, theta_star)
    if theta is None:
        return Plan("gp3", None, actions, False, "the placements block the target",
                    budget.elapsed, stats)
    return Plan("gp3", theta, actions, True, "", budget.elapsed, stats)
