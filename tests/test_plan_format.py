"""The tsad-plan/1 format: the shipped JSON Schema and the validator agree, documents round-trip."""

import json
import math
import tomllib
from pathlib import Path

import pytest

from tsad_drake.plan_format import (
    ACTION_KEYS,
    PLAN_FORMAT,
    REQUIRED_ACTION,
    REQUIRED_TOP,
    SCHEMA_PATH,
    TOP_KEYS,
    PlanFormatError,
    load_schema,
    parse_plan,
    plan_from_episode,
    plan_json,
)
from tsad_drake.planning.types import Action
from tsad_drake.scenario import ObjectConfig, Scenario

ROOT = Path(__file__).resolve().parent.parent


def _scene() -> Scenario:
    return Scenario(name="fmt", target="t", objects=[
        ObjectConfig(name="a", shape="cylinder", size=[0.03, 0.15], x=0.08, y=0.0),
        ObjectConfig(name="t", shape="box", kind="square_pillar", size=[0.04, 0.04, 0.12],
                     x=0.25, y=0.0, yaw=0.2)])


def test_the_schema_ships_in_the_package_and_names_the_validators_fields():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    patterns = config["tool"]["setuptools"]["package-data"]["tsad_drake"]
    package = ROOT / "tsad_drake"
    assert any(SCHEMA_PATH in package.glob(p) for p in patterns)
    schema = load_schema()
    assert schema["properties"]["format"]["const"] == PLAN_FORMAT
    assert tuple(schema["properties"]) == TOP_KEYS and tuple(schema["required"]) == REQUIRED_TOP
    item = schema["properties"]["actions"]["items"]
    assert tuple(item["properties"]) == ACTION_KEYS and tuple(item["required"]) == REQUIRED_ACTION
    assert schema["additionalProperties"] is False and item["additionalProperties"] is False


def test_a_document_round_trips_through_json():
    actions = [Action("a", math.radians(-10), 0.10, 0.15, math.radians(20), 2)]
    text = json.dumps(plan_json(_scene(), actions, retrieve_target=True,
                                theta_retrieve=math.radians(10), meta={"by": "test"}))
    plan = parse_plan(json.loads(text))
    assert plan.scenario == _scene() and plan.retrieve_target and plan.meta == {"by": "test"}
    assert math.isclose(plan.theta_retrieve, math.radians(10))
    (action,) = plan.actions
    assert (action.object, action.x, action.y, action.sub_search) == ("a", 0.10, 0.15, 2)
    assert math.isclose(action.theta_pick, math.radians(-10))
    assert math.isclose(action.theta_place, math.radians(20))


def test_placement_follows_the_yaw_through_the_plan():
    """The box turns by theta_place - theta_pick at each action: 45 degrees later its corner
    reaches past a point its side did not."""
    t = _scene().object("t")
    # this close to the back wall the box fits at its own yaw (0.2 rad), not turned by 40 deg
    edge = 0.32 - t.size[0] / 2 * (math.cos(t.yaw) + math.sin(t.yaw)) - 0.001
    straight = [Action("t", 0.0, 0.25, 0.1, 0.0), Action("t", 0.0, edge, 0.1, 0.0)]
    assert len(parse_plan(plan_json(_scene(), straight)).actions) == 2
    turned = [Action("t", 0.0, 0.25, 0.1, math.radians(40)), Action("t", 0.0, edge, 0.1, 0.0)]
    with pytest.raises(PlanFormatError, match=r"actions\[1\].place_xy: .* outside the shelf"):
        parse_plan(plan_json(_scene(), turned))


def test_plan_from_episode_takes_the_true_objects_and_the_retrieval():
    row = {"planner": "tsad", "feasibility": "geometric", "seed": 3, "success": True,
           "theta_star_deg": -10.0,
           "actions": [{"object": "seg1", "true_object": "a", "theta_pick_deg": 0.0,
                        "place_xy": [0.1, 0.15], "theta_place_deg": 10.0, "sub_search": 0}]}
    document = plan_from_episode(_scene(), row)
    assert document["retrieve_target"] and document["meta"]["theta_star_deg"] == -10.0
    plan = parse_plan(json.loads(json.dumps(document)))
    assert [a.object for a in plan.actions] == ["a"]
    assert not plan_from_episode(_scene(), {**row, "success": False})["retrieve_target"]


def test_the_documented_example_is_a_valid_plan():
    import re

    text = (ROOT / "docs" / "plan-format.md").read_text()
    example = json.loads(re.search(r"```json\n(.*?)```", text, re.S).group(1))
    plan = parse_plan(example)
    assert [a.object for a in plan.actions] == ["front", "side"] and plan.retrieve_target
    # the example script writes this very plan
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "verify_hand_made_plan", ROOT / "examples" / "verify_hand_made_plan.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert plan.scenario == parse_plan(plan_json(module.scene(), [])).scenario
    assert all(math.isclose(a.theta_pick, b.theta_pick) and (a.object, a.x, a.y) == (b.object, b.x, b.y)
               for a, b in zip(plan.actions, module.ACTIONS, strict=True))
