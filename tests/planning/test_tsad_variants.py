"""TSAD's variants: `paper` is the paper's algorithm with every extra off, `full` the default."""

import dataclasses as dc

import numpy as np
import pytest
from frozen_scenes import load_scene

from tsad_drake.execution.world import GeometricWorld
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.pipeline import make_feasibility
from tsad_drake.planners.gp3 import gp3_optimal_angle
from tsad_drake.planners.tsad.config import EXTRAS, TSADConfig, TSADExtras, with_extras
from tsad_drake.planners.tsad.plan import plan_tsad
from tsad_drake.planners.tsad.sub_search import EmptyCells, SubSearch
from tsad_drake.planning.baseline_common import Budget
from tsad_drake.planning.registry import make_config
from tsad_drake.planning.state import make_workspace, state_from_perception

KEYS = [("1", 0), ("1", 1), ("3", 1)]


@pytest.fixture(scope="module")
def scenes():
    out = {}
    for key in KEYS:
        scenario = load_scene(*key)
        workspace = make_workspace(scenario)
        state = state_from_perception(observe_raycast(scenario).scene)
        out[key] = (scenario, workspace, state, make_feasibility("oracle", scenario, workspace))
    return out


def test_every_extra_has_a_paper_value_that_differs_from_full():
    full, paper = make_config("tsad"), make_config("tsad", variant="paper")
    assert len(EXTRAS) >= 13 and paper.extras == TSADExtras.paper()
    for name in EXTRAS:
        assert getattr(paper.extras, name) != getattr(full.extras, name), name
    # the variant changes the extras only, and never shares them between configs
    assert dc.replace(paper, extras=full.extras) == full
    assert make_config("tsad", variant="paper").extras is not paper.extras
    # the reward ablations stack on the variant
    assert make_config("tsad", "no-ro", variant="paper").use_ro is False
    with pytest.raises(ValueError, match="no variant"):
        make_config("gp3", variant="paper")
    with pytest.raises(ValueError, match="no variant"):
        make_config("tsad", variant="fancy")


@pytest.mark.parametrize("key", KEYS)
def test_paper_theta_star_is_gp3s(key, scenes):
    scenario, workspace, state, feasibility = scenes[key]
    config = make_config("tsad", variant="paper")
    plan = plan_tsad(state, feasibility, workspace, config, np.random.default_rng(key[1]))
    expected, _ = gp3_optimal_angle(state, feasibility, workspace,
                                    rng=np.random.default_rng(key[1]))
    assert plan.theta_star == pytest.approx(expected)
    assert plan.stats["gp3_order"]  # GP3's search ran and found an order


@pytest.mark.parametrize("key", KEYS)
def test_a_paper_plan_uses_no_extra_and_is_executable(key, scenes):
    scenario, workspace, state, feasibility = scenes[key]
    config = make_config("tsad", variant="paper")
    plan = plan_tsad(state, feasibility, workspace, config, np.random.default_rng(key[1]))
    assert plan.stats["extras_used"] == {name: 0 for name in EXTRAS}
    # fixed number of iterations per sub-search: exactly `iterations`
    assert all(n == config.iterations for n in plan.stats.get("iterations", []))
    if plan.success:  # executed in the world model, the plan does what it claims
        world = GeometricWorld(scenario)
        for action in plan.actions:
            assert world.execute(action).moved
        assert world.retrievable() and not world.fallen
    # the full variant on the same scene does use extras
    full = plan_tsad(state, feasibility, workspace, TSADConfig(), np.random.default_rng(key[1]))
    assert sum(full.stats["extras_used"].values()) > 0


def test_paper_rollouts_only_estimate_values_and_r_e_is_floored(scenes):
    scenario, workspace, state, feasibility = scenes[("1", 0)]
    config = make_config("tsad", variant="paper")
    k = 3  # the front angle (0 rad) of the 7
    assert workspace.approach_angles[k] == pytest.approx(0.0)
    cells = EmptyCells(workspace)
    search = SubSearch(state, k, feasibility, workspace, config, np.random.default_rng(0), cells,
                       cells(state) + 50)  # a reference no state reaches: r_e would be negative
    search.run(Budget(config.iterations, 60.0))
    assert search.iterations == config.iterations
    # one node per iteration at most: no rollout path was added to the tree
    assert search.nodes <= 1 + search.iterations
    nodes, stack = [], [search.root]
    while stack:
        node = stack.pop()
        nodes.append(node)
        stack.extend(node.children)
    assert min(n.reward for n in nodes) >= -config.w_o  # r_e never below 0; r_o at most -w_o
    full = with_extras(config, negative_empty_reward=True)
    negative = SubSearch(state, k, feasibility, workspace, full, np.random.default_rng(0), cells,
                         cells(state) + 50)
    assert negative.root.reward < 0
