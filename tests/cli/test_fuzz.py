"""Property-based tests (hypothesis) of issue 18: mutated scenario YAML and command lines end with
exit 0, 1 or 2, never a traceback, and write nothing outside --out; the writers keep hostile names
inside their directory and escape them in SDFormat and YAML text.

The command-line fuzz replaces the long work behind each command (planning, rendering, episodes,
training) by quick stand-ins that write through the same output helpers: what is under test is
everything the command does before and around that work. `make test` runs a bounded number of
examples with a fixed seed; the `slow` variants run many more.
"""

import contextlib
import copy
import json
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml
from cli_harness import assert_clean, bench_document, changed_outside, invoke, snapshot
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydrake.multibody.parsing import LoadModelDirectives

from tsad_drake.errors import UsageError
from tsad_drake.motion.export import write_scene_directives
from tsad_drake.outputs import OutputDir, atomic_write_text
from tsad_drake.plan_format import plan_json
from tsad_drake.scenario import OBJECT_NAME_PATTERN, RESERVED_NAMES, save_scenario
from tsad_drake.scenes import generate_scenario

FAST = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
LONG = settings(FAST, max_examples=400)

COMMANDS = ("scene", "render", "plan", "bench", "report", "dataset", "train", "net-calibrate",
            "net-eval", "verify")


@pytest.fixture(scope="module")
def scene3():
    return generate_scenario("3", 0)


@pytest.fixture(scope="module")
def base_yaml(scene3, tmp_path_factory) -> dict:
    path = tmp_path_factory.mktemp("base") / "scene.yaml"
    save_scenario(scene3, path)
    return yaml.safe_load(path.read_text())


# -- mutated scenario YAML ---------------------------------------------------------------------
HOSTILE_NAMES = ["../../x", "/abs/x", "a/b", 'a"b', "a<b>", "a::b", "shelf", "ur5e",
                 "gripper_2f85", "world", "", " ", "x" * 300, "caf\u00e9", "a\nb", "yes", "null",
                 "1e3", ".", "..", "obj1", "target"]
VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-(2**70), 2**70),
    st.sampled_from([0, -1, 1, 2**31, 0.0, -0.0, 1e-9, 1e9, math.nan, math.inf, -math.inf]),
    st.sampled_from(HOSTILE_NAMES), st.text(max_size=20), st.booleans(), st.none(),
    st.lists(st.floats(allow_nan=True), max_size=4), st.dictionaries(st.text(max_size=5),
                                                                     st.integers(), max_size=2))


def _paths(data, prefix=()):
    """Every key path in nested YAML data (containers and leaves)."""
    found = [prefix] if prefix else []
    if isinstance(data, dict):
        for key, value in data.items():
            found += _paths(value, (*prefix, key))
    elif isinstance(data, list):
        for index, value in enumerate(data):
            found += _paths(value, (*prefix, index))
    return found


@st.composite
def mutated_scenarios(draw, base: dict) -> dict:
    data = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 3))):
        paths = _paths(data)
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        holder = data
        for key in path[:-1]:
            holder = holder[key]
        if draw(st.booleans()) and isinstance(holder, dict):
            del holder[path[-1]]
        else:
            holder[path[-1]] = draw(VALUES)
    return data


def _check_mutated_yaml(data, cli):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        source = root / "mutated.yaml"
        source.write_text(yaml.safe_dump(data, allow_unicode=True))
        out = root / "out"
        before = snapshot(root)
        result = cli("scene", "--scenario", source, "--out", out / "scene.yaml")
        assert_clean(result, codes=(0, 2))
        if result[0] == 0:  # a valid scene: its motion export stays inside the folder too
            from tsad_drake.scenario import load_scenario

            write_scene_directives(load_scenario(out / "scene.yaml"), out / "export")
        assert changed_outside(before, snapshot(root), [out]) == []


@pytest.fixture
def cli(capsys):
    return lambda *args: invoke(capsys, [str(a) for a in args])


@pytest.mark.parametrize("config", [settings(FAST, max_examples=30),
                                    pytest.param(LONG, marks=pytest.mark.slow)],
                         ids=["bounded", "long"])
