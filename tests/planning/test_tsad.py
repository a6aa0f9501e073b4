"""TSAD on generated scenes with the oracle model: Theorems 1-2 as properties, plans that the world
model confirms, determinism, budgets; feasibility models against the generator's ground truth."""

import dataclasses as dc
import time

import numpy as np
import pytest
from frozen_scenes import load_scene

from tsad_drake.execution.world import GeometricWorld
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.pipeline import make_feasibility
from tsad_drake.planners.tsad.config import TSADConfig, with_extras
from tsad_drake.planners.tsad.plan import plan_tsad
from tsad_drake.planning.baseline_common import Budget
from tsad_drake.planning.pick_veto import PickVeto
from tsad_drake.planning.plan_check import plan_still_valid, shorten_plan
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.planning.types import Action
from tsad_drake.scenario import ObjectConfig, Scenario
from tsad_drake.scenario_generator import target_blockers

#: generated scenes (frozen as JSON, so generator changes do not move them) that TSAD solves with
#: the oracle; 1/0 needs a non-blocker relocated out of the way first
SOLVED = [("1", 0), ("1", 1), ("3", 1)]
CONFIG = TSADConfig()
def _cyl(name, x, y, r=0.03):
    return ObjectConfig(name=name, kind="cylinder", shape="cylinder", size=[r, 0.15], x=x, y=y)


def walled_in_scene() -> Scenario:
    """The target's blocker is flanked by two boxes too wide to pick: no collision-free plan."""
    large = [ObjectConfig(name=f"large{i}", kind="large", shape="box", size=[0.11, 0.11, 0.18],
                          x=0.07, y=side * 0.09) for i, side in enumerate((1, -1))]
    return Scenario(name="walled", objects=[_cyl("target", 0.27, 0.0), _cyl("a", 0.17, 0.0), *large],
                    target="target")


@pytest.fixture(scope="module")
def scenes():
    out = {}
    for key in SOLVED + [("walled", 0)]:
        scenario = walled_in_scene() if key[0] == "walled" else load_scene(*key)
        workspace = make_workspace(scenario)
        state = state_from_perception(observe_raycast(scenario).scene)
        out[key] = (scenario, workspace, state)
    return out


@pytest.fixture(scope="module")
def plans(scenes):
    out = {}
    for key in SOLVED:
        scenario, workspace, state = scenes[key]
        feasibility = make_feasibility("oracle", scenario, workspace)
        out[key] = plan_tsad(state, feasibility, workspace, CONFIG, np.random.default_rng(key[1]))
    return out


def _names(state, indices):
    return {state.objects[i].name for i in indices}


@pytest.mark.parametrize("key", SOLVED)
def test_rearrangement_set_shrinks_and_termination_conditions_hold(key, scenes, plans):
    scenario, workspace, state = scenes[key]
    plan = plans[key]
    assert plan.success, plan.failure_reason
    feasibility = make_feasibility("oracle", scenario, workspace)
    k = int(np.argmin(np.abs(workspace.approach_angles - plan.theta_star)))
    sizes = plan.stats["rearrangement_set_sizes"]
    assert all(b < a for a, b in zip(sizes, sizes[1:], strict=False)) and sizes[-1] == 0
    # the first complete plan is returned: its attempt and angle are among those configured
    found = plan.stats["found_at"]
    assert 0 <= found["attempt"] < CONFIG.extras.restarts
    assert 0 <= found["angle_rank"] <= CONFIG.extras.angle_fallbacks
    assert 0 < plan.stats["iterations_total"] <= CONFIG.iteration_budget
    root = current = state
    for sub in sorted({a.sub_search for a in plan.actions}):
        for action in [a for a in plan.actions if a.sub_search == sub]:
            assert feasibility.pickable(current, current.index(action.object)).any()
            current = simulate_pick_place(current, action)
        before = _names(root, feasibility.blockers(root, root.target_index)[k])
        after = _names(current, feasibility.blockers(current, current.target_index)[k])
        assert before - after, "termination condition 1: some blocker left R"
        assert after <= before, "termination condition 2: no new blocker"
        root = current
    assert feasibility.pickable(current, current.target_index)[k]


