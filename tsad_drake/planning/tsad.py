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

Beyond the paper (each a `TSADConfig` field; see its comments): a complete plan is shortened by
dropping or merging actions while `plan_check.replay_plan` still accepts it (and split into
sub-searches afresh), the shortest of `complete_plans` complete plans (found within
`improve_iterations` of the first) is returned, and a sub-search that finds no terminal state makes
the search back up to the previous sub-search's next-best terminal state (`backtrack_width`).
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Callable

import numpy as np

from tsad_drake.planning.actions import (
    UntriedActions,
    choose_theta_pick,
    random_action,
    rederive,
)
from tsad_drake.planning.baseline_common import Budget, reachable_angles
from tsad_drake.planning.feasibility import angle_index, blockers_at
from tsad_drake.planning.plan_check import (
    action_key,
    rearrangement_set,
    relocation_key,
    shorten_plan,
)
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.state import completed_footprint_points, occupied_cells
from tsad_drake.planning.types import Action, FeasibilityModel, Plan, PlanningState, Workspace


@dc.dataclass
class TSADConfig:
    """Every constant of TSAD (paper values where it gives them)."""

    #: sub-MCTS iterations per sub-search (60 -> 120 on 2026-11-24: scenario 2, geometric, 30
    #: episodes, actions over successes 4.28 -> 4.13 on seeds 0-29, 4.18 -> 4.00 on held-out seeds
    #: 100-129; median planning 0.78 -> 0.91 s)
    iterations: int = 120
    max_iterations: int = 300  #: iterations a sub-search may use while it has found no terminal state
    exploration: float = 0.3  #: c, UCB exploration coefficient (dimensionless)
    step_penalty: float = 0.1  #: alpha, value lost per action (dimensionless)
    max_depth: int = 4  #: d_max, actions per sub-search (tree plus rollout)
    w_o: float = 0.5  #: weight of r_o (new obstacle penalty)
    w_e: float = 0.3  #: weight of r_e (empty cells)
    empty_gain: float = 0.1  #: r_e gained per extra empty grid cell
    empty_cap: float = 1.0  #: largest r_e
    empty_reference: str = "initial"  #: r_e counts empty cells vs "initial" s_0 or "sub_root"
    widening: float | None = 3.0  #: children <= widening * sqrt(N(s)); None: expand all first
    max_sub_searches: int = 12  #: sub-MCTS runs before giving up
    #: sub-MCTS iterations of one plan_tsad call, over every attempt: the budget that ends a
    #: search, so the same seed gives the same plan on any machine. 20,000 is about the 20 s
    #: wall-clock budget it replaced on the 2-core bench machine (700-1,400 iterations/s on
    #: scenario 2); scenario 2 seed 1, five blockers, needs about 9,000 for its first complete plan
    iteration_budget: int = 20_000
    #: s, wall-clock cap of one plan_tsad call: a safety net only (a plan cut by it depends on the
    #: machine's speed; the plan's stats say `time_capped`)
    time_budget_s: float = 60.0
    use_ro: bool = True  #: ablation: False drops r_o ("w/o r_o")
    use_re: bool = True  #: ablation: False drops r_e ("w/o r_e")
    max_removals: int = 8  #: optimal_angle: longest monotone removal sequence considered
    angle_fallbacks: int = 6  #: next-ranked angles tried when theta* yields no complete plan
    #: relocations (object, x, y) that motion planning rejected; the closed loop adds to it and
    #: plans again, and no action of the plan is one of them (not only the first: a refused
    #: relocation second in a sub-search came back after each unrelated first move)
    excluded_actions: tuple[tuple[str, float, float], ...] = ()
    #: probability that a rollout step moves a relevant object (a member of R_{theta*,s} or an
    #: object blocking a member along theta*) instead of any object; 0 is the paper's uniform
    #: random policy. Expansion also tries relevant objects' actions first when this is > 0.
    rollout_bias: float = 0.7
    #: whole sequential searches tried (fresh random streams) until one reaches R = empty; the
    #: sub-searches are myopic, so a dead end later on is escaped by searching again
    restarts: int = 2
    #: closed loop: still plan every sub-search (and execute only the first), so the executed
    #: sub-plan is part of a complete plan; False is the paper's first-sub-search-only planning
    lookahead: bool = True
    #: closed loop: after a sub-search is executed and the scene observed again, keep the rest of
    #: the last plan when it is still feasible on the new observation (`plan_check`) instead of
    #: searching afresh; False re-plans every round as the paper does
    reuse_plans: bool = True
    #: drop or merge the actions of a found plan that it does not need (`plan_check.shorten_plan`):
    #: random rollouts leave detours in the tree; False keeps the plan as the search extracted it
    shorten: bool = True
    #: complete plans collected (each from a fresh sequential search) before the shortest is
    #: returned; 1 returns the first plan found, as the paper does
    complete_plans: int = 3
    #: sub-MCTS iterations allowed after the first complete plan for finding shorter ones (about
    #: the 2 s it replaced on the bench machine)
    improve_iterations: int = 2_000
    #: terminal states of a sub-search tried, best first, before the search backs up further
    #: when a later sub-search finds no terminal state (depth-first backtracking over the
    #: sequence); 1 keeps the extracted one only, as the paper does. 3 on 2026-12-01: scenario 2
    #: seeds 0-29 (with the per-cell pick angle and regrouped shortening) 4.37 -> 3.97 actions,
    #: 30/30 either way; a myopic first sub-search no longer dooms the attempt
    backtrack_width: int = 3
    #: rollouts draw their random actions with the feasibility model's cheaper `rollout_model`
    #: when it has one (the network: its point-cloud placement model), rewards still come from
    #: the model itself, and a rollout that reaches a terminal state joins the tree only after
    #: each of its actions is re-derived and checked on the model itself (`SubSearch.recheck`).
    #: Rollouts were 86% of the network's search time; False asks the network at every step
    fast_rollouts: bool = True