def test_mutated_yaml_is_clean(config, base_yaml, cli):
    @config
    @given(mutated_scenarios(base_yaml))
    def check(data):
        _check_mutated_yaml(data, cli)

    check()


# -- command lines -----------------------------------------------------------------------------
class StandIns:
    """Quick stand-ins for the long work behind each command, writing through the real helpers."""

    def __init__(self, scenario):
        self.scenario = scenario

    def generate_scenario(self, name, seed, occluded=False, config=None, camera=None):
        return copy.deepcopy(self.scenario)

    @staticmethod
    def plan_episode(scenario, seed, settings, out_dir=None):
        if settings.motion and out_dir is not None:
            write_scene_directives(scenario, out_dir)
            atomic_write_text(out_dir / "replay.html", "<html></html>")
        from tsad_drake.execution.record import EpisodeRecord

        return EpisodeRecord(scenario.name, seed, settings.planner, settings.feasibility,
                             success=seed % 2 == 0, num_actions=1, theta_star_deg=0.0,
                             failure_reason="" if seed % 2 == 0 else "stand-in",
                             motion_checked=settings.motion,
                             motion=[] if settings.motion else None)

    @staticmethod
    def render_and_write(scenario, out, segmentation="label"):
        out.write_text("segments.json", "{}")

    @staticmethod
    def run_bench(specs, out, workers=1, progress=True, threads=1):
        from tsad_drake.bench.metrics import summarise

        rows = [{"seed": s.seed, "success": True, "num_actions": 1, "falls": 0,
                 "planning_time_s": 0.0} for s in specs]
        document = {"spec": {"scenario": specs[0].scenario, "planner": specs[0].planner},
                    "rows": rows, "summary": summarise(rows)}
        atomic_write_text(out, json.dumps(document))
        return document

    @staticmethod
    def verify_plan(scenario, actions, world="none", retrieve_target=False, keep_going=False,
                    **kwargs):
        from tsad_drake.verification import VerificationReport

        return VerificationReport(scenario.name, world, keep_going, retrieve_target, [], None,
                                  True, "", 0.0)

    @staticmethod
    def write_replay_html(scenario, actions, motions, out_path, **kwargs):
        return atomic_write_text(out_path, "<html></html>")

    @staticmethod
    def generate_dataset(out, scenes, seed_start, observer="raycast", shard_size=20):
        return {"scenes": scenes}

    @staticmethod
    def train(data_dir, out, *args, **kwargs):
        return {"best_val_score": 0.0}

    @staticmethod
    def calibrate_thresholds(weights, scenes=16, **kwargs):
        return {}

    @staticmethod
    def evaluate_scenes(model_factory, scenes, seed_start, observer="raycast", progress=True):
        return {"queries_per_second": 0.0}


@pytest.fixture
def stand_ins(monkeypatch, scene3):
    import tsad_drake.bench.runner as runner
    import tsad_drake.motion.replay as replay
    import tsad_drake.pipeline as pipeline
    import tsad_drake.prehensile.dataset as dataset
    import tsad_drake.prehensile.training as training
    import tsad_drake.render_output as render_output
    import tsad_drake.scenes as scenes
    import tsad_drake.verification as verification

    fake = StandIns(scene3)
    monkeypatch.setattr(scenes, "generate_scenario", fake.generate_scenario)
    monkeypatch.setattr(pipeline, "plan_episode", fake.plan_episode)
    monkeypatch.setattr(render_output, "render_and_write", fake.render_and_write)
    monkeypatch.setattr(runner, "run_bench", fake.run_bench)
    monkeypatch.setattr(dataset, "generate_dataset", fake.generate_dataset)
    monkeypatch.setattr(verification, "verify_plan", fake.verify_plan)
    monkeypatch.setattr(replay, "write_replay_html", fake.write_replay_html)
    for name in ("train", "calibrate_thresholds", "evaluate_scenes"):
        monkeypatch.setattr(training, name, getattr(fake, name))
    return fake


