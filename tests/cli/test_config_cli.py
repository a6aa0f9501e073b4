"""`--config FILE.yaml`, `--set section.field=value` and `tsad config --dump`: every setting in YAML,
recorded whole in plan.json, and bad input one line with exit status 2 before any work."""

import json

import pytest
from cli_harness import assert_clean, invoke
from frozen_scenes import load_scene

from tsad_drake.bench.report import group_by_scenario
from tsad_drake.bench.runner import SPEC_KEYS, EpisodeSpec
from tsad_drake.pipeline import EpisodeSettings
from tsad_drake.run_config import (
    SECTIONS,
    apply_sets,
    config_digest,
    default_run_config,
    dump_run_config,
    merge_file,
)
from tsad_drake.scenario import save_scenario

#: a small search whose wall-clock cap never binds, so the plan depends on the seed alone
BUDGET = ["--set", "planner.iteration_budget=400", "--set", "planner.safety_stop_s=600"]


def _plan(tmp_path, capsys, out: str, *flags) -> dict:
    """`tsad plan` (TSAD, geometric model, ray-cast observer, open loop: one observation) on
    frozen scene 1/0: plan.json."""
    scene = tmp_path / "scene.yaml"
    if not scene.exists():
        save_scenario(load_scene("1", 0), scene)
    result = invoke(capsys, ["plan", "--scenario", scene, "--planner", "tsad", "--feasibility",
                             "geometric", "--observer", "raycast", "--open-loop", *flags,
                             "--out", tmp_path / out])
    assert_clean(result, codes=(0, 1))
    return json.loads((tmp_path / out / "plan.json").read_text())


def _actions(doc: dict) -> list:
    return [(a["object"], a["theta_pick_deg"], a["place_xy"], a["theta_place_deg"])
            for a in doc["actions"]]


def test_a_dumped_config_plans_the_same_as_the_flags_it_came_from(tmp_path, capsys):
    code, dumped, _ = invoke(capsys, ["config", "--planner", "tsad", "--dump", *BUDGET])
    assert code == 0
    (tmp_path / "run.yaml").write_text(dumped)
    # `tsad config` defaults to ideal sensing (as bench), `tsad plan` to realistic: say so
    ideal = ["--sensor", "ideal", "--segmentation", "label"]
    with_sets = _plan(tmp_path, capsys, "sets", *ideal, *BUDGET)
    with_file = _plan(tmp_path, capsys, "file", *ideal, "--config", tmp_path / "run.yaml")
    assert with_sets["config"]["planner"]["iteration_budget"] == 400
    assert with_file["config"] == with_sets["config"]
    assert with_file["config_digest"] == with_sets["config_digest"]
    assert _actions(with_file) == _actions(with_sets) and with_file["actions"]


def test_set_changes_the_config_recorded_in_plan_json(tmp_path, capsys):
    doc = _plan(tmp_path, capsys, "out", "--set", "planner.iteration_budget=300", "--set",
                "planner.safety_stop_s=600", "--set", "station.camera.width=96")
    assert doc["config"]["planner"]["iteration_budget"] == 300
    assert doc["config"]["station"]["camera"]["width"] == 96
    assert set(doc["config"]) == set(SECTIONS)
    assert doc["config_digest"] != config_digest(default_run_config("tsad"))
    assert "config" not in doc["settings"]  # recorded once


