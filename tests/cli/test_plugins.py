"""Names come from the registries, and a planner of your own registered in one call (a plugin:
examples/own_planner.py registers `greedy`) runs with `tsad plan` and `tsad bench`."""

import json
from pathlib import Path

import pytest
from cli_harness import assert_clean, invoke

from tsad_drake import plugins
from tsad_drake.cli.main import build_parser
from tsad_drake.pipeline import FEASIBILITY_NAMES, OBSERVER_NAMES, WORLD_NAMES
from tsad_drake.planners.tsad.config import VARIANTS
from tsad_drake.planning.registry import ABLATIONS, PLANNERS

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "own_planner.py"
IDEAL = ["--sensor", "ideal", "--segmentation", "label", "--observer", "raycast"]


@pytest.fixture
def greedy_plugin():
    """The example plugin, unregistered again afterwards (other tests see the built-in names)."""
    yield str(EXAMPLE)
    PLANNERS.pop("greedy", None)
    plugins._LOADED.pop(plugins.plugin_reference(str(EXAMPLE)), None)


def _choices(command: str) -> dict[str, tuple]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    return {a.dest: tuple(a.choices) for a in sub._actions if a.choices}


@pytest.mark.parametrize("command", ["plan", "bench", "config"])
def test_argparse_choices_are_the_registries(command):
    choices = _choices(command)
    assert choices["planner"] == tuple(PLANNERS)
    assert choices["variant"] == tuple(VARIANTS) and choices["ablation"] == tuple(ABLATIONS)
    assert choices["world"] == WORLD_NAMES
    if command != "config":
        assert choices["feasibility"] == FEASIBILITY_NAMES
        assert choices["observer"] == OBSERVER_NAMES


def test_a_plugin_planner_plans_and_benches_by_name(tmp_path, capsys, greedy_plugin):
    # scenario 2 seed 1: greedy frees the target (3 relocations) with ideal sensing
    result = invoke(capsys, ["--plugin", greedy_plugin, "plan", "--scenario", "2", "--seed", "1",
                             "--planner", "greedy", *IDEAL, "--out", tmp_path / "plan"])
    assert_clean(result, codes=(0,))
    plan = json.loads((tmp_path / "plan" / "plan.json").read_text())
    assert plan["success"] and plan["num_actions"] >= 2
    assert plan["config"]["planner"] == {"max_moves": 8}  # its own config type, recorded
    assert "greedy" in _choices("plan")["planner"]
    # two workers: each spawned process imports the plugin before it reads its episodes
    out = tmp_path / "bench.json"
    result = invoke(capsys, ["--plugin", greedy_plugin, "bench", "--scenario", "2",
                             "--seed-start", "0", "--episodes", "2", "--workers", "2",
                             "--planner", "greedy", "--out", out])
    assert_clean(result, codes=(0,))
    rows = json.loads(out.read_text())["rows"]
    assert [r["seed"] for r in rows] == [0, 1] and all(r["planner"] == "greedy" for r in rows)
    assert "error" not in rows[0]["failure_reason"] and rows[1]["success"]
    assert rows[1]["num_actions"] == plan["num_actions"]  # the same episode as `plan`


def test_a_missing_or_broken_plugin_is_one_line_and_exit_2(tmp_path, capsys):
    broken = tmp_path / "broken.py"
    broken.write_text("raise RuntimeError('no planner here')\n")
    for name, expected in [(tmp_path / "none.py", "no such file"),
                           (broken, "RuntimeError: no planner here"),
                           ("no_such_module_xyz", "ModuleNotFoundError")]:
        code, out, err = invoke(capsys, ["--plugin", name, "plan", "--scenario", "1",
                                         "--planner", "tsad", "--out", tmp_path / "out"])
        assert_clean((code, out, err))
        assert code == 2 and expected in err
    assert not (tmp_path / "out").exists()
