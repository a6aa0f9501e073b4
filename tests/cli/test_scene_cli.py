"""`tsad scene --settle` and a touching scene through `tsad plan` in both worlds (issue 38's
acceptance)."""

import json

import pytest
from cli_harness import assert_clean, invoke
from touching_scenes import touching_scene

from tsad_drake.scenario import interpenetrations, load_scenario, save_scenario


@pytest.fixture
def touching_yaml(tmp_path):
    path = tmp_path / "touching.yaml"
    save_scenario(touching_scene(), path)
    return path


@pytest.fixture
def deep_yaml(tmp_path):
    path = tmp_path / "deep.yaml"
    save_scenario(touching_scene(-0.002), path)
    return path


PLAN = ["plan", "--planner", "tsad", "--feasibility", "geometric", "--sensor", "ideal",
        "--segmentation", "label"]


def _plan(capsys, scenario, out, *extra):
    result = invoke(capsys, [*PLAN, "--scenario", scenario, "--out", out, *extra])
    assert_clean(result, codes=(0,))
    return json.loads((out / "plan.json").read_text())


def test_touching_scene_plans_and_executes_in_the_geometric_world(touching_yaml, tmp_path,
                                                                  capsys):
    plan = _plan(capsys, touching_yaml, tmp_path / "plan")
    assert plan["success"] and plan["falls"] == 0
    assert [a["object"] for a in plan["actions"]] == ["blocker"]


def test_touching_scene_executes_in_the_physics_world(touching_yaml, tmp_path, capsys):
    """The blocker is lifted off the target it touches, and the target taken out (about 15 s)."""
    plan = _plan(capsys, touching_yaml, tmp_path / "plan", "--world", "physics")
    assert plan["success"] and plan["falls"] == 0
    [action] = plan["actions"]
    assert action["object"] == "blocker" and action["physics"]["moved"]
    assert action["physics"]["disturbed"] == [] and action["physics"]["fallen"] == []
    assert all(m["verified"] for m in plan["motion"])


def test_interpenetration_is_refused_and_settle_fixes_it(deep_yaml, tmp_path, capsys):
    code, _, err = assert_refused = invoke(capsys, [*PLAN, "--scenario", deep_yaml,
                                                    "--out", tmp_path / "p"])
    assert_clean(assert_refused, codes=(2,))
    assert "objects[0] (front_box) and objects[1] (back_box)" in err and "2.0 mm" in err
    out = tmp_path / "settled.yaml"
    code, stdout, _ = invoke(capsys, ["scene", "--settle", deep_yaml, "--out", out])
    assert code == 0
    lines = stdout.splitlines()
    for name, line in zip(("front_box", "back_box", "blocker", "target"), lines, strict=False):
        assert line.startswith(name) and " mm" in line
    assert lines[-1].startswith(f"wrote {out}")
    settled = load_scenario(out)
    assert interpenetrations(settled) == []
    assert [o.name for o in settled.objects] == [o.name for o in touching_scene().objects]


@pytest.mark.parametrize("args, needle", [
    (["--settle", "{missing}"], "not found"),
    (["--settle", "{deep}", "--scenario", "1"], "exactly one of"),
    (["--settle", "{deep}", "--seed", "4"], "--seed"),
    ([], "exactly one of"),
    (["--settle", "{too_deep}"], "too deep to settle"),
])
def test_bad_scene_sources_exit_2_with_one_line(args, needle, deep_yaml, tmp_path, capsys):
    too_deep = tmp_path / "too_deep.yaml"
    scene = touching_scene(-0.002)
    scene.objects[1].x -= 0.01
    save_scenario(scene, too_deep)
    paths = {"missing": tmp_path / "nope.yaml", "deep": deep_yaml, "too_deep": too_deep}
    args = [a.format(**paths) for a in args]
    result = invoke(capsys, ["scene", *args, "--out", tmp_path / "out.yaml"])
    assert_clean(result, codes=(2,))
    assert needle in result[2]
    assert not (tmp_path / "out.yaml").exists()
