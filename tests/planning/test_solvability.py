"""Unsolvable perceived problems end at once with their reason; a split object is joined again."""

from __future__ import annotations

import dataclasses as dc
import json
from pathlib import Path

import numpy as np
import pytest

from tsad_drake.perception.observe import (
    interpenetration,
    join_interpenetrating,
    perception_config,
)
from tsad_drake.perception.sensor import sensor_config
from tsad_drake.perception.types import PerceivedObject, PerceivedScene
from tsad_drake.pipeline import make_feasibility
from tsad_drake.planners.tsad.plan import plan_tsad
from tsad_drake.planning.registry import make_config
from tsad_drake.planning.solvability import freeable, unsolvable_reason
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.scenes import generate_scenario

FIXTURE = Path(__file__).parent / "observations" / "demo_split_obj4.npz"


def load_observation(path: Path) -> PerceivedScene:
    data = np.load(path)
    meta = json.loads(str(data["meta"]))
    objects = [PerceivedObject(o["name"], data[f"points_{k}"], o["x"], o["y"], o["yaw"],
                               is_target=o["is_target"], shape=o["shape"], size=tuple(o["size"]),
                               outline=data[f"outline_{k}"] if f"outline_{k}" in data else None,
                               uncertainty=o["uncertainty"])
               for k, o in enumerate(meta["objects"])]
    return PerceivedScene(objects, meta["target"])


@pytest.fixture(scope="module")
def demo():
    scenario = generate_scenario("1", 0)
    return scenario, make_workspace(scenario), load_observation(FIXTURE)


@pytest.mark.parametrize("model", ["geometric", "net"])
def test_the_demo_split_observation_fails_at_once_naming_the_pieces(demo, model):
    scenario, workspace, scene = demo
    state = state_from_perception(scene)
    feasibility = make_feasibility(model, scenario, workspace, "realistic")
    plan = plan_tsad(state, feasibility, workspace, make_config("tsad"), np.random.default_rng(0))
    assert not plan.success and plan.actions == [] and plan.stats["unsolvable"]
    assert "mutually blocking: cluster2 and cluster3" in plan.failure_reason
    assert "iterations_total" not in plan.stats  # no search ran
    # the verdict is right for the model: neither piece is pickable at any angle, each blocks
    # the other wherever it is reachable, and the target's every reachable corridor holds one
    names = [o.name for o in state.objects]
    two, three = names.index("cluster2"), names.index("cluster3")
    for i, j in ((two, three), (three, two)):
        assert not feasibility.pickable(state, i).any()
        reach = feasibility.reachable(state, i)
        assert all(j in feasibility.blockers(state, i)[k] for k in np.nonzero(reach)[0])
    assert two not in freeable(state, feasibility) and three not in freeable(state, feasibility)


def test_the_paper_variant_searches_anyway(demo):
    scenario, workspace, scene = demo
    state = state_from_perception(scene)
    feasibility = make_feasibility("geometric", scenario, workspace)
    config = dc.replace(make_config("tsad", variant="paper"), max_sub_searches=2)
    plan = plan_tsad(state, feasibility, workspace, config, np.random.default_rng(0))
    assert not plan.success and "unsolvable" not in plan.stats
    assert plan.stats["extras_used"]["fail_fast"] == 0


def test_joining_the_interpenetrating_pieces_makes_the_demo_solvable(demo):
    scenario, workspace, scene = demo
    by_name = {o.name: o for o in scene.objects}
    depth = interpenetration(by_name["cluster2"].outline, by_name["cluster3"].outline)
    assert depth > 0.02  # rigid objects cannot stand 2 cm inside each other
    config = perception_config(sensor_config("realistic"))
    joined = join_interpenetrating(scene.objects, config, None)
    assert [o.name for o in joined] == [n for n in by_name if n != "cluster3"]
    merged = next(o for o in joined if o.name == "cluster2")
    assert len(merged.points) == len(by_name["cluster2"].points) + len(by_name["cluster3"].points)
    # the joined box stands where the true obj4 stands
    obj4 = next(o for o in scenario.objects if o.name == "obj4")
    assert np.hypot(merged.x - obj4.x, merged.y - obj4.y) < 0.01
    state = state_from_perception(PerceivedScene(joined, scene.target))
    feasibility = make_feasibility("geometric", scenario, workspace)
    assert unsolvable_reason(state, feasibility) == ""
    plan = plan_tsad(state, feasibility, workspace, make_config("tsad"), np.random.default_rng(0))
    assert plan.success and plan.actions


def too_wide_scene():
    """The target behind a 0.22 m wide box: no approach angle fits it in the 85 mm stroke."""
    from tsad_drake.scenario import ObjectConfig, Scenario, validate

    scenario = Scenario(name="too-wide", target="target", objects=[
        ObjectConfig(name="slab", kind="square_pillar", shape="box", size=[0.06, 0.22, 0.14],
                     x=0.10, y=0.0),
        ObjectConfig(name="target", shape="cylinder", size=[0.03, 0.13], x=0.25, y=0.0),
        ObjectConfig(name="side", shape="cylinder", size=[0.03, 0.13], x=0.12, y=0.18)])
    validate(scenario)
    return scenario


@pytest.mark.parametrize(("planner", "model"), [
    ("tsad", "geometric"), ("gp3", "geometric"), ("rots", "geometric"),
    ("rots-star", "geometric"), ("rots-star-search", "geometric"), ("optimal", "oracle")])
def test_a_blocker_too_wide_to_grasp_is_reported_by_every_planner(planner, model):
    """The episode fails as unsolvable, naming the blocker and its width against the stroke, with
    under a second of planning (TSAD checks itself; the loop checks for the others)."""
    from tsad_drake.pipeline import EpisodeSettings, plan_episode

    row = plan_episode(too_wide_scene(), 0, EpisodeSettings(planner=planner, feasibility=model)).to_json()
    assert not row["success"]
    reason = row["failure_reason"]
    assert "unsolvable" in reason and "slab cannot be grasped at any approach angle" in reason
    assert "narrowest across the gripper 220 mm" in reason, reason
    assert row["rounds"][0]["stats"]["unsolvable"]
    assert row["planning_time_s"] < 1.0  # a figure of this test's scene, not a timing target
    assert row["num_actions"] <= 3 and all(a["object"] == "side" for a in row["actions"])


def test_the_target_too_wide_to_grasp_is_named_with_its_width():
    from tsad_drake.planning.feasibility import GeometricFeasibility
    from tsad_drake.planning.state import true_state

    scenario = too_wide_scene()
    scenario.target = "slab"
    state = true_state(scenario)
    why = unsolvable_reason(state, GeometricFeasibility(make_workspace(scenario)))
    assert why.startswith("unsolvable: the target slab cannot be grasped at any approach angle")
    assert "stroke takes" in why
