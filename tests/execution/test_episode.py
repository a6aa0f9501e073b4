"""One closed-loop episode end to end (ray-cast observation, oracle TSAD, world model)."""

import json

import pytest

from tsad_drake.execution.episode import run_episode
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.planning.registry import get_planner, make_config
from tsad_drake.scenario_generator import generate_scenario


def test_closed_loop_episode_succeeds_and_serialises():
    scenario = generate_scenario("1", 1)
    result = run_episode(scenario, get_planner("tsad"), "oracle",
                         lambda s: observe_raycast(s).scene, make_config("tsad"), seed=1,
                         planner_name="tsad")
    assert result.success and result.falls == 0, result.failure_reason
    assert result.num_actions == len(result.actions) + 1  # relocations plus the retrieval
    assert len(result.rounds) >= 2  # planned, executed the first sub-search, observed again
    data = json.loads(json.dumps(result.to_json()))
    for key in ("scenario", "seed", "planner", "feasibility", "theta_star_deg", "actions",
                "success", "num_actions", "falls", "failure_reason", "planning_time_s"):
        assert key in data
    assert set(data["actions"][0]) >= {"object", "theta_pick_deg", "place_xy", "theta_place_deg",
                                       "sub_search"}


def test_bad_names_and_limits():
    with pytest.raises(ValueError, match="unknown planner"):
        get_planner("astar")
    with pytest.raises(ValueError, match="ablation"):
        make_config("tsad", "no-xx")
    assert make_config("tsad", "no-ro").use_ro is False
    with pytest.raises(ValueError, match="max_actions"):
        run_episode(generate_scenario("1", 1), get_planner("tsad"), "oracle",
                    lambda s: observe_raycast(s).scene, make_config("tsad"), seed=0, max_actions=0)
