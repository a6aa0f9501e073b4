"""`tsad plan --variant paper`: the paper's TSAD from the command line, recorded as such."""

import json

from cli_harness import invoke
from frozen_scenes import load_scene

from tsad_drake.bench.report import _label
from tsad_drake.bench.runner import SPEC_KEYS, EpisodeSpec
from tsad_drake.planning.tsad_config import EXTRAS
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
    doc = _plan_frozen_scene(tmp_path, capsys, ("1", 0), "--variant", "paper")
    assert doc["success"] and doc["variant"] == "paper"
    for record in doc["rounds"]:
        used = record["stats"].get("extras_used", {})
        assert set(used) <= set(EXTRAS) and not any(used.values()), used


def test_bench_rows_of_the_variants_are_kept_apart():
    paper = EpisodeSpec("1", 0, "tsad", "geometric", variant="paper")
    assert "variant" in SPEC_KEYS and paper.key() != EpisodeSpec("1", 0, "tsad", "geometric").key()
    spec = {k: getattr(paper, k) for k in SPEC_KEYS}
    assert _label(spec) == "tsad-paper" and _label({**spec, "variant": "full"}) == "tsad"


def test_plan_with_realistic_sensing_and_cluster_segmentation(tmp_path, capsys):
    doc = _plan_frozen_scene(tmp_path, capsys, ("3", 1), "--sensor", "realistic",
                             "--segmentation", "cluster")
    assert doc["sensor"] == "realistic" and doc["settings"]["segmentation"] == "cluster"
    assert doc["success"], doc["failure_reason"]


def test_physics_with_a_noisy_sensor_is_refused_before_work(tmp_path, capsys):
    code, _, stderr = invoke(capsys, ["plan", "--scenario", "1", "--planner", "tsad",
                                      "--world", "physics", "--sensor", "realistic",
                                      "--out", str(tmp_path / "out")])
    assert code == 2 and "--sensor" in stderr and len(stderr.strip().splitlines()) == 1


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
