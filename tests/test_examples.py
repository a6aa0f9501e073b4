"""The README's Python example and the scripts in examples/ run, and what they plug in works."""

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from tsad_drake.execution.world import GeometricWorld
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.planning.feasibility import GeometricFeasibility
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.scenes import generate_scenario

ROOT = Path(__file__).resolve().parent.parent


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "examples" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readme_python_example_runs():
    text = (ROOT / "README.md").read_text()
    code = re.search(r"## Python.*?```python\n(.*?)```", text, re.S).group(1)
    assert len(code.strip().splitlines()) <= 12
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=600, cwd=ROOT)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "target retrieved" in run.stdout


def test_own_feasibility_model_agrees_with_the_geometric_model_and_places_soundly():
    example = _load("own_feasibility_model")
    scenario = generate_scenario("3", 1)
    workspace = make_workspace(scenario)
    state = state_from_perception(observe_raycast(scenario).scene)
    own, geometric = example.PointCorridorModel(workspace), GeometricFeasibility(workspace)
    pairs = [(a, b) for i in range(len(state.objects))
             for a, b in zip(own.blockers(state, i), geometric.blockers(state, i))]
    assert np.mean([a == b for a, b in pairs]) >= 0.8
    # the interface's default placement answers, judged by the world on the true shapes
    i = next(i for i, o in enumerate(state.objects)
             if o.name != state.target and own.pickable(state, i).any())
    theta = float(workspace.approach_angles[int(np.argmax(own.pickable(state, i)))])
    options = own.place_options(state, i, theta)
    assert np.isfinite(options).any()
    cell, theta_place = own.first_place_option(state, i, theta, list(range(len(options))))
    assert theta_place == options[cell] and np.isnan(options[:cell]).all()
    from tsad_drake.planning.types import Action

    x, y = workspace.cell_centres[cell]
    world = GeometricWorld(scenario)
    outcome = world.execute(Action(state.objects[i].name, theta, float(x), float(y), theta_place))
    assert outcome.moved and not outcome.fallen


def test_own_planner_runs_a_closed_loop_episode_without_falls():
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "own_planner.py"),
                          "--scenario", "3", "--seed", "1"], capture_output=True, text=True,
                         timeout=600, cwd=ROOT)
    assert run.returncode == 0, run.stderr[-2000:]
    assert re.search(r"greedy on scenario 3 seed 1: success (True|False), \d+ actions, 0 falls",
                     run.stdout), run.stdout


def test_plan_yaml_scene_plans_a_scene_written_by_tsad_scene(tmp_path):
    from frozen_scenes import load_scene

    from tsad_drake.scenario import save_scenario

    save_scenario(load_scene("1", 1), tmp_path / "scene.yaml")
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "plan_yaml_scene.py"),
                          str(tmp_path / "scene.yaml")], capture_output=True, text=True,
                         timeout=600, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert re.search(r": target retrieved; \d+ actions: obj", run.stdout), run.stdout


def test_sweep_parameter_changes_the_search_it_names():
    example = _load("sweep_parameter")
    from frozen_scenes import load_scene

    rows = example.sweep("iterations", [20, 40], {0: load_scene("1", 0)}, "paper")
    assert [r["value"] for r in rows] == [20, 40]
    # the paper variant runs each sub-search for exactly the swept number of iterations
    for r in rows:
        assert r["sub_search_iterations"] and set(r["sub_search_iterations"]) == {r["value"]}


def test_verify_hand_made_plan_writes_and_verifies_its_plan(tmp_path):
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "verify_hand_made_plan.py"),
                          str(tmp_path / "out")], capture_output=True, text=True, timeout=600,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.splitlines()[-1] == "plan verified", run.stdout
    import json

    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert [a["status"] for a in report["actions"]] == ["verified", "verified"]
    assert report["retrieval"]["world"]["retrieved"]


def test_pddl_steps_become_a_plan_tsad_verify_reads(tmp_path):
    import math

    import pytest

    from tsad_drake.plan_format import load_plan, plan_json
    from tsad_drake.planning.types import Action
    from tsad_drake.scenario import save_scenario

    example = _load("pddl_to_plan")
    actions, retrieve = example.pddl_actions(
        "(pick obj2 0.0) (place obj2 0.10 -0.05 0.3)\n(pick obj0 -0.17) (place obj0 0.07 0.2 0)"
        " (retrieve target)")
    assert actions == [Action("obj2", 0.0, 0.10, -0.05, 0.3), Action("obj0", -0.17, 0.07, 0.2, 0.0)]
    assert retrieve
    for bad in ("(pick obj2 0.0)", "(place obj2 0.1 0.1 0)", "(pick obj2 0) (place obj3 0 0 0)",
                "(pick obj2 zero)", "(retrieve t) (pick a 0)", "pick obj2 0", ""):
        with pytest.raises(ValueError):
            example.pddl_actions(bad)
    from frozen_scenes import load_scene

    scenario = load_scene("1", 0)
    save_scenario(scenario, tmp_path / "scene.yaml")
    names = [o.name for o in scenario.objects if o.name != scenario.target]
    (tmp_path / "steps.txt").write_text(f"(pick {names[0]} 0.0) (place {names[0]} 0.10 -0.05 0.3)")
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "pddl_to_plan.py"), "steps.txt",
                          "scene.yaml", "plan.tsad.json"], capture_output=True, text=True,
                         timeout=600, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    plan = load_plan(tmp_path / "plan.tsad.json")
    (action,) = plan.actions
    assert (action.object, action.theta_pick, action.x, action.y) == (names[0], 0.0, 0.10, -0.05)
    assert math.isclose(action.theta_place, 0.3, abs_tol=1e-12) and not plan.retrieve_target
    assert plan.scenario.objects == scenario.objects
    # the degrees in the file round-trip to the radians of the steps
    assert math.isclose(plan_json(scenario, plan.actions)["actions"][0]["theta_place_deg"],
                        math.degrees(0.3), abs_tol=1e-6)
