"""`tsad verify PLAN`: plans from `tsad plan` and by hand, checked at the motion level; refusals
name their cause; malformed plans are one line and exit status 2."""

import copy
import json
import math

import numpy as np
import pytest
from cli_harness import assert_clean, invoke
from frozen_scenes import load_scene

from tsad_drake.plan_format import PLAN_FORMAT, plan_json
from tsad_drake.planning.types import Action
from tsad_drake.scenario import ObjectConfig, Scenario, save_scenario, validate


def small_scene() -> Scenario:
    """Four objects with room to move (the motion tests' layout): the target behind `front`."""
    scenario = Scenario(name="verify-test", target="target", objects=[
        ObjectConfig(name="front", shape="cylinder", size=[0.03, 0.15], x=0.08, y=0.0),
        ObjectConfig(name="box", kind="square_pillar", shape="box", size=[0.045, 0.045, 0.14],
                     x=0.20, y=0.10, yaw=0.3),
        ObjectConfig(name="side", shape="cylinder", size=[0.03, 0.16], x=0.18, y=-0.12),
        ObjectConfig(name="target", shape="cylinder", size=[0.03, 0.13], x=0.25, y=0.0)])
    validate(scenario)
    return scenario


#: clears the target's way: front to the left, side further to the right
GOOD = [Action("front", 0.0, 0.08, 0.16, 0.0),
        Action("side", math.radians(-10), 0.08, -0.16, math.radians(-10))]


def _write(tmp_path, document, name="plan.json"):
    path = tmp_path / name
    path.write_text(document if isinstance(document, str) else json.dumps(document))
    return path


def _verify(tmp_path, capsys, plan_path, *flags, out="out"):
    result = invoke(capsys, ["verify", plan_path, *flags, "--out", tmp_path / out])
    assert_clean(result)
    report = tmp_path / out / "report.json"
    return result, (json.loads(report.read_text()) if report.exists() else None)


def test_a_plan_by_tsad_plan_verifies_as_its_motion_run(tmp_path, capsys):
    """Scenario 1 seed 0 (frozen), TSAD on the geometric model, ideal sensing: plan.tsad.json
    read back by `tsad verify` gives the --motion run's verdict and segments for every action."""
    save_scenario(load_scene("1", 0), tmp_path / "scene.yaml")
    code, _, err = invoke(capsys, ["plan", "--scenario", tmp_path / "scene.yaml", "--planner",
                                   "tsad", "--feasibility", "geometric", "--observer", "raycast",
                                   "--sensor", "ideal", "--segmentation", "label", "--motion",
                                   "--out", tmp_path / "plan"])
    assert code == 0, err
    planned = json.loads((tmp_path / "plan" / "plan.json").read_text())
    document = json.loads((tmp_path / "plan" / "plan.tsad.json").read_text())
    assert document["format"] == PLAN_FORMAT and document["retrieve_target"] is True
    assert [a["object"] for a in document["actions"]] == [
        a["true_object"] for a in planned["actions"]]
    (code, out, _), report = _verify(tmp_path, capsys, tmp_path / "plan" / "plan.tsad.json")
    motion = planned["motion"]
    assert len(motion) >= 2 and report["num_actions"] == len(motion)
    assert [a["verified"] for a in report["actions"]] == [m["verified"] for m in motion]
    assert [a["failure"] for a in report["actions"]] == [m["failure"] for m in motion]
    assert [a["segments"] for a in report["actions"]] == [
        [s["name"] for s in m["segments"]] for m in motion]
    assert code == 0 and report["success"] and report["retrieval"]["verified"], out
    for name in ("replay.html", "scene.dmd.yaml", "report.json"):
        assert (tmp_path / "out" / name).stat().st_size > 0


def test_a_hand_made_plan_placing_onto_a_neighbour_is_refused_at_that_action(tmp_path, capsys):
    scenario = small_scene()
    box = scenario.object("box")
    actions = [GOOD[0], Action("side", 0.0, box.x, box.y, 0.0), GOOD[1]]
    path = _write(tmp_path, plan_json(scenario, actions, retrieve_target=True))
    (code, out, _), report = _verify(tmp_path, capsys, path)
    assert code == 1 and not report["success"]
    first, second, third = report["actions"]
    assert first["status"] == "verified" and third["status"] == "not checked"
    assert second["status"] == "refused" and not second["skipped"]
    cause = second["cause"]
    assert cause["kind"] == "clearance" and cause["half"] == "place"
    assert sorted(cause["bodies"]) == ["box", "side"] and cause["margin_mm"] < 0
    assert cause["where"].startswith("place")
    assert report["retrieval"]["status"] == "not checked"
    assert "action 2 (side) refused" in report["failure_reason"] and "REFUSED" in out