@pytest.mark.parametrize("key", SOLVED)
def test_plan_outcome_in_world_model_matches_claim(key, scenes, plans):
    scenario, _, _ = scenes[key]
    plan = plans[key]
    world = GeometricWorld(scenario)
    for action in plan.actions:
        world.execute(action)
    assert world.retrieve()
    outcome = world.outcome()
    assert outcome.success and outcome.falls == 0
    assert outcome.num_actions == len(plan.actions) + 1


def test_non_monotone_scene_is_solved_by_relocating_a_non_blocker(scenes, plans):
    """Scene 1/0: a blocker is only pickable once an object outside R is moved out of its way."""
    scenario, workspace, state = scenes[("1", 0)]
    plan = plans[("1", 0)]
    assert plan.success
    feasibility = make_feasibility("oracle", scenario, workspace)
    k = int(np.argmin(np.abs(workspace.approach_angles - plan.theta_star)))
    initial = _names(state, feasibility.blockers(state, state.target_index)[k])
    stuck = [n for n in initial if not feasibility.pickable(state, state.index(n)).any()]
    assert stuck, "some blocker cannot be picked at first"
    moved = [a.object for a in plan.actions]
    assert any(n not in initial for n in moved), moved


def test_same_seed_same_plan(scenes, plans):
    scenario, workspace, state = scenes[("1", 1)]
    again = plan_tsad(state, make_feasibility("oracle", scenario, workspace), workspace, CONFIG,
                      np.random.default_rng(1))
    assert again.actions == plans[("1", 1)].actions and again.theta_star == plans[("1", 1)].theta_star


def test_unsolvable_scene_is_a_failure_result(scenes):
    scenario, workspace, state = scenes[("walled", 0)]
    oracle = make_feasibility("oracle", scenario, workspace)
    # the full variant sees before searching that no sequence can free the target
    plan = plan_tsad(state, oracle, workspace, CONFIG, np.random.default_rng(0))
    assert not plan.success and plan.failure_reason.startswith("unsolvable")
    assert plan.stats["unsolvable"] and plan.stats["extras_used"]["fail_fast"] == 1
    # without the check (the paper's algorithm) the search ends on its count budget
    searched = plan_tsad(state, oracle, workspace, with_extras(CONFIG, fail_fast=False),
                         np.random.default_rng(0))
    assert not searched.success and searched.failure_reason
    assert 0 < searched.stats["iterations_total"] <= CONFIG.iteration_budget


def test_the_iteration_budget_ends_a_search_the_same_way_on_any_machine(scenes):
    scenario, workspace, state = scenes[("1", 1)]
    oracle = make_feasibility("oracle", scenario, workspace)
    # sub-searches that never stop on their own: only the call's budget ends the search
    endless = with_extras(dc.replace(CONFIG, iterations=10**9), max_iterations=10**9,
                          attempt_iterations=None)
    config = dc.replace(endless, iteration_budget=400)
    plan = plan_tsad(state, oracle, workspace, config, np.random.default_rng(0))
    assert not plan.success and "budget" in plan.failure_reason
    assert plan.stats["iterations_total"] == 400 and not plan.timed_out
    again = plan_tsad(state, oracle, workspace, config, np.random.default_rng(0))
    assert again.actions == plan.actions and again.stats["iterations"] == plan.stats["iterations"]
    # the wall-clock safety stop behind it makes the call a failure, never a shorter search
    config = dc.replace(endless, iteration_budget=10**9, safety_stop_s=1.0)
    t0 = time.perf_counter()
    plan = plan_tsad(state, oracle, workspace, config, np.random.default_rng(0))
    assert not plan.success and plan.timed_out and plan.stats["timed_out"]
    assert plan.actions == [] and plan.failure_reason.startswith("timed out")
    assert time.perf_counter() - t0 < 1.0 + 5.0