#: option -> values to draw from ({tmp} is the example's folder, {cwd} relative paths start there)
PATHS = ["{tmp}/out", "{tmp}/out/file.json", "{tmp}/out/sub/deeper/x.yaml", "{tmp}/out/notes.txt",
         "{tmp}/out/bench.json", "{tmp}/out/w.pt", "{tmp}/out/..", "out/rel", "../../up",
         "../../../../escape", "", ".", "/dev/full", "/dev/null/x", "{tmp}/inputs/scene.yaml",
         "{tmp}/inputs/bench.json", "{tmp}/inputs/garbage.bin", "{tmp}/inputs"]
NUMBERS = ["0", "1", "2", "-1", "3", "7", "100000", str(2**31), "1e9", "nan", "inf", "-inf", "1.5",
           "abc", "", "0x10"]
OPTIONS = {
    "--scenario": ["1", "2", "3", "real", "7", "", "{tmp}/inputs/scene.yaml",
                   "{tmp}/inputs/garbage.bin", "{tmp}/inputs/missing.yaml", "../../x.yaml"],
    "--seed": NUMBERS, "--seed-start": NUMBERS, "--episodes": NUMBERS, "--workers": NUMBERS,
    "--threads": NUMBERS, "--max-actions": NUMBERS, "--scenes": NUMBERS, "--shard-size": NUMBERS,
    "--epochs": NUMBERS, "--batch": NUMBERS, "--lr": NUMBERS, "--max-minutes": NUMBERS,
    "--planner": ["tsad", "gp3", "rots", "rots-star", "rots-star-search", "optimal", "astar"],
    "--feasibility": ["net", "geometric", "oracle", "magic"],
    "--ablation": ["none", "no-ro", "no-re", "all"], "--observer": ["raycast", "drake", "eyes"],
    "--segmentation": ["label", "cluster", "magic"], "--out": PATHS, "--data": PATHS,
    "--weights": PATHS, "--world": ["none", "geometric", "physics", "mars"],
    "--config": PATHS, "--set": ["motion.lift=0.05", "motion.bogus=1", "nodot", "motion.lift=[",
                                 "planner.iteration_budget=-3", "world.dt=abc"],
}
FLAGS = ["--occluded", "--motion", "--open-loop", "--keep-going", "--help"]


@st.composite
def command_lines(draw) -> list[str]:
    args = [draw(st.sampled_from(COMMANDS))]
    for _ in range(draw(st.integers(0, 7))):
        if draw(st.integers(0, 4)) == 0:
            args.append(draw(st.sampled_from(FLAGS)))
        else:
            option = draw(st.sampled_from(sorted(OPTIONS)))
            args += [option, draw(st.sampled_from(OPTIONS[option]))]
    if args[0] == "report":
        args += draw(st.lists(st.sampled_from(PATHS), max_size=2))
    if args[0] == "verify":
        args += draw(st.lists(st.sampled_from(["{tmp}/inputs/plan.json", *PATHS]), max_size=2))
    return args


def _allowed_outputs(args: list[str], cwd: Path) -> list[Path]:
    """Where a command may write: each --out (or --weights, updated in place) given, the files a
    command writes beside a file output, and plan's and verify's default folders."""
    given_paths = [Path(args[i + 1]) for i, a in enumerate(args[:-1]) if a in ("--out", "--weights")]
    allowed = [cwd / "out" / "plan", cwd / "out" / "verify"]
    for path in given_paths:
        path = path if path.is_absolute() else cwd / path
        allowed += [path, path.with_suffix(".json"), path.with_suffix(".png"),
                    path.with_name(path.name + ".rows.jsonl")]
    return [Path(os.path.normpath(a)) for a in allowed]