@pytest.mark.parametrize("flags, needle", [
    (["--set", "planner.no_such_field=1"], "no_such_field"),
    (["--set", "brain.iterations=1"], "unknown section 'brain'"),
    (["--set", "planner.iteration_budget=lots"], "iteration_budget"),
    (["--set", "planner.iteration_budget=1.5"], "iteration_budget"),
    (["--set", "planner.iteration_budget"], "section.field=value"),
    (["--set", "station.camera.nope=3"], "nope"),
    (["--set", "world.contact_model=jelly"], "contact_model"),
    (["--config", "missing.yaml"], "cannot read"),
])
def test_bad_config_input_is_one_line_and_exit_2_before_work(tmp_path, capsys, monkeypatch,
                                                             flags, needle):
    monkeypatch.chdir(tmp_path)
    for command in (["plan", "--scenario", "1"], ["bench", "--scenario", "1"], ["config", "--dump"]):
        extra = ["--out", tmp_path / "out"] if command[0] == "plan" else []
        extra += ["--out", tmp_path / "b.json"] if command[0] == "bench" else []
        result = invoke(capsys, [*command, "--planner", "tsad", *flags, *extra])
        assert_clean(result, codes=(2,))
        assert needle in result[2], result[2]
    assert not (tmp_path / "out").exists() and not (tmp_path / "b.json").exists()


def test_a_file_for_another_planner_or_a_malformed_file_is_refused(tmp_path, capsys):
    code, dumped, _ = invoke(capsys, ["config", "--planner", "gp3", "--dump"])
    (tmp_path / "gp3.yaml").write_text(dumped)
    (tmp_path / "bad.yaml").write_text("planner: {iterations: [\n")
    (tmp_path / "list.yaml").write_text("- planner\n")
    for name, needle in (("gp3.yaml", "TSADConfig"), ("bad.yaml", "not valid YAML"),
                         ("list.yaml", "mapping")):
        result = invoke(capsys, ["config", "--planner", "tsad", "--dump", "--config",
                                 tmp_path / name])
        assert_clean(result, codes=(2,))
        assert needle in result[2], result[2]


@pytest.mark.parametrize("flags", [
    ["--planner", "tsad"],
    ["--planner", "tsad", "--variant", "paper", "--sensor", "realistic", "--ablation", "no-re"],
    ["--planner", "rots-star", "--segmentation", "cluster", "--world", "physics"],
    ["--planner", "optimal", "--set", "motion.home_q=[0, -1, 1, 0, 1, 1.5]"],
])
def test_config_dump_round_trips(tmp_path, capsys, flags):
    code, first, _ = invoke(capsys, ["config", "--dump", *flags])
    assert code == 0
    (tmp_path / "c.yaml").write_text(first)
    planner = flags[1]  # the file's planner section is that planner's config
    code, second, _ = invoke(capsys, ["config", "--dump", "--planner", planner, "--config",
                                      tmp_path / "c.yaml"])
    assert code == 0 and second.splitlines()[1:] == first.splitlines()[1:]
    loaded = merge_file(default_run_config(planner), str(tmp_path / "c.yaml"))
    assert dump_run_config(loaded) == "".join(first.splitlines(keepends=True)[1:])


def test_none_values_and_nested_fields_survive_the_round_trip(tmp_path):
    paper = default_run_config("tsad", variant="paper")  # max_iterations and widening are None
    assert paper.planner.extras.max_iterations is None and paper.planner.extras.widening is None
    (tmp_path / "paper.yaml").write_text(dump_run_config(paper))
    assert merge_file(default_run_config("tsad"), str(tmp_path / "paper.yaml")) == paper
    changed = apply_sets(paper, ["planner.extras.widening=2.5", "perception.cloud.voxel_size=0.004"])
    assert changed.planner.extras.widening == 2.5 and changed.perception.cloud.voxel_size == 0.004
    assert config_digest(changed) != config_digest(paper)


def test_bench_keeps_rows_and_report_columns_of_different_configs_apart():
    base = EpisodeSpec("1", 0, EpisodeSettings("gp3", "geometric"))
    other = EpisodeSpec("1", 0, EpisodeSettings(
        "gp3", "geometric",
        config=apply_sets(default_run_config("gp3"), ["planner.iterations=50"])))
    assert "config_digest" in SPEC_KEYS and base.key() != other.key()
    docs = [{"spec": spec.identity()} for spec in (base, other)]
    assert len(group_by_scenario(docs)["1"]) == 2