def test_each_attempt_ends_at_its_share_of_the_iterations(scenes):
    scenario, workspace, state = scenes[("1", 1)]
    oracle = make_feasibility("oracle", scenario, workspace)
    # sub-searches that never stop on their own: each attempt ends at its cap, doubled in the
    # restart pass, and the next angle is tried; the call's budget still bounds them all
    endless = with_extras(dc.replace(CONFIG, iterations=10**9), max_iterations=10**9,
                          attempt_iterations=100, restarts=2, angle_fallbacks=1)
    plan = plan_tsad(state, oracle, workspace, dc.replace(endless, iteration_budget=10**6),
                     np.random.default_rng(0))
    assert not plan.success and not plan.timed_out
    angles = {a["angle_rank"] for a in plan.stats["attempts"]}
    assert angles == {0, 1}
    assert plan.stats["attempts"] == [{"attempt": a, "angle_rank": j, "iterations": 100 * 2 ** a}
                                      for a in range(2) for j in range(2)]
    assert plan.stats["iterations_total"] == 600
    assert plan.stats["extras_used"]["attempt_iterations"] == 4
    # a budget smaller than the caps: it ends the call inside the second attempt
    short = plan_tsad(state, oracle, workspace, dc.replace(endless, iteration_budget=150),
                      np.random.default_rng(0))
    assert [a["iterations"] for a in short.stats["attempts"]] == [100, 50]
    assert short.stats["iterations_total"] == 150 and "budget" in short.failure_reason


def test_a_failed_plan_reports_the_whole_call_as_planning_time(scenes, monkeypatch):
    # the furthest attempt comes first; the attempts after it cost time too and must be counted
    import tsad_drake.planners.tsad.plan as tsad_module

    scenario, workspace, state = scenes[("walled", 0)]
    calls = []

    def attempt(state, feasibility, workspace, config, rng, theta_star, budget, result, extras):
        time.sleep(0.1)
        calls.append(theta_star)
        actions = [Action(state.objects[0].name, 0.0, 0.1, 0.0, 0.0)] if len(calls) == 1 else []
        return result(theta_star, actions, False, "sub-search 0: no terminal state found")

    monkeypatch.setattr(tsad_module, "_sequential_sub_search", attempt)
    t0 = time.perf_counter()
    plan = plan_tsad(state, make_feasibility("oracle", scenario, workspace), workspace,
                     with_extras(CONFIG, fail_fast=False), np.random.default_rng(0))
    wall = time.perf_counter() - t0
    assert not plan.success and len(plan.actions) == 1 and len(calls) >= 3
    assert plan.planning_time_s >= wall - 0.05 >= 0.1 * len(calls) - 0.05


def test_target_too_wide_is_a_failure_result(scenes):
    scenario, workspace, state = scenes[("1", 1)]
    wide = dc.replace(scenario, objects=[dc.replace(o, shape="box", size=[0.12, 0.12, 0.15], yaw=0.0)
                                         if o.name == scenario.target else o
                                         for o in scenario.objects])
    plan = plan_tsad(state, make_feasibility("oracle", wide, workspace), workspace, CONFIG,
                     np.random.default_rng(0))
    assert not plan.success and "any approach angle" in plan.failure_reason


@pytest.mark.parametrize("name", ["oracle", "geometric"])
def test_target_blockers_match_ground_truth(name, scenes):
    scenario, workspace, state = scenes[("1", 1)]
    feasibility = make_feasibility(name, scenario, workspace)
    found = feasibility.blockers(state, state.target_index)
    for theta, blockers in zip(workspace.approach_angles, found, strict=True):
        truth = {scenario.objects[i].name for i in target_blockers(scenario, theta)}
        assert _names(state, blockers) == truth


def test_unknown_model_is_a_value_error():
    scenario = walled_in_scene()
    with pytest.raises(ValueError, match="unknown feasibility"):
        make_feasibility("magic", scenario, make_workspace(scenario))


@pytest.mark.parametrize("key", SOLVED)
def test_plan_check_accepts_the_plan_and_rejects_a_cut_or_broken_one(scenes, plans, key):
    scenario, workspace, state = scenes[key]
    plan = plans[key]
    feasibility = make_feasibility("oracle", scenario, workspace)
    assert plan.success and plan.actions
    assert plan_still_valid(state, plan.actions, plan.theta_star, feasibility, workspace)
    # without its last action the target is still blocked at theta*
    assert not plan_still_valid(state, plan.actions[:-1], plan.theta_star, feasibility, workspace)
    # an action on an object that is not in the state, or that moves the target, is not valid
    ghost = dc.replace(plan.actions[0], object="no-such-object")
    assert not plan_still_valid(state, [ghost, *plan.actions[1:]], plan.theta_star, feasibility,
                                workspace)
    moves_target = dc.replace(plan.actions[0], object=state.target)
    assert not plan_still_valid(state, [moves_target, *plan.actions[1:]], plan.theta_star,
                                feasibility, workspace)
    # the rest of the plan, from the state its first sub-search leads to, is valid there too
    after = state
    first = [a for a in plan.actions if a.sub_search == plan.actions[0].sub_search]
    for action in first:
        after = simulate_pick_place(after, action)
    assert plan_still_valid(after, plan.actions[len(first):], plan.theta_star, feasibility,
                            workspace)


