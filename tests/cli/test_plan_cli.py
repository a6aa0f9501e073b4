"""`tsad plan --variant paper`: the paper's TSAD from the command line, recorded as such."""

import json

from cli_harness import invoke
from frozen_scenes import load_scene

from tsad_drake.bench.report import _label
from tsad_drake.bench.runner import SPEC_KEYS, EpisodeSpec
from tsad_drake.pipeline import EpisodeSettings
from tsad_drake.planners.tsad.config import EXTRAS
from tsad_drake.scenario import save_scenario


def _plan_frozen_scene(tmp_path, capsys, key: tuple[str, int], *flags: str) -> dict:
    """`tsad plan` (TSAD, geometric model, ray-cast observer) on a frozen scene: plan.json."""
    save_scenario(load_scene(*key), tmp_path / "scene.yaml")
    code, _, stderr = invoke(capsys, ["plan", "--scenario", tmp_path / "scene.yaml", "--planner",
                                      "tsad", "--feasibility", "geometric", "--observer",
                                      "raycast", *flags, "--out", tmp_path / "out"])
    assert code in (0, 1), stderr
    return json.loads((tmp_path / "out" / "plan.json").read_text())


def test_plan_with_the_paper_variant_uses_no_extra(tmp_path, capsys):
    doc = _plan_frozen_scene(tmp_path, capsys, ("1", 0), "--variant", "paper", "--sensor", "ideal",
                             "--segmentation", "label")
    assert doc["success"] and doc["variant"] == "paper"
    for record in doc["rounds"]:
        used = record["stats"].get("extras_used", {})
        assert set(used) <= set(EXTRAS) and not any(used.values()), used


def test_bench_rows_of_the_variants_are_kept_apart():
    paper = EpisodeSpec("1", 0, EpisodeSettings("tsad", "geometric", variant="paper"))
    full = EpisodeSpec("1", 0, EpisodeSettings("tsad", "geometric"))
    assert "variant" in SPEC_KEYS and paper.key() != full.key()
    spec = paper.identity()
    assert _label(spec) == "tsad-paper" and _label({**spec, "variant": "full"}) == "tsad"


def test_plan_observes_as_a_robot_by_default(tmp_path, capsys):
    """`tsad plan` without sensing flags: the realistic sensor (eight fused frames per view) and
    cluster segmentation; the frozen scene's target is still retrieved."""
    doc = _plan_frozen_scene(tmp_path, capsys, ("3", 1))
    assert doc["sensor"] == "realistic" and doc["settings"]["segmentation"] == "cluster"
    assert doc["config"]["sensor"]["frames"] == 8
    assert doc["success"], doc["failure_reason"]


def test_physics_world_plans_through_the_realistic_sensor(tmp_path, capsys):
    """`--world physics --sensor realistic`: the physics world's renders go through the sensor
    model and cluster segmentation; a one-blocker scene is still retrieved."""
    from tsad_drake.scenario import ObjectConfig, Scenario

    scene = Scenario(name="blocked", objects=[
        ObjectConfig(name="target", shape="cylinder", size=[0.03, 0.13], x=0.24, y=0.0),
        ObjectConfig(name="front", shape="cylinder", size=[0.03, 0.17], x=0.10, y=0.0),
        ObjectConfig(name="side", kind="square_pillar", shape="box", size=[0.045, 0.045, 0.15],
                     x=0.22, y=0.15)], target="target")
    path = tmp_path / "scene.yaml"
    save_scenario(scene, path)
    code, _, stderr = invoke(capsys, ["plan", "--scenario", str(path), "--seed", "0",
                                      "--planner", "tsad", "--feasibility", "geometric",
                                      "--world", "physics", "--sensor", "realistic",
                                      "--segmentation", "cluster", "--out", str(tmp_path / "out")])
    doc = json.loads((tmp_path / "out" / "plan.json").read_text())
    assert code == 0, stderr
    assert doc["world"] == "physics" and doc["sensor"] == "realistic"
    assert doc["settings"]["segmentation"] == "cluster" and doc["success"]
    assert all("physics" in a for a in doc["actions"])


def test_plan_with_meshcat_serves_the_scene_and_its_motion(tmp_path, capsys, monkeypatch):
    import urllib.request

    from tsad_drake.cli import plan as plan_cli

    served = {}

    def keep(meshcat):  # instead of waiting for Enter: look at what Meshcat holds, while it runs
        with urllib.request.urlopen(meshcat.web_url(), timeout=10) as page:
            served["status"] = page.status
        served["paths"] = [meshcat.HasPath(f"/drake/visualizer/{name}") for name in
                           ("ur5e", "gripper_2f85", "shelf", "obj1")]
        served["animation"] = len(meshcat.StaticHtml())

    monkeypatch.setattr(plan_cli, "hold_meshcat", keep)
    save_scenario(load_scene("3", 1), tmp_path / "scene.yaml")
    code, out, stderr = invoke(capsys, ["plan", "--scenario", tmp_path / "scene.yaml", "--planner",
                                        "gp3", "--feasibility", "oracle", "--observer", "raycast",
                                        "--max-actions", "2", "--meshcat", "--out", tmp_path / "o"])
    assert code in (0, 1), stderr
    assert out.startswith("meshcat: http://localhost:")  # printed before planning starts
    assert served["status"] == 200 and all(served["paths"]), served
    doc = json.loads((tmp_path / "o" / "plan.json").read_text())
    assert doc["motion"] and (tmp_path / "o" / "replay.html").stat().st_size > 10_000
