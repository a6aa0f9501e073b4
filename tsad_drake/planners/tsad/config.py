"""TSAD's settings: the paper's parameters and every option beyond the paper, each with its unit.

`TSADConfig()` is the `full` variant: every option beyond the paper is a field of its `extras`
(`TSADExtras`), all on by default; `TSADExtras.paper()` switches each off, and
`make_config("tsad", variant="paper")` (`extras=TSADExtras.paper()`) is the paper's TSAD (section
IV) exactly:
theta* from GP3's search, sequential sub-MCTS run for a fixed number of iterations with the paper's
reward (r_e floored at 0), value update, UCB, uniform random rollouts that only estimate values,
extraction along the highest-value children, one sub-search planned per observation, no plan
reuse. Parameters the paper does not state (iterations, c, alpha, d_max) keep the defaults below.
`EXTRAS` names the extras (docs/benchmark.md measures each; a config file sets them under
`planner.extras`); the extras that steer the closed loop are the run's `episode` section
(`EPISODE_VARIANTS`).
"""

from __future__ import annotations

import dataclasses as dc


@dc.dataclass
class TSADExtras:
    """TSAD's options beyond the paper, each on (`full`) by default; `paper()` switches all off."""

    #: iterations a sub-search may use while it has found no terminal state (extra: the search is
    #: extended past `iterations`; None is the paper's fixed number, `iterations`)
    max_iterations: int | None = 300
    widening: float | None = 3.0  #: children <= widening * sqrt(N(s)); None: expand all first
    angle_fallbacks: int = 6  #: next-ranked angles tried when theta* yields no complete plan
    #: probability that a rollout step moves a relevant object (a member of R_{theta*,s} or an
    #: object blocking a member along theta*) instead of any object; 0 is the paper's uniform
    #: random policy. Expansion also tries relevant objects' actions first when this is > 0.
    rollout_bias: float = 0.7
    #: whole sequential searches tried (fresh random streams) until one reaches R = empty; the
    #: sub-searches are myopic, so a dead end later on is escaped by searching again. The first
    #: complete plan is returned: collecting three and keeping the shortest (`complete_plans`,
    #: until 2026-12-07) doubled the planning time of a round for 2 to 8 shorter plans in 65 to
    #: 78 rounds (tuning seeds 0-29, scenarios 2-3, realistic sensing; docs/benchmark.md)
    restarts: int = 2
    #: iterations one attempt (one retrieval angle in one pass over the angles) may use before
    #: the next angle is tried, doubled in each restart pass; the call's `iteration_budget` bounds
    #: them all; None: only that budget. Without it, a plan found at a fallback angle came after
    #: the angles ranked above it had spent thousands of iterations failing. 500 (1,000 until
    #: 2026-12-07's second change, with `iteration_budget` 4,000): on tuning seeds 0-29 of
    #: scenarios 2-3 (realistic sensing, 8 frames, `cluster`) success 26 / 28 of 30 on the network
    #: and 25 / 29 geometric (26 / 29 and 24 / 29 before), worst episode 36 -> 28 s and
    #: 29 -> 11 s on the network; 250 (budget 1,000) gave more rounds and more actions
    #: (docs/benchmark.md)
    attempt_iterations: int | None = 500
    #: drop or merge the actions of a found plan that it does not need (`plan_check.shorten_plan`):
    #: random rollouts leave detours in the tree; False keeps the plan as the search extracted it
    shorten: bool = True
    #: terminal states of a sub-search tried, best first, before the search backs up further
    #: when a later sub-search finds no terminal state (depth-first backtracking over the
    #: sequence); 1 keeps the extracted one only, as the paper does; a myopic first sub-search
    #: no longer dooms the attempt
    backtrack_width: int = 3
    #: rollouts draw their random actions with the feasibility model's cheaper `rollout_model`
    #: when it has one (the network: its point-cloud placement model) and judge their states
    #: (R, terminal, the relevant objects) on it too; a rollout that reaches a terminal state
    #: joins the tree only after each of its actions is re-derived and checked, and its end state
    #: found terminal, on the model itself (`SubSearch.recheck`); tree nodes' rewards always come
    #: from the model itself. Rollouts were 86% of the network's search time (and its rewards
    #: most of its queries, 2026-12-03); False asks the network at every step
    fast_rollouts: bool = True
    #: how theta* is chosen: "greedy" ranks the angles by a greedy remove-only sequence
    #: (`tsad.ranked_angles`, fast); "gp3" takes it from GP3's order search (`gp3_optimal_angle`)
    #: as the paper does
    angle_search: str = "greedy"
    #: a rollout that reaches a terminal state adds its path to the tree, so the search can
    #: extract it; False: rollouts only estimate the leaf's value (the paper)
    keep_rollout_paths: bool = True
    #: extraction follows the highest-value children that lead to a terminal state; False follows
    #: the highest-value children whatever they lead to (the paper), and fails when the path ends
    #: in a state that is not terminal
    terminal_extraction: bool = True
    #: r_e may go negative (a state with fewer empty cells than the reference is penalised);
    #: False floors r_e at 0 (the paper: "at the initial value of 0, the value increases by 0.1")
    negative_empty_reward: bool = True
    #: end a call (or back up from a sub-search root) at once when no remove-only sequence can
    #: free the target (`solvability.unsolvable_reason`: e.g. two pieces of one segmented object
    #: blocking each other at every angle), with that reason, instead of searching until the
    #: budget is spent; False searches anyway, as the paper does
    fail_fast: bool = True
    #: a round is searched first on the feasibility model's cheaper `rollout_model` (the
    #: network: its point-cloud placement model), with the same budgets, and the model itself
    #: certifies the draft: each action re-derived on it (theta_pick, theta_place as an
    #: expansion chooses them), the target pickable at the end (`plan_check.replay_plan`). A
    #: certified draft is the plan; a draft the model rejects, or one unsolvable where the
    #: model's own fail-fast test was not, is searched again on the model;
    #: a draft that finds no plan ends the round, with its certified first actions (the loop
    #: executes them or looks again). The network's failing rounds were 6-8 s of 2,000
    #: iterations where the placement model fails the same rounds in 1-2 s
    #: (docs/benchmark.md); False searches on the model itself
    draft_search: bool = True

    @classmethod
    def paper(cls) -> TSADExtras:
        """Every extra off: the paper's algorithm."""
        return cls(max_iterations=None, widening=None, restarts=1, attempt_iterations=None,
                   angle_fallbacks=0,
                   rollout_bias=0.0, shorten=False, backtrack_width=1,
                   fast_rollouts=False, angle_search="gp3", keep_rollout_paths=False,
                   terminal_extraction=False, negative_empty_reward=False, fail_fast=False,
                   draft_search=False)