@pytest.mark.parametrize("model_name", ["oracle", "geometric", "net"])
def test_untried_actions_draw_exactly_the_feasible_actions_in_candidate_order(model_name):
    """The lazy draw (the network: one query per drawn cell) gives the eager list."""
    from tsad_drake.planning.actions import SAME_PLACE, UntriedActions
    from tsad_drake.planning.interface import approach_order
    from tsad_drake.planning.types import Action

    scenario = load_scene("2", 3)  # obj0 reaches its useful cell from another pick angle only
    workspace = make_workspace(scenario)
    state = state_from_perception(observe_raycast(scenario).scene)
    model = make_feasibility(model_name, scenario, workspace)
    movable = [i for i, o in enumerate(state.objects) if o.name != state.target]
    cells = range(len(workspace.cell_centres))
    candidates = [(i, c) for i in movable for c in cells]
    order = np.random.default_rng(0).permutation(len(candidates))
    candidates = [candidates[j] for j in order]
    # enumerated independently: per cell, the first pickable angle (nearest 0) from which
    # place_options has a placement there
    eager = {}
    angles = workspace.approach_angles
    second_choice = 0  # cells reached only from a pick angle other than the nearest one
    for i in movable:
        obj = state.objects[i]
        pickable = model.pickable(state, i)
        picks = [float(angles[k]) for k in approach_order(angles, 0.0) if pickable[k]]
        for n, theta_pick in enumerate(picks):
            options = model.place_options(state, i, theta_pick)
            for c in np.nonzero(np.isfinite(options))[0]:
                x, y = (float(v) for v in workspace.cell_centres[c])
                if np.hypot(x - obj.x, y - obj.y) >= SAME_PLACE and (obj.name, x, y) not in eager:
                    eager[(obj.name, x, y)] = Action(obj.name, theta_pick, x, y,
                                                     float(options[c]))
                    second_choice += n > 0
    assert eager, "the scene has feasible actions"
    assert second_choice, "some cell admits the object only from another pick angle"
    expected = []  # the eager list filtered in the candidates' drawing order (from the end)
    for i, c in reversed(candidates):
        x, y = workspace.cell_centres[c]
        key = (state.objects[i].name, float(x), float(y))
        if key in eager:
            expected.append(eager[key])
    fresh = make_feasibility(model_name, scenario, workspace)  # nothing asked yet
    untried = UntriedActions(fresh, state, workspace, list(candidates))
    drawn = []
    while (action := untried.pop()) is not None:
        drawn.append(action)
    assert drawn == expected
    again = UntriedActions(model, state, workspace, list(candidates))
    first = again.peek()
    again.discard(first.object, first.x, first.y)
    assert again.pop() == expected[1]


class _WithRolloutModel(PickVeto):
    """A feasibility model whose rollouts draw actions with another (cheaper) model, as the
    network's do with its point-cloud placement model (a PickVeto that vetoes nothing)."""

    def __init__(self, own, rollout_model):
        super().__init__(own, set())
        self._rollout = rollout_model

    def rollout_model(self):
        return self._rollout