def test_keep_going_checks_later_actions_without_the_refused_one(tmp_path, capsys):
    scenario = small_scene()
    box = scenario.object("box")
    actions = [GOOD[0], Action("side", 0.0, box.x, box.y, 0.0), GOOD[1]]
    path = _write(tmp_path, plan_json(scenario, actions, retrieve_target=True))
    (code, _, _), report = _verify(tmp_path, capsys, path, "--keep-going")
    assert code == 1 and report["keep_going"] and report["skipped_actions"] == [1]
    assert [a["status"] for a in report["actions"]] == ["verified", "refused", "verified"]
    assert report["note"] and report["actions"][1]["skipped"]
    # side never moved onto the box: moving it from where it stands verifies, and so does the
    # retrieval on that scene
    assert report["retrieval"]["verified"]


def test_a_plan_picking_a_blocked_object_is_refused_with_a_collision_cause(tmp_path, capsys):
    scenario = small_scene()  # the target stands right behind `front`
    path = _write(tmp_path, plan_json(scenario, [Action("target", 0.0, 0.25, 0.18, 0.0)]))
    (code, _, _), report = _verify(tmp_path, capsys, path)
    assert code == 1
    (verdict,) = report["actions"]
    cause = verdict["cause"]
    assert verdict["status"] == "refused" and cause["kind"] == "clearance"
    assert cause["half"] == "pick" and "front" in cause["bodies"] and cause["margin_mm"] < 0


def test_a_feasible_plan_verifies_in_the_geometric_world_and_exits_0(tmp_path, capsys):
    scenario = small_scene()
    save_scenario(scenario, tmp_path / "scene.yaml")
    # the scenario as a path relative to the plan file
    path = _write(tmp_path, plan_json("scene.yaml", GOOD, retrieve_target=True))
    (code, out, _), report = _verify(tmp_path, capsys, path, "--world", "geometric")
    assert code == 0, out
    assert report["world"] == "geometric" and report["success"]
    assert all(a["world"]["moved"] and not a["world"]["fallen"] for a in report["actions"])
    assert report["retrieval"]["world"]["retrieved"]
    assert all(a["planning_time_s"] > 0 for a in report["actions"])


def test_the_public_api_returns_the_same_report():
    import tsad_drake as td

    report = td.verify_plan(small_scene(), GOOD, retrieve_target=True)
    assert isinstance(report, td.VerificationReport) and report.success
    doc = report.to_json()
    assert json.loads(json.dumps(doc)) == doc
    assert [a["status"] for a in doc["actions"]] == ["verified", "verified"]
    # one continuous motion: the second action starts where the first ended
    first, second = report.motions[:2]
    assert np.allclose(second.segments[0].q[0], first.end_q)
    with pytest.raises(ValueError, match=r"actions\[0\].object: no object named 'ghost'"):
        td.verify_plan(small_scene(), [Action("ghost", 0.0, 0.1, 0.1, 0.0)])


def _valid() -> dict:
    return plan_json(small_scene(), GOOD, retrieve_target=True)


def _set(path: list, value):
    def mutate(doc: dict) -> dict:
        target = doc
        for key in path[:-1]:
            target = target[key]
        if value is _DELETE:
            del target[path[-1]]
        else:
            target[path[-1]] = value
        return doc
    return mutate


_DELETE = object()

#: (mutation of a valid plan, text the one error line must contain)
MALFORMED = [
    (_set(["format"], _DELETE), "format: missing"),
    (_set(["format"], "tsad-plan/2"), "format: must be 'tsad-plan/1'"),
    (_set(["actoins"], []), "actoins: unknown field"),
    (_set(["scenario"], _DELETE), "scenario: missing"),
    (_set(["scenario"], 3), "scenario: must be the path"),
    (_set(["scenario"], "nowhere.yaml"), "scenario: scenario file not found"),
    (_set(["scenario", "objects", 0, "size"], [-0.03, 0.15]), "scenario.objects[0].size[0]"),
    (_set(["scenario", "colour"], "red"), "scenario: "),
    (_set(["scenario", "target"], "ghost"), "scenario.target"),
    (_set(["actions"], {"object": "front"}), "actions: must be a list"),
    (_set(["actions", 0], "front"), "actions[0]: must be an object"),
    (_set(["actions", 0, "object"], "ghost"), "actions[0].object: no object named 'ghost'"),
    (_set(["actions", 1, "object"], 7), "actions[1].object: must be an object name"),
    (_set(["actions", 0, "theta_pick_deg"], "0"), "actions[0].theta_pick_deg: must be"),
    (_set(["actions", 0, "theta_pick_deg"], 120), "actions[0].theta_pick_deg: must be"),
    (_set(["actions", 1, "theta_place_deg"], None), "actions[1].theta_place_deg: must be"),
    (_set(["actions", 0, "theta_place_deg"], _DELETE), "actions[0].theta_place_deg: missing"),
    (_set(["actions", 0, "place_xy"], [0.1]), "actions[0].place_xy: must be [x, y]"),
    (_set(["actions", 0, "place_xy"], [0.1, True]), "actions[0].place_xy: must be [x, y]"),
    (_set(["actions", 1, "place_xy"], [0.30, 0.0]), "actions[1].place_xy: (0.3, 0) puts side"),
    (_set(["actions", 0, "place_xy"], [0.08, 0.24]), "actions[0].place_xy: (0.08, 0.24) puts"),
    (_set(["actions", 0, "theta"], 0.0), "actions[0].theta: unknown field"),
    (_set(["actions", 0, "sub_search"], -1), "actions[0].sub_search"),
    (_set(["retrieve_target"], "yes"), "retrieve_target: must be true or false"),
    (_set(["theta_retrieve_deg"], 95), "theta_retrieve_deg: must be"),
    (_set(["meta"], [1]), "meta: must be an object"),
]


