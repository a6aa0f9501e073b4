"""TSAD's subgoal-conditioned MCTS: one sub-search from a root toward shrinking R_{theta*,s}.

Selection by Q = V(s') + c sqrt(2 ln N(s) / N(s')), expansion of an untried action, a
random-policy rollout to d_max with feasibility checks, backpropagation of
V(s) = max[R(s), max_child V(s') - alpha] with R(s) = r_t + w_o r_o + w_e r_e, and extraction of
the plan along the highest-value children (the paper's section IV-C).
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections import Counter

import numpy as np

from tsad_drake.planners.tsad.config import TSADConfig
from tsad_drake.planning.actions import (
    UntriedActions,
    move_table,
    random_action,
    rederive,
)
from tsad_drake.planning.baseline_common import Budget
from tsad_drake.planning.interface import FeasibilityModel
from tsad_drake.planning.plan_check import (
    action_key,
    rearrangement_set,
    relocation_key,
)
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.state import moved_completed_points, occupied_cells
from tsad_drake.planning.types import Action, PlanningState, Workspace


class EmptyCells:
    """epsilon_s with per-object caching (an object's occupied cells depend only on its pose)."""

    def __init__(self, workspace: Workspace) -> None:
        self.workspace = workspace
        self._cache: dict[tuple, np.ndarray] = {}
        self._counts: dict[tuple, int] = {}  #: state key -> epsilon_s

    def __call__(self, state: PlanningState) -> int:
        count = self._counts.get(state.key())
        if count is None:
            count = self._counts[state.key()] = self._count(state)
        return count

    def _count(self, state: PlanningState) -> int:
        occupied = np.zeros(len(self.workspace.cell_centres), dtype=bool)
        for obj in state.objects:
            key = (obj.name, obj.pose, obj.origin, len(obj.points))
            cells = self._cache.get(key)
            if cells is None:
                cells = occupied_cells(moved_completed_points(obj), self.workspace.cell_centres,
                                       self.workspace.min_empty_distance)
                self._cache[key] = cells
            occupied |= cells
        return int(len(occupied) - occupied.sum())


@dc.dataclass(eq=False)
class Node:
    """A search-tree node: a state reached from its parent by `action`."""

    state: PlanningState
    action: Action | None
    parent: Node | None
    depth: int
    reward: float  #: R(s)
    terminal: bool  #: r_t(s) = 1
    value: float  #: V(s)
    visits: int = 0
    children: list[Node] = dc.field(default_factory=list)
    untried: UntriedActions | None = None  #: shuffled candidate actions, checked when drawn
    has_terminal: bool = False  #: a terminal state lies in this subtree
    rollout_value: float = -math.inf  #: best value a rollout from here reached


class SubSearch:
    """One subgoal-conditioned MCTS from `root` toward removing a member of R_{theta*,root}."""

    def __init__(self, root: PlanningState, theta_index: int, feasibility: FeasibilityModel,
                 workspace: Workspace, config: TSADConfig, rng: np.random.Generator,
                 empty_cells: EmptyCells, initial_empty: int,
                 excluded: frozenset[tuple[str, float, float]] = frozenset()) -> None:
        self.feasibility, self.workspace, self.config, self.rng = feasibility, workspace, config, rng
        #: how often each option beyond the paper changed what this search did, by
        #: `TSADConfig` field name (`planners.tsad.config.EXTRAS`); the paper variant leaves it empty
        self.extras: Counter[str] = Counter()
        #: the model rollouts draw their actions with (see `TSADExtras.fast_rollouts`)
        self.rollout_model = (feasibility.rollout_model() if config.extras.fast_rollouts
                              else feasibility)
        self.excluded = excluded  #: action keys (`relocation_key`) not allowed anywhere
        self.k = theta_index
        self.theta = float(workspace.approach_angles[theta_index])
        self.empty_cells = empty_cells
        self.target_set = self.rearrangement_set(root)
        #: R at the root as the rollout model reads it: rollouts judge their states on that
        #: model alone (a rollout only estimates a value; a terminal path is re-checked)
        self.rollout_target_set = (self.target_set if self.rollout_model is feasibility else
                                   rearrangement_set(root, self.rollout_model, self.k))
        ref = empty_cells(root) if config.empty_reference == "sub_root" else initial_empty
        self.reference_empty = ref
        self.root = self.make_node(root, None, None)
        self.iterations = 0
        self.nodes = 1

    def rearrangement_set(self, state: PlanningState) -> frozenset[str]:
        """Names in R_{theta*,s} (names, so sets compare across states)."""
        return rearrangement_set(state, self.feasibility, self.k)

    def reward(self, state: PlanningState, rollout: bool = False) -> tuple[float, bool]:
        """R(s) = r_t + w_o r_o + w_e r_e and whether s is terminal (`rollout`: R as the rollout
        model reads it)."""
        cfg = self.config
        if rollout and self.rollout_model is not self.feasibility:
            current = rearrangement_set(state, self.rollout_model, self.k)
            target_set = self.rollout_target_set
        else:
            current, target_set = self.rearrangement_set(state), self.target_set
        no_new = current <= target_set
        terminal = no_new and bool(target_set - current)
        reward = 1.0 if terminal else 0.0
        if cfg.use_ro and not no_new:
            reward -= cfg.w_o
        if cfg.use_re:
            gain = cfg.empty_gain * (self.empty_cells(state) - self.reference_empty)
            if gain < 0:
                if not cfg.extras.negative_empty_reward:
                    gain = 0.0
                else:
                    self.extras["negative_empty_reward"] += 1
            reward += cfg.w_e * min(gain, cfg.empty_cap)
        return reward, terminal

    def make_node(self, state: PlanningState, action: Action | None, parent: Node | None) -> Node:
        reward, terminal = self.reward(state)
        depth = 0 if parent is None else parent.depth + 1
        return Node(state, action, parent, depth, reward, terminal, reward, has_terminal=terminal)

    def relevant(self, state: PlanningState, model: FeasibilityModel | None = None) -> list[int]:
        """Indices of R_{theta*,s} and of the objects blocking its members along theta* (the ones
        in front of them, which must go first), as `model` (default: the search's) reads them."""
        model = model or self.feasibility
        members = set(model.blockers_at(state, state.target_index, self.k))
        related = set(members)
        for i in members:
            related |= model.blockers_at(state, i, self.k)
        related.discard(state.target_index)
        return sorted(related)

    def actions(self, node: Node) -> UntriedActions:
        """The node's untried actions: (movable object, cell) pairs in a random order, the
        relevant objects' last (they are drawn from the end), each checked when drawn.

        A model that answers every cell of an object at once (the footprint models) has its
        infeasible pairs dropped before shuffling, so the order is a permutation of the feasible
        actions as before lazy drawing; for the network every pair is shuffled and checked only
        when drawn (one query per drawn placement instead of one per feasible cell and object).
        """
        if node.untried is None:
            state, cells = node.state, self.workspace.cell_centres
            movable = [i for i, o in enumerate(state.objects) if o.name != state.target]
            if self.feasibility.answers_one_cell:
                candidates = [(i, c) for i in movable for c in range(len(cells))]
            else:  # the feasible cells of each object, from its (memoised) move table
                candidates = [(i, int(c)) for i in movable for c in np.nonzero(~np.isnan(
                    move_table(self.feasibility, state, i, self.workspace, self.theta)[1]))[0]]
            if self.excluded:
                candidates = [(i, c) for i, c in candidates
                              if relocation_key(state.objects[i].name, *cells[c])
                              not in self.excluded]
            candidates = [candidates[j] for j in self.rng.permutation(len(candidates))]
            if self.config.extras.rollout_bias > 0:
                self.extras["rollout_bias"] += 1
                relevant = set(self.relevant(state))
                candidates.sort(key=lambda ic: ic[0] in relevant)
            node.untried = UntriedActions(self.feasibility, state, self.workspace, candidates,
                                          self.theta)
        return node.untried

    def can_expand(self, node: Node) -> bool:
        if self.actions(node).peek() is None:
            return False
        w = self.config.extras.widening
        if w is None or len(node.children) < max(1.0, w * math.sqrt(node.visits)):
            return True
        self.extras["widening"] += 1
        return False

    def select_child(self, node: Node) -> Node:
        c = self.config.exploration
        log_n = math.log(max(node.visits, 1))

        def q(child: Node) -> float:
            if child.visits == 0:
                return math.inf
            return child.value + c * math.sqrt(2.0 * log_n / child.visits)

        return max(node.children, key=q)

    def rollout(self, node: Node) -> list[Node]:
        """Random feasible actions from `node` to d_max; the path if it reaches a terminal state."""
        cfg = self.config
        state, path_actions, best = node.state, [], -math.inf
        model = self.rollout_model
        if model is not self.feasibility:
            self.extras["fast_rollouts"] += 1
        for step in range(1, cfg.max_depth - node.depth + 1):
            action = None
            if cfg.extras.rollout_bias > 0 and self.rng.random() < cfg.extras.rollout_bias:
                self.extras["rollout_bias"] += 1
                action = random_action(model, state, self.workspace, self.rng,
                                       self.theta, among=self.relevant(state, model))
            if action is None:
                action = random_action(model, state, self.workspace, self.rng, self.theta)
            if action is None or action_key(action) in self.excluded:
                break
            state = simulate_pick_place(state, action)
            path_actions.append((action, state))
            reward, terminal = self.reward(state, rollout=True)
            best = max(best, reward - cfg.step_penalty * step)
            if terminal:
                if not cfg.extras.keep_rollout_paths:
                    break  # the paper: the rollout only estimates the leaf's value
                self.extras["keep_rollout_paths"] += 1
                if model is not self.feasibility:
                    path_actions = self.recheck(node.state, path_actions)
                    if path_actions is None:  # not feasible on the search's own model
                        return []
                node.rollout_value = max(node.rollout_value, best)
                return self.materialise(node, path_actions)
        node.rollout_value = max(node.rollout_value, best)
        return []

    def recheck(self, state: PlanningState, path: list[tuple[Action, PlanningState]]
                ) -> list[tuple[Action, PlanningState]] | None:
        """A rollout path drawn with `rollout_model`, re-derived on the search's own model: each
        action's theta_pick and theta_place chosen as an expansion would choose them (None when
        the object cannot be picked or placed there), and the end state terminal. None if not."""
        checked = []
        for action, _ in path:
            redone = rederive(self.feasibility, state, action, self.workspace, self.theta)
            if redone is None:
                return None
            state = simulate_pick_place(state, redone)
            checked.append((redone, state))
        return checked if self.reward(state)[1] else None

    def materialise(self, node: Node, path: list[tuple[Action, PlanningState]]) -> list[Node]:
        """Add a rollout path that reached a terminal state to the tree (so it can be extracted)."""
        added = []
        for action, state in path:
            child = self.make_node(state, action, node)
            node.children.append(child)
            if node.untried is not None:
                node.untried.discard(action.object, action.x, action.y)
            added.append(child)
            node = child
        self.nodes += len(added)
        return added

    def backpropagate(self, leaf: Node) -> None:
        alpha = self.config.step_penalty
        node: Node | None = leaf
        while node is not None:
            node.visits += 1
            value = max(node.reward, node.rollout_value)
            if node.children and not node.terminal:
                value = max(value, max(ch.value for ch in node.children) - alpha)
                node.has_terminal = node.has_terminal or any(ch.has_terminal for ch in node.children)
            node.value = node.reward if node.terminal else value
            node = node.parent

    def iterate(self) -> None:
        """One selection-expansion-simulation-backpropagation pass."""
        node = self.root
        while not node.terminal and node.depth < self.config.max_depth:
            if self.can_expand(node):
                action = node.untried.pop()
                child = self.make_node(simulate_pick_place(node.state, action), action, node)
                node.children.append(child)
                self.nodes += 1
                node = child
                if not child.terminal:
                    added = self.rollout(child)
                    if added:
                        node = added[-1]
                break
            if not node.children:
                break
            node = self.select_child(node)
        self.backpropagate(node)
        self.iterations += 1

    def run(self, budget: Budget) -> None:
        """Search until this sub-search's iterations (extended while nothing terminal is found)
        or the whole call's `budget` run out; `extract` / `alternatives` read the result."""
        cfg = self.config
        most = cfg.iterations if cfg.extras.max_iterations is None else cfg.extras.max_iterations
        while not budget.exhausted():
            if self.iterations >= most:
                break
            if self.iterations >= cfg.iterations:
                if self.root.has_terminal:
                    break
                self.extras["max_iterations"] += 1
            self.iterate()
            budget.tick()
            if not self.root.children and self.actions(self.root).peek() is None:
                break  # nothing can be moved at all

    def extract(self) -> list[Action] | None:
        """Actions along the highest-value children to a terminal state, or None.

        `terminal_extraction`: only children that lead to a terminal state are followed; else
        (the paper) the highest-value child whatever it leads to, None when that path ends
        before a terminal state.
        """
        if not self.root.has_terminal:
            return None
        node, actions = self.root, []
        while not node.terminal:
            if not node.children:
                return None
            best = max(node.children, key=lambda ch: ch.value)
            if self.config.extras.terminal_extraction:
                chosen = max((ch for ch in node.children if ch.has_terminal),
                             key=lambda ch: ch.value)
                if chosen is not best:
                    self.extras["terminal_extraction"] += 1
                best = chosen
            node = best
            actions.append(node.action)
        self.terminal_state = node.state
        return actions

    def alternatives(self, limit: int) -> list[tuple[list[Action], PlanningState]]:
        """Up to `limit` sub-plans to distinct terminal states: the extracted one first, then the
        other terminal nodes of the tree by their value R(s) - alpha * depth."""
        first = self.extract()
        if first is None:
            return []
        found = [(first, self.terminal_state)]
        seen = {self.terminal_state.key()}
        terminals, stack = [], [self.root]
        while stack:
            node = stack.pop()
            if node.terminal:
                terminals.append(node)
            else:
                stack.extend(node.children)
        terminals.sort(key=lambda n: n.reward - self.config.step_penalty * n.depth, reverse=True)
        for node in terminals:
            if len(found) >= limit:
                break
            if node.state.key() in seen:
                continue
            seen.add(node.state.key())
            path, walk = [], node
            while walk.parent is not None:
                path.append(walk.action)
                walk = walk.parent
            found.append((path[::-1], node.state))
        return found