def test_fast_rollouts_join_the_tree_only_as_actions_of_the_searchs_own_model(scenes):
    from tsad_drake.planners.tsad.sub_search import EmptyCells, SubSearch
    from tsad_drake.planning.interface import angle_index

    scenario, workspace, state = scenes[("1", 0)]
    oracle = make_feasibility("oracle", scenario, workspace)
    model = _WithRolloutModel(oracle, make_feasibility("geometric", scenario, workspace))
    plan = plan_tsad(state, model, workspace, with_extras(CONFIG, draft_search=False),
                     np.random.default_rng(0))
    assert plan.success and plan_still_valid(state, plan.actions, plan.theta_star, oracle,
                                             workspace)
    world = GeometricWorld(scenario)
    for action in plan.actions:
        world.execute(action)
    assert world.retrieve() and not world.fallen

    # recheck: an object the search's model cannot pick ends the path; a pickable one is
    # re-derived with the search's own angles and its end state judged on that model
    k = angle_index(workspace.approach_angles, plan.theta_star)
    search = SubSearch(state, k, model, workspace, CONFIG, np.random.default_rng(0),
                       EmptyCells(workspace), 0)
    assert search.rollout_model is model.rollout_model()
    stuck = [i for i, o in enumerate(state.objects)
             if o.name != state.target and not oracle.pickable(state, i).any()]
    free = [i for i, o in enumerate(state.objects)
            if o.name != state.target and oracle.pickable(state, i).any()]
    assert stuck and free
    x, y = workspace.cell_centres[0]
    bad = Action(state.objects[stuck[0]].name, 0.0, float(x), float(y), 0.0)
    assert search.recheck(state, [(bad, simulate_pick_place(state, bad))]) is None
    # the plan's first sub-search ends in a terminal state of a search rooted at `state`
    moves = [a for a in plan.actions if a.sub_search == 0]
    path, current = [], state
    for a in moves:
        skewed = dc.replace(a, theta_pick=a.theta_pick + 0.3, theta_place=a.theta_place + 0.3)
        current = simulate_pick_place(current, skewed)
        path.append((skewed, current))
    redone = search.recheck(state, path)
    assert redone is not None and len(redone) == len(moves)
    current = state
    for (again, after), a in zip(redone, moves, strict=True):
        assert (again.object, again.x, again.y) == (a.object, a.x, a.y)
        assert again.theta_pick != a.theta_pick + 0.3
        k_pick = angle_index(workspace.approach_angles, again.theta_pick)
        assert oracle.pickable(current, current.index(a.object))[k_pick]
        current = after
    assert search.reward(current)[1]


def test_a_cell_reached_only_from_another_pick_angle_is_an_action():
    """Scenario 2 seed 3: the one relocation that frees the target (obj0, a long box, to the
    front-right cell, turned by 20 degrees) cannot be made when obj0 is picked at the retrieval
    angle (10 degrees), only from 0 or -10: the action set takes the pick angle per cell, and
    TSAD finds the one-relocation plan that `optimal` finds."""
    from tsad_drake.planning.actions import UntriedActions
    from tsad_drake.planning.interface import angle_index

    scenario = load_scene("2", 3)
    workspace = make_workspace(scenario)
    state = state_from_perception(observe_raycast(scenario).scene)
    oracle = make_feasibility("oracle", scenario, workspace)
    i = state.index("obj0")
    cells = workspace.cell_centres
    cell = int(np.argmin(np.hypot(cells[:, 0] - 0.06625, cells[:, 1] + 0.1075)))
    prefer = np.radians(10.0)
    assert np.isnan(oracle.place_options(state, i, prefer)[cell])
    action = UntriedActions(oracle, state, workspace, [], prefer).check(i, cell)
    assert action is not None and not np.isclose(action.theta_pick, prefer)
    assert oracle.pickable(state, i)[angle_index(workspace.approach_angles, action.theta_pick)]
    after = simulate_pick_place(state, action)
    assert oracle.pickable(after, i)[angle_index(workspace.approach_angles, action.theta_place)]

    plan = plan_tsad(state, oracle, workspace, CONFIG, np.random.default_rng(3))
    assert plan.success and len(plan.actions) == 1 and plan.actions[0].object == "obj0"
    world = GeometricWorld(scenario)
    world.execute(plan.actions[0])
    assert world.retrieve() and not world.fallen