class EmptyCells:
    """epsilon_s with per-object caching (an object's occupied cells depend only on its pose)."""

    def __init__(self, workspace: Workspace) -> None:
        self.workspace = workspace
        self._cache: dict[tuple, np.ndarray] = {}

    def __call__(self, state: PlanningState) -> int:
        occupied = np.zeros(len(self.workspace.cell_centres), dtype=bool)
        for obj in state.objects:
            key = (obj.name, obj.pose, obj.origin, len(obj.points))
            cells = self._cache.get(key)
            if cells is None:
                cells = occupied_cells(completed_footprint_points(obj), self.workspace.cell_centres,
                                       self.workspace.min_empty_distance)
                self._cache[key] = cells
            occupied |= cells
        return int(len(occupied) - occupied.sum())


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
        #: the model rollouts draw their actions with (see `TSADConfig.fast_rollouts`)
        self.rollout_model = (getattr(feasibility, "rollout_model", feasibility)
                              if config.fast_rollouts else feasibility)
        self.excluded = excluded  #: action keys (`relocation_key`) not allowed anywhere
        self.k = theta_index
        self.theta = float(workspace.approach_angles[theta_index])
        self.empty_cells = empty_cells
        self.target_set = self.rearrangement_set(root)
        ref = empty_cells(root) if config.empty_reference == "sub_root" else initial_empty
        self.reference_empty = ref
        self.root = self.make_node(root, None, None)
        self.iterations = 0
        self.nodes = 1

    def rearrangement_set(self, state: PlanningState) -> frozenset[str]:
        """Names in R_{theta*,s} (names, so sets compare across states)."""
        return rearrangement_set(state, self.feasibility, self.k)

    def reward(self, state: PlanningState) -> tuple[float, bool]:
        """R(s) = r_t + w_o r_o + w_e r_e and whether s is terminal."""
        cfg = self.config
        current = self.rearrangement_set(state)
        no_new = current <= self.target_set
        terminal = no_new and bool(self.target_set - current)
        reward = 1.0 if terminal else 0.0
        if cfg.use_ro and not no_new:
            reward -= cfg.w_o
        if cfg.use_re:
            gain = cfg.empty_gain * (self.empty_cells(state) - self.reference_empty)
            reward += cfg.w_e * min(gain, cfg.empty_cap)
        return reward, terminal

    def make_node(self, state: PlanningState, action: Action | None, parent: Node | None) -> Node:
        reward, terminal = self.reward(state)
        depth = 0 if parent is None else parent.depth + 1
        return Node(state, action, parent, depth, reward, terminal, reward, has_terminal=terminal)

    def relevant(self, state: PlanningState) -> list[int]:
        """Indices of R_{theta*,s} and of the objects blocking its members along theta* (the ones
        in front of them, which must go first)."""
        members = set(blockers_at(self.feasibility, state, state.target_index, self.k))
        related = set(members)
        for i in members:
            related |= blockers_at(self.feasibility, state, i, self.k)
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
            candidates = [(i, c) for i, o in enumerate(state.objects) if o.name != state.target
                          for c in range(len(cells))]
            if getattr(self.feasibility, "first_place_option", None) is None:
                probe = UntriedActions(self.feasibility, state, self.workspace, [], self.theta)
                candidates = [ic for ic in candidates if probe.check(*ic) is not None]
            if self.excluded:
                candidates = [(i, c) for i, c in candidates
                              if relocation_key(state.objects[i].name, *cells[c])
                              not in self.excluded]
            candidates = [candidates[j] for j in self.rng.permutation(len(candidates))]
            if self.config.rollout_bias > 0:
                relevant = set(self.relevant(state))
                candidates.sort(key=lambda ic: ic[0] in relevant)
            node.untried = UntriedActions(self.feasibility, state, self.workspace, candidates,
                                          self.theta)
        return node.untried

    def can_expand(self, node: Node) -> bool:
        if self.actions(node).peek() is None:
            return False
        w = self.config.widening
        return w is None or len(node.children) < max(1.0, w * math.sqrt(node.visits))

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
        for step in range(1, cfg.max_depth - node.depth + 1):
            action = None
            if self.rng.random() < cfg.rollout_bias:
                action = random_action(model, state, self.workspace, self.rng,
                                       self.theta, among=self.relevant(state))
            if action is None:
                action = random_action(model, state, self.workspace, self.rng, self.theta)
            if action is None or action_key(action) in self.excluded:
                break
            state = simulate_pick_place(state, action)
            path_actions.append((action, state))
            reward, terminal = self.reward(state)
            best = max(best, reward - cfg.step_penalty * step)
            if terminal:
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
        while not budget.exhausted():
            if self.iterations >= cfg.max_iterations:
                break
            if self.iterations >= cfg.iterations and self.root.has_terminal:
                break
            self.iterate()
            budget.tick()
            if not self.root.children and self.actions(self.root).peek() is None:
                break  # nothing can be moved at all

    def extract(self) -> list[Action] | None:
        """Actions along the highest-value children that lead to a terminal state, or None."""
        if not self.root.has_terminal:
            return None
        node, actions = self.root, []
        while not node.terminal:
            node = max((ch for ch in node.children if ch.has_terminal), key=lambda ch: ch.value)
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