#: the extras, by field name of `TSADExtras`
EXTRAS: tuple[str, ...] = tuple(f.name for f in dc.fields(TSADExtras))


@dc.dataclass
class TSADConfig:
    """Every constant of TSAD (paper values where it gives them) and its extras."""

    #: sub-MCTS iterations per sub-search (docs/design.md gives the measurement behind 120)
    iterations: int = 120
    exploration: float = 0.3  #: c, UCB exploration coefficient (dimensionless)
    step_penalty: float = 0.1  #: alpha, value lost per action (dimensionless)
    max_depth: int = 4  #: d_max, actions per sub-search (tree plus rollout)
    w_o: float = 0.5  #: weight of r_o (new obstacle penalty)
    w_e: float = 0.3  #: weight of r_e (empty cells)
    empty_gain: float = 0.1  #: r_e gained per extra empty grid cell
    empty_cap: float = 1.0  #: largest r_e
    empty_reference: str = "initial"  #: r_e counts empty cells vs "initial" s_0 or "sub_root"
    max_sub_searches: int = 12  #: sub-MCTS runs before giving up
    #: sub-MCTS iterations of one plan_tsad call, over every attempt: the budget that ends a
    #: search, so the same seed gives the same plan on any machine. 2,000 (20,000 until
    #: 2026-12-07, then 8,000, then 4,000 with `attempt_iterations` 1,000): a round's time follows
    #: its iterations, and a failing round used the whole budget, while the closed loop executes
    #: the failed round's furthest first sub-search and observes again; on tuning seeds 0-29 of
    #: scenarios 2-3 the rows' iterations fell 25-47% (success: `attempt_iterations`).
    #: The paper variant (120 iterations per sub-search, at most 12 sub-searches, no fallbacks)
    #: never reaches it.
    iteration_budget: int = 2_000
    #: s, wall-clock safety stop of one plan_tsad call: the counts above end a search; a call the
    #: clock stops is a failure (`Plan.timed_out`, "timed out: ..."), never the plan it had so far
    safety_stop_s: float = 300.0
    use_ro: bool = True  #: ablation: False drops r_o ("w/o r_o")
    use_re: bool = True  #: ablation: False drops r_e ("w/o r_e")
    max_removals: int = 8  #: optimal_angle: longest monotone removal sequence considered
    #: relocations (object, x, y) that motion planning rejected; the closed loop adds to it and
    #: plans again, and no action of the plan is one of them (at any depth, not only the first)
    #: (a run-time field: a config file leaves it empty)
    excluded_actions: list[tuple[str, float, float]] = dc.field(default_factory=list)
    #: the options beyond the paper (`TSADExtras.paper()` switches every one off)
    extras: TSADExtras = dc.field(default_factory=TSADExtras)


def with_extras(config: TSADConfig, **changes: object) -> TSADConfig:
    """`config` with the named extras changed (the others, and `config`, unchanged)."""
    return dc.replace(config, extras=dc.replace(config.extras, **changes))


#: TSAD's variants: name -> config overrides (`make_config` copies them)
VARIANTS: dict[str, dict[str, object]] = {"full": {}, "paper": {"extras": TSADExtras.paper()}}

#: TSAD's extras that steer the closed loop, not the search: fields of the run's `episode` section
#: (`execution.episode.EpisodeConfig`) whose defaults, the paper's, switch them off. `full` sets
#: - lookahead: still plan every sub-search (and execute only the first), so the executed
#:   sub-plan is part of a complete plan (off: the paper's first-sub-search-only planning);
#: - reuse_plans: after a sub-search is executed and the scene observed again, keep the rest of
#:   the last plan while it is still feasible on the new observation (`plan_check`);
#: - look_again 3: when a plan fails with nothing to execute, move one of the target's nearest
#:   neighbours to a random feasible place and observe again (perception errors such as a cut-off
#:   fragment blocking every corridor change with the scene);
#: - reobserve_unsolvable 2: observe the unchanged scene again after a round that failed as
#:   unsolvable (a segmentation that cut an object apart draws fresh noise), before look_again.
EPISODE_VARIANTS: dict[str, dict[str, object]] = {
    "full": {"lookahead": True, "reuse_plans": True, "look_again": 3, "reobserve_unsolvable": 2},
    "paper": {},
}