@pytest.mark.parametrize("key", SOLVED)
def test_shortened_plans_are_split_into_sub_searches_afresh(key, scenes, plans):
    from tsad_drake.planning.plan_check import regroup

    scenario, workspace, state = scenes[key]
    plan = plans[key]
    oracle = make_feasibility("oracle", scenario, workspace)
    flat = [dc.replace(a, sub_search=0) for a in plan.actions]
    regrouped = regroup(state, flat, plan.theta_star, oracle, workspace)
    # the labels a valid plan splits into meet the termination conditions (plan_check checks them)
    assert regrouped is not None and plan_still_valid(state, regrouped, plan.theta_star, oracle,
                                                      workspace)
    if len(plan.actions) > 1:
        assert regrouped[-1].sub_search > 0
    # a detour (the first object moved somewhere else first) is dropped again
    cells = workspace.cell_centres
    first = plan.actions[0]
    i = state.index(first.object)
    from tsad_drake.planning.actions import object_actions

    detours = [a for a in object_actions(oracle, state, i, workspace, first.theta_pick)
               if (a.x, a.y) != (first.x, first.y)]
    assert detours and len(cells) > 1
    detour = dc.replace(detours[0], sub_search=0)
    longer = [detour, dc.replace(first, theta_pick=detour.theta_place), *plan.actions[1:]]
    shortened = shorten_plan(state, longer, plan.theta_star, oracle, workspace)
    assert len(shortened) <= len(plan.actions)
    assert plan_still_valid(state, shortened, plan.theta_star, oracle, workspace)
    world = GeometricWorld(scenario)
    for action in shortened:
        world.execute(action)
    assert world.retrieve() and not world.fallen
    # moving an object to where it already is is no action (a merge of two moves can end there)
    from tsad_drake.planning.plan_check import replay_plan

    after = simulate_pick_place(state, first)
    assert replay_plan(after, plan.actions, plan.theta_star, oracle, workspace,
                       groups=False) is None


def test_a_sub_search_offers_distinct_terminal_states_best_first(scenes):
    from tsad_drake.planners.tsad.plan import optimal_angle
    from tsad_drake.planners.tsad.sub_search import EmptyCells, SubSearch
    from tsad_drake.planning.interface import angle_index

    scenario, workspace, state = scenes[("1", 0)]
    oracle = make_feasibility("oracle", scenario, workspace)
    k = angle_index(workspace.approach_angles, optimal_angle(state, oracle, workspace))
    search = SubSearch(state, k, oracle, workspace, CONFIG, np.random.default_rng(0),
                       EmptyCells(workspace), 0)
    search.run(Budget(10_000, 60.0))
    extracted = search.extract()
    branches = search.alternatives(3)
    assert 1 <= len(branches) <= 3 and branches[0][0] == extracted
    assert len({reached.key() for _, reached in branches}) == len(branches)
    for actions, reached in branches:
        current = state
        for action in actions:
            current = simulate_pick_place(current, action)
        assert current.key() == reached.key() and search.reward(reached)[1]


def test_a_move_there_and_back_is_dropped_as_a_pair():
    """Scenario 2 seed 23 (frozen): the search's plan moves obj7 to A, to B, back to A and to B
    again. Merging the middle two would move obj7 to where it already is (no action) and neither
    can go alone, so the pair is dropped: 5 relocations, `optimal`'s count, and the world model
    retrieves the target."""
    from tsad_drake.planning.plan_check import replay_plan

    scenario = load_scene("2", 23)
    workspace = make_workspace(scenario)
    state = state_from_perception(observe_raycast(scenario).scene)
    geometric = make_feasibility("geometric", scenario, workspace)
    a, b = (0.06625, 0.035833), (0.06625, -0.1075)
    steps = [("obj4", 10, (0.06625, 0.179167), 10), ("obj7", -30, a, -30),
             ("obj8", -30, (0.12875, -0.179167), -30), ("obj7", -30, b, -30),
             ("obj7", -30, a, -30), ("obj5", 20, (0.06625, -0.179167), 10), ("obj7", -30, b, -30)]
    searched = [Action(n, np.radians(tp), x, y, np.radians(tq)) for n, tp, (x, y), tq in steps]
    theta_star = np.radians(-20.0)
    assert replay_plan(state, searched, theta_star, geometric, workspace, groups=False)
    shortened = shorten_plan(state, searched, theta_star, geometric, workspace)
    assert len(shortened) == 5 and [x.object for x in shortened].count("obj7") == 2
    world = GeometricWorld(scenario)
    for action in shortened:
        world.execute(action)
    assert world.retrieve() and not world.fallen


