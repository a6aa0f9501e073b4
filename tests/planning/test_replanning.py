"""The closed loop's re-planning policy on its own: exclusions, vetoes, plan reuse, the cycle guard."""

import dataclasses as dc
import math

import numpy as np
import pytest

from tsad_drake.perception.observe import observe_raycast
from tsad_drake.pipeline import make_feasibility
from tsad_drake.planning.pick_veto import PickVeto
from tsad_drake.planning.plan_check import action_key, relocation_key
from tsad_drake.planning.registry import get_planner, make_config
from tsad_drake.planning.replanning import ReplanningPolicy, configuration, reused
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.planning.types import Action, Plan
from tsad_drake.scenes import generate_scenario


def _moved(scene, name, x, y):
    """`scene` with object `name` at (x, y)."""
    objects = [dc.replace(o, x=x, y=y) if o.name == name else o for o in scene.objects]
    return dc.replace(scene, objects=objects)


def test_closed_loop_asks_tsad_for_one_sub_search_unless_it_looks_ahead():
    scene = generate_scenario("1", 1)
    tsad = get_planner("tsad")
    config = make_config("tsad")
    assert ReplanningPolicy(tsad, config, True, scene).config.max_sub_searches == 1
    assert ReplanningPolicy(tsad, config, False, scene).config.max_sub_searches == config.max_sub_searches
    ahead = ReplanningPolicy(tsad, config, True, scene, lookahead=True)
    assert ahead.config.max_sub_searches == config.max_sub_searches
    gp3 = get_planner("gp3")  # no sub-searches, no exclusions: its config is left alone
    assert ReplanningPolicy(gp3, make_config("gp3"), True, scene).config == make_config("gp3")


def test_a_round_back_to_an_earlier_configuration_excludes_every_move_since():
    scene = generate_scenario("1", 1)
    policy = ReplanningPolicy(get_planner("tsad"), make_config("tsad", safety_stop_s=600.0), True, scene)
    obj = scene.object("obj7")
    there = Action("obj7", 0.0, 0.05, 0.20, 0.0)
    back = Action("obj7", 0.0, obj.x, obj.y, 0.0)
    policy.executed([there], 1, _moved(scene, "obj7", there.x, there.y))
    assert policy.excluded == []  # a new configuration: progress
    turned = dc.replace(scene, objects=[dc.replace(o, yaw=o.yaw + 0.3) if o.name == "obj7" else o
                                        for o in scene.objects])
    assert configuration(turned) == configuration(scene)  # the yaw is no progress
    policy.executed([back], 1, turned)
    assert policy.excluded == [action_key(there), action_key(back)]


def test_rejections_veto_a_pick_angle_or_exclude_a_relocation_and_end_after_the_limit():
    scene = generate_scenario("1", 1)
    workspace = make_workspace(scene)
    policy = ReplanningPolicy(get_planner("tsad"), make_config("tsad", safety_stop_s=600.0), True, scene,
                              max_rejections=2)
    pick = Action("obj7", math.radians(10.0), 0.05, 0.20, 0.0)
    place = Action("obj3", 0.0, 0.06, -0.20, 0.0)
    assert not policy.rejected(pick, True, workspace)
    assert policy.vetoes == {("obj7", 4)} and policy.excluded == []
    assert not policy.rejected(place, False, workspace)
    assert policy.excluded == [relocation_key("obj3", 0.06, -0.20)]
    assert isinstance(policy.model(make_feasibility("oracle", scene, workspace)), PickVeto)
    assert policy.rejected(place, False, workspace)  # the third in a row
    policy.executed([place], 1, scene)  # an executed action clears the vetoes, not exclusions
    assert policy.vetoes == set() and policy.in_a_row == 0 and policy.excluded
    stub = Plan("stub", 0.0, [], False)
    seen = []
    spec = dc.replace(get_planner("tsad"),
                      plan=lambda *args: seen.append(args[3].excluded_actions) or stub)
    ReplanningPolicy(spec, make_config("tsad", safety_stop_s=600.0), True, scene).plan(None, None, workspace,
                                                                   np.random.default_rng(0))
    assert seen == [[]]  # a fresh policy excludes nothing


def test_the_rest_of_a_plan_is_kept_for_the_next_round_and_dropped_when_cut_short():
    scene = generate_scenario("2", 16)
    policy = ReplanningPolicy(get_planner("tsad"), make_config("tsad", safety_stop_s=600.0), True, scene,
                              lookahead=True, reuse_plans=True)
    actions = [Action("obj1", 0.0, 0.05, 0.2, 0.0, 0), Action("obj2", 0.0, 0.05, -0.2, 0.0, 1)]
    todo = policy.this_round(Plan("tsad", 0.0, actions, True))
    assert todo == actions[:1] and policy.pending.actions == actions[1:]
    policy.executed(todo, 0, scene)  # nothing executed: the rest no longer follows
    assert policy.pending is None


@pytest.mark.slow  # 60 s; reuse and its dropping stay covered by the test above
def test_the_rest_of_a_plan_is_not_reused_once_one_of_its_relocations_is_excluded():
    """The closed loop keeps the rest of the last plan while it is still feasible, but never one
    that holds a relocation excluded since (a motion refusal or the cycle guard): that would
    execute an excluded relocation."""
    scenario = generate_scenario("2", 16)  # five blockers: TSAD's plan has several sub-searches
    workspace = make_workspace(scenario)
    state = state_from_perception(observe_raycast(scenario).scene)
    oracle = make_feasibility("oracle", scenario, workspace)
    plan = get_planner("tsad").plan(state, oracle, workspace, make_config("tsad", safety_stop_s=600.0),
                                    np.random.default_rng(16))
    assert plan.success and len(plan.actions) >= 2
    kept = reused(plan, state, oracle, workspace)
    assert kept is not None and kept.stats["reused"]
    assert [action_key(a) for a in kept.actions] == [action_key(a) for a in plan.actions]
    last = action_key(plan.actions[-1])
    assert reused(plan, state, oracle, workspace, frozenset({last})) is None
    unrelated = (plan.actions[-1].object, 9.0, 9.0)
    assert reused(plan, state, oracle, workspace, frozenset({unrelated})) is not None