def plan_tsad(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
              config: TSADConfig, rng: np.random.Generator) -> Plan:
    """TSAD's plan for taking `state.target` out (a failure result, never an exception or a hang)."""
    budget = Budget(config.iteration_budget, config.time_budget_s)
    name = "tsad" if config.use_ro and config.use_re else (
        "tsad-no-ro" if config.use_re else "tsad-no-re" if config.use_ro else "tsad-no-ro-no-re")

    def result(theta: float | None, actions: list[Action], success: bool, reason: str = "",
               **stats) -> Plan:
        return Plan(name, theta, actions, success, reason, budget.elapsed, stats)

    if not state.target or state.target not in [o.name for o in state.objects]:
        return result(None, [], False, "target not observed")
    t = state.target_index
    pick_now = choose_theta_pick(feasibility, state, t, workspace, 0.0)
    if pick_now is not None:
        return result(pick_now, [], True, rearrangement_set_sizes=[0])
    first = optimal_angle(state, feasibility, workspace, config.max_removals)
    if first is None:
        return result(None, [], False, "target cannot be grasped at any approach angle")
    ranked = ranked_angles(state, feasibility, workspace, config.max_removals)
    candidates = [first] + [theta for theta in ranked if theta != first][:config.angle_fallbacks]
    best = None  #: the failed attempt that got furthest
    found: list[Plan] = []  #: complete plans, shortened
    for _ in range(max(config.restarts, 1) + config.complete_plans - 1):
        for theta_star in candidates:
            plan = _sequential_sub_search(state, feasibility, workspace, config, rng, theta_star,
                                          budget, result)
            if plan.success:
                if config.shorten:
                    searched = len(plan.actions)
                    plan.actions = shorten_plan(state, plan.actions, theta_star, feasibility,
                                                workspace, frozenset(config.excluded_actions))
                    plan.stats["actions_before_shortening"] = searched
                found.append(plan)
                if len(found) == 1:
                    budget.max_iterations = min(budget.max_iterations,
                                                budget.iterations + config.improve_iterations)
                break
            if best is None or len(plan.actions) > len(best.actions):
                best = plan
            if budget.exhausted():
                break
        if len(found) >= config.complete_plans or budget.exhausted():
            break
    chosen = min(found, key=lambda p: len(p.actions)) if found else best  # the first of the shortest
    if found:
        chosen.stats["complete_plans"] = [len(p.actions) for p in found]
    chosen.stats["iterations_total"] = budget.iterations
    chosen.stats["time_capped"] = budget.elapsed >= budget.time_limit_s
    chosen.planning_time_s = budget.elapsed  # every attempt, not just the chosen one
    return chosen


def _sequential_sub_search(state: PlanningState, feasibility: FeasibilityModel,
                           workspace: Workspace, config: TSADConfig, rng: np.random.Generator,
                           theta_star: float, budget: Budget,
                           result: Callable[..., Plan]) -> Plan:
    """Stage 2 of TSAD for one retrieval angle: sub-MCTS after sub-MCTS until R is empty.

    When a sub-search finds no terminal state, the search backs up to the previous sub-search
    and continues from its next-best terminal state (`TSADConfig.backtrack_width`), depth first;
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
        search = SubSearch(current, k, feasibility, workspace, config, rng, empty_cells,
                           initial_empty, frozenset(config.excluded_actions))
        search.run(budget)
        iterations.append(search.iterations)
        nodes.append(search.nodes)
        branches = search.alternatives(max(config.backtrack_width, 1))
        if not branches:
            why = "search budget spent" if budget.exhausted() else "no terminal state found"
            fail(actions, sizes, f"sub-search {sub}: {why}")
            return None
        for sub_actions, reached in branches:
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