class _NoPlacements(PickVeto):
    """A model that can pick what its base picks but place nothing anywhere."""

    def __init__(self, base):
        super().__init__(base, set())

    def place_options(self, state, index, theta_pick):
        return np.full(len(self.workspace.cell_centres), np.nan)

    def first_place_option(self, state, index, theta_pick, cells):
        return None


def test_a_draft_on_the_rollout_model_is_the_plan_only_when_the_model_certifies_it(scenes,
                                                                                  monkeypatch):
    scenario, workspace, state = scenes[("1", 0)]
    oracle = make_feasibility("oracle", scenario, workspace)
    geometric = make_feasibility("geometric", scenario, workspace)
    plan = plan_tsad(state, _WithRolloutModel(oracle, geometric), workspace, CONFIG,
                     np.random.default_rng(0))
    draft = plan.stats["draft"]
    assert plan.success and draft["certified"] is True and draft["model"] == "geometric"
    assert plan.stats["iterations_total"] == draft["iterations"] > 0
    assert plan.stats["extras_used"]["draft_search"] == 1
    assert plan_still_valid(state, plan.actions, plan.theta_star, oracle, workspace)
    world = GeometricWorld(scenario)
    for action in plan.actions:
        world.execute(action)
    assert world.retrieve() and not world.fallen

    # the model rules out the draft's first pick at every angle: the draft is not certified,
    # the round is searched on the model itself, and its plan never makes that pick
    first = plan.actions[0].object
    vetoed = PickVeto(oracle, {(first, k) for k in range(len(workspace.approach_angles))})
    again = plan_tsad(state, _WithRolloutModel(vetoed, geometric), workspace, CONFIG,
                      np.random.default_rng(0))
    assert again.stats["draft"]["certified"] is False
    assert again.stats["iterations_total"] > again.stats["draft"]["iterations"]
    assert first not in {a.object for a in again.actions}
    if again.success:
        assert plan_still_valid(state, again.actions, again.theta_star, vetoed, workspace)

    # a draft whose search finds no plan ends the round with the draft's reason, and nothing
    # is searched after it (the model itself would have found one here)
    failed = plan_tsad(state, _WithRolloutModel(oracle, _NoPlacements(geometric)), workspace,
                       CONFIG, np.random.default_rng(0))
    assert not failed.success and failed.failure_reason.endswith("(draft on the geometric model)")
    assert failed.stats["draft"]["success"] is False and failed.actions == []
    assert failed.stats["iterations_total"] == failed.stats["draft"]["iterations"]
    # the paper's TSAD searches on the model itself
    paper = plan_tsad(state, _WithRolloutModel(oracle, _NoPlacements(geometric)), workspace,
                      with_extras(CONFIG, draft_search=False), np.random.default_rng(0))
    assert paper.success and "draft" not in paper.stats
    # a draft that calls the state unsolvable where the model itself did not: the models
    # disagree about the state, and the round is searched on the model itself
    import tsad_drake.planners.tsad.plan as tsad_module

    real = tsad_module.unsolvable_reason
    monkeypatch.setattr(tsad_module, "unsolvable_reason", lambda s, model: (
        "unsolvable: the rollout model says so" if model is geometric else real(s, model)))
    searched = plan_tsad(state, _WithRolloutModel(oracle, geometric), workspace, CONFIG,
                         np.random.default_rng(0))
    assert searched.stats["draft"]["success"] is False and searched.success
    assert searched.stats["iterations_total"] > 0
    assert plan_still_valid(state, searched.actions, searched.theta_star, oracle, workspace)


def test_the_certified_prefix_stops_at_the_first_action_the_model_refuses(scenes, plans):
    from tsad_drake.planning.plan_check import certified_prefix

    scenario, workspace, state = scenes[("1", 0)]
    oracle = make_feasibility("oracle", scenario, workspace)
    actions = plans[("1", 0)].actions
    assert len(actions) >= 2
    whole = certified_prefix(state, actions, oracle, workspace)
    assert [(a.object, a.x, a.y, a.sub_search) for a in whole] == [
        (a.object, a.x, a.y, a.sub_search) for a in actions]
    second = actions[1].object
    vetoed = PickVeto(oracle, {(second, k) for k in range(len(workspace.approach_angles))})
    cut = certified_prefix(state, actions, vetoed, workspace)
    assert len(cut) == next(i for i, a in enumerate(actions) if a.object == second)
