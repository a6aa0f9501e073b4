"""Command line: scene writing, and every bad input exits 2 with exactly one line."""

import subprocess
import sys

import pytest
from cli_harness import assert_clean, invoke

from tsad_drake.scenario import load_scenario, save_scenario
from tsad_drake.scenes import generate_scenario


def run_cli(capsys, *args):
    return invoke(capsys, list(args))


def assert_one_line_exit_2(result):
    assert_clean(result, codes=(2,))


def test_scene_writes_loadable_yaml(tmp_path, capsys):
    out = tmp_path / "sub" / "scene.yaml"
    code, stdout, _ = run_cli(capsys, "scene", "--scenario", "2", "--seed", "3", "--out", str(out))
    assert code == 0 and "wrote" in stdout
    assert load_scenario(out) == generate_scenario("2", 3)


@pytest.fixture
def overlapping_yaml(tmp_path):
    scenario = generate_scenario("3", 0)  # quick to generate (scenario 1 seed 0 takes ~13 s)
    scenario.objects[1].x, scenario.objects[1].y = scenario.objects[0].x, scenario.objects[0].y
    path = tmp_path / "overlap.yaml"
    save_scenario(scenario, path)
    return path


def test_bad_inputs_exit_2_with_one_line(tmp_path, capsys, overlapping_yaml):
    malformed = tmp_path / "malformed.yaml"
    malformed.write_text("objects: [{name: a, size: [0.1\n")
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    cases = [
        ["render", "--scenario", "7", "--out", str(tmp_path / "r")],
        ["scene", "--scenario", "nope", "--out", str(tmp_path / "s.yaml")],
        ["render", "--scenario", str(malformed), "--out", str(tmp_path / "r")],
        ["render", "--scenario", str(overlapping_yaml), "--out", str(tmp_path / "r")],
        ["render", "--scenario", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "r")],
        ["scene", "--scenario", "3", "--out", str(blocker / "x" / "scene.yaml")],
        ["render", "--scenario", "3", "--out", str(blocker / "dir")],
        ["render", "--scenario", "3", "--segmentation", "magic", "--out", str(tmp_path / "r")],
        ["plan", "--scenario", "3", "--planner", "astar", "--out", str(tmp_path / "p")],
        ["plan", "--scenario", "3", "--planner", "tsad", "--max-actions", "0",
         "--out", str(tmp_path / "p")],
        ["bench", "--scenario", "3", "--planner", "tsad", "--episodes", "0",
         "--out", str(tmp_path / "b.json")],
        ["bench", "--scenario", str(overlapping_yaml), "--planner", "tsad",
         "--out", str(tmp_path / "b.json")],
        ["report", str(malformed), "--out", str(tmp_path / "report.md")],
        ["frobnicate"],
    ]
    for args in cases:
        assert_one_line_exit_2(run_cli(capsys, *args))
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").iterdir())


def test_console_script_help_and_bad_input():
    exe = [sys.executable, "-m", "tsad_drake.cli"]
    helped = subprocess.run(exe + ["render", "--help"], capture_output=True, text=True)
    assert helped.returncode == 0 and "--segmentation" in helped.stdout
    bad = subprocess.run(exe + ["scene", "--scenario", "9", "--out", "x.yaml"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1


def test_version_quiet_and_verbose(tmp_path, capsys, monkeypatch):
    from tsad_drake import __version__
    from tsad_drake.runtime import VERBOSITY_ENV

    monkeypatch.setenv(VERBOSITY_ENV, "1")  # restored after the test (main() sets it per call)
    code, out, _ = run_cli(capsys, "--version")
    assert code == 0 and out.startswith(f"tsad_drake {__version__} (drake ") and "torch" in out
    assert_one_line_exit_2(run_cli(capsys, "-q", "-v", "scene", "--scenario", "3"))
    scene = tmp_path / "scene.yaml"
    save_scenario(generate_scenario("3", 1), scene)
    plan = ["plan", "--scenario", scene, "--planner", "gp3", "--feasibility", "oracle",
            "--observer", "raycast"]
    code, loud, _ = run_cli(capsys, *plan, "--out", tmp_path / "loud")
    code_q, quiet, _ = run_cli(capsys, "--quiet", *plan, "--out", tmp_path / "quiet")
    assert code == code_q and "1. move" in loud and "1. move" not in quiet
    verdict = [text.splitlines()[-2].rsplit(", planning", 1)[0] for text in (loud, quiet)]
    assert verdict[0] == verdict[1] and quiet.splitlines()[-1].endswith("quiet/plan.json")
    code, out, err = run_cli(capsys, "--verbose", "bench", "--scenario", "3", "--planner", "gp3",
                             "--feasibility", "oracle", "--episodes", "1", "--out",
                             tmp_path / "bench.json")
    assert code == 0 and "seed 0: " in err and " actions, " in err