@pytest.mark.parametrize(("mutate", "expected"), MALFORMED,
                         ids=[m[1].split(":")[0] for m in MALFORMED])
def test_every_malformed_field_is_one_line_and_exit_2(tmp_path, capsys, mutate, expected):
    path = _write(tmp_path, mutate(copy.deepcopy(_valid())))
    code, _, err = invoke(capsys, ["verify", path, "--out", tmp_path / "out"])
    assert_clean((code, "", err), codes=(2,))
    assert expected in err, err
    assert not (tmp_path / "out").exists()  # nothing written, not even the folder


@pytest.mark.parametrize(("text", "expected"), [
    ("{not json", "malformed JSON"), ("[1, 2]", "plan: must be a JSON object"),
    ('{"format": "tsad-plan/1", "scenario": "s.yaml", "actions": [], "x": NaN}', "x: unknown"),
])
def test_files_that_are_not_plans_are_one_line_and_exit_2(tmp_path, capsys, text, expected):
    code, _, err = invoke(capsys, ["verify", _write(tmp_path, text), "--out", tmp_path / "out"])
    assert_clean((code, "", err), codes=(2,))
    assert expected in err and not (tmp_path / "out").exists()


def test_a_missing_plan_file_is_one_line_and_exit_2(tmp_path, capsys):
    code, _, err = invoke(capsys, ["verify", tmp_path / "none.json", "--out", tmp_path / "out"])
    assert_clean((code, "", err), codes=(2,))
    assert "plan file not found" in err


@pytest.mark.slow
def test_physics_world_reports_the_outcomes_of_tsad_plan_world_physics(tmp_path, capsys):
    """Scenario 1 seed 0 (frozen): `tsad plan --world physics` (ideal sensing), then its plan
    through `tsad verify --world physics`: the same objects move, nothing else falls or is
    disturbed where tsad plan saw it not, and placement errors agree within 5 mm."""
    save_scenario(load_scene("1", 0), tmp_path / "scene.yaml")
    code, _, err = invoke(capsys, ["plan", "--scenario", tmp_path / "scene.yaml", "--planner",
                                   "tsad", "--feasibility", "geometric", "--sensor", "ideal",
                                   "--segmentation", "label", "--world", "physics",
                                   "--out", tmp_path / "plan"])
    assert code == 0, err
    planned = json.loads((tmp_path / "plan" / "plan.json").read_text())
    (code, out, _), report = _verify(tmp_path, capsys, tmp_path / "plan" / "plan.tsad.json",
                                     "--world", "physics")
    assert code == 0, out
    assert len(report["actions"]) == len(planned["actions"]) >= 1
    for simulated, verified in zip(planned["actions"], report["actions"], strict=True):
        a, b = simulated["physics"], verified["world"]
        assert (a["moved"], a["fallen"], a["disturbed"]) == (b["moved"], b["fallen"],
                                                              b["disturbed"]), (a, b)
        assert abs(a["placement_error_mm"] - b["placement_error_mm"]) < 5.0
    assert report["retrieval"]["world"]["retrieved"] == planned["success"]
    for name in ("replay.html", "planned_replay.html", "scene.dmd.yaml"):
        assert (tmp_path / "out" / name).stat().st_size > 0


def test_set_changes_the_motion_settings_verification_runs_with(tmp_path, capsys):
    """--set reaches the motion planner: a held-object clearance wider than the gap between the
    shelf's side wall and where `front` is placed refuses the first action; an unknown field is
    one line, exit 2 and nothing written."""
    path = _write(tmp_path, plan_json(small_scene(), GOOD[:1]))
    (code, _, _), report = _verify(tmp_path, capsys, path, "--set", "motion.held_clearance=0.08")
    assert code == 1 and report["actions"][0]["status"] == "refused"
    assert report["actions"][0]["cause"]["kind"] == "clearance"
    code, _, err = invoke(capsys, ["verify", path, "--set", "motion.bogus=1",
                                   "--out", tmp_path / "bad"])
    assert_clean((code, "", err), codes=(2,))
    assert "motion.bogus" in err and not (tmp_path / "bad").exists()