def _check_command_line(template: list[str], cli, scenario) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        inputs = root / "inputs"
        inputs.mkdir()
        (inputs / "garbage.bin").write_bytes(bytes(range(256)))
        (inputs / "bench.json").write_text(json.dumps(bench_document()))
        save_scenario(scenario, inputs / "scene.yaml")
        (inputs / "plan.json").write_text(json.dumps(plan_json("scene.yaml", [])))
        (root / "out").mkdir()
        (root / "out" / "notes.txt").write_text("unrelated")
        cwd = root / "cwd" / "a" / "b" / "c" / "d"  # relative paths with ../ stay inside root
        cwd.mkdir(parents=True)
        args = [a.replace("{tmp}", tmp) for a in template]
        before = snapshot(root)
        with contextlib.chdir(cwd):
            result = cli(*args)
        assert_clean(result, codes=(0, 1, 2))
        changed = changed_outside(before, snapshot(root), _allowed_outputs(args, cwd))
        assert changed == [], (args, changed)


@pytest.mark.parametrize("config", [FAST, pytest.param(LONG, marks=pytest.mark.slow)],
                         ids=["bounded", "long"])
def test_command_lines_are_clean(config, stand_ins, cli):
    @config
    @given(command_lines())
    def check(args):
        _check_command_line(args, cli, stand_ins.scenario)

    check()


# -- writers with hostile names -----------------------------------------------------------------
NAME_TEXT = st.text(st.characters(blacklist_categories=("Cs", "Cc")) | st.sampled_from(
    list("/\\.:\"'<>&\n\t ")), max_size=40)
#: hostile text, names YAML would read as other types, and valid identifiers
OBJECT_NAMES = NAME_TEXT | st.sampled_from(["yes", "no", "null", "true", "on", "e1", "inf", "nan",
                                            "shelf", "World", "obj1"]) | st.from_regex(
    OBJECT_NAME_PATTERN, fullmatch=True)


def _check_output_dir(name: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        folder = OutputDir(root / "out")
        (root / "out").mkdir()
        try:
            path = folder.write_text(name, "content")
        except UsageError:
            path = None
        except OSError:  # a name the file system refuses (too long in bytes)
            path = None
        files = [p for p in root.rglob("*") if p.is_file()]
        assert all(p.parent == root / "out" for p in files), files
        assert not any(p.name.startswith(".") and ".tmp-" in p.name for p in files)
        if path is not None:
            assert files == [path] and path.read_text() == "content"


def dc_replace_name(scenario, name: str):
    """A copy of `scenario` whose second object is called `name` (not validated)."""
    scenario = copy.deepcopy(scenario)
    scenario.objects[1].name = name
    return scenario


def _check_scene_export(scene3, name: str) -> None:
    scenario = dc_replace_name(scene3, name)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        out = root / "out"
        try:
            write_scene_directives(scenario, out)
        except UsageError:
            assert not OBJECT_NAME_PATTERN.fullmatch(name) or name.lower() in RESERVED_NAMES
        else:
            sdf = ET.parse(out / f"{name}.sdf").getroot()
            assert sdf.find("model").get("name") == name
            directives = LoadModelDirectives(str(out / "scene.dmd.yaml")).directives
            assert name in [d.add_model.name for d in directives if d.add_model]
        files = [p for p in root.rglob("*") if p.is_file()]
        assert all(p.parent == out for p in files), files


def test_output_dir_keeps_hostile_names_inside():
    for name in ["../x", "../../x", "/abs/x", "a/b", "..", ".", "", "a\0b", "x" * 300]:
        with pytest.raises(UsageError):
            OutputDir(tempfile.gettempdir()).path(name)

    @FAST
    @given(NAME_TEXT)
    def check(name):
        _check_output_dir(name)

    check()


def test_scene_export_escapes_and_contains_hostile_names(scene3):
    for name in ("yes", "null", "e1", "inf", "box_7"):  # YAML would read these unquoted as others
        _check_scene_export(scene3, name)
    for name in ("../../x", "/abs/x", 'a"b', "a<b", "a::b", "shelf"):
        with pytest.raises(UsageError):
            write_scene_directives(dc_replace_name(scene3, name), tempfile.gettempdir())

    @settings(FAST, max_examples=15)
    @given(OBJECT_NAMES)
    def check(name):
        _check_scene_export(scene3, name)

    check()


@pytest.mark.slow
def test_writers_long(scene3):
    @LONG
    @given(OBJECT_NAMES)
    def check(name):
        _check_output_dir(name)
        _check_scene_export(scene3, name)

    check()
