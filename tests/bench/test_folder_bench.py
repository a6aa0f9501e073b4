"""`tsad bench --scenario DIR`: one episode per scene file of a folder (file i with seed K+i),
resumable by (scene file, seed), refused with one line before any work; `tsad report` names the
folder."""

import json
import shutil

import pytest
from cli_harness import assert_clean, invoke

from tsad_drake.bench import runner
from tsad_drake.bench.runner import EpisodeSpec, rows_path_of, run_spec
from tsad_drake.cli import main
from tsad_drake.pipeline import EpisodeSettings
from tsad_drake.scenario import save_scenario
from tsad_drake.scenes import generate_scenario

#: the folder's scene files in name order and the scenario-3 seeds that made them (three scenes
#: that generate in under a second, each planned differently by `optimal`), written out of order
SCENES = {"a.yaml": 1, "b.yaml": 0, "c.yml": 2}
SEED_START = 7
#: a fast bench: the exhaustive planner on the oracle model, ray-cast observer, ideal sensing
FLAGS = ["--planner", "optimal", "--seed-start", str(SEED_START)]


def _bench_argv(folder, out, *extra) -> list[str]:
    return ["-q", "bench", "--scenario", str(folder), *FLAGS, *extra, "--out", str(out)]


def _outcome(row: dict) -> tuple:
    """What an episode planned and how it ended (not its timings)."""
    return (row["success"], row["num_actions"], row["falls"],
            [(a["object"], a["place_xy"]) for a in row["actions"]])


@pytest.fixture(scope="module")
def folder_bench(tmp_path_factory):
    """A folder of three scene files (plus a text file and a subfolder a bench ignores), benched
    once: (folder, out, document)."""
    root = tmp_path_factory.mktemp("folder_bench")
    folder = root / "scenes"
    (folder / "sub").mkdir(parents=True)
    for name in ("c.yml", "b.yaml", "a.yaml"):
        save_scenario(generate_scenario("3", SCENES[name]), folder / name)
    (folder / "notes.txt").write_text("not a scene\n")
    (folder / "sub" / "deeper.yaml").write_text("objects: [{name: a, size: [0.1\n")  # not read
    out = root / "out" / "bench.json"
    assert main(_bench_argv(folder, out)) == 0
    return folder, out, json.loads(out.read_text())


def test_folder_bench_runs_one_row_per_scene_file(folder_bench):
    folder, out, document = folder_bench
    names = list(SCENES)
    assert document["spec"]["scenario"] == str(folder.resolve())
    assert document["scenes"] == names
    assert document["seeds"] == [SEED_START, SEED_START + 1, SEED_START + 2]
    rows = document["rows"]
    assert [r["scene_file"] for r in rows] == names
    assert [r["seed"] for r in rows] == document["seeds"]
    assert [r["scenario"] for r in rows] == [str(folder.resolve() / n) for n in names]
    assert len({r["scene_digest"] for r in rows}) == 3
    assert len(rows_path_of(out).read_text().splitlines()) == 3
    # each row ran its own file: the same plan as that file benched alone with the row's seed
    for row in rows:
        alone = run_spec(EpisodeSpec(str(folder / row["scene_file"]), row["seed"],
                                     EpisodeSettings(planner="optimal", feasibility="oracle")))
        assert _outcome(row) == _outcome(alone), row["scene_file"]
    assert len({json.dumps(_outcome(r)) for r in rows}) == 3  # three different plans


def test_folder_bench_resumes_by_scene_file(folder_bench, tmp_path, capsys, monkeypatch):
    folder = tmp_path / "scenes"
    shutil.copytree(folder_bench[0], folder)
    out = tmp_path / "bench.json"
    ran = []

    def counted(spec):
        ran.append(spec.scene_file)
        return run_spec(spec)

    monkeypatch.setattr(runner, "run_spec", counted)

    def bench(*extra) -> dict:
        ran.clear()
        code, stdout, stderr = invoke(capsys, _bench_argv(folder, out, *extra))
        assert code == 0, stderr
        assert "scenes: scenes/ (" in stdout  # the printed table names the folder
        return json.loads(out.read_text())

    first = bench()
    assert ran == list(SCENES)
    # the same command again: nothing runs, the rows are the first run's
    assert bench()["rows"] == first["rows"] and ran == []
    assert len(rows_path_of(out).read_text().splitlines()) == 3

    # one row's line gone: exactly that scene runs again, with its seed
    lines = rows_path_of(out).read_text().splitlines()
    rows_path_of(out).write_text("".join(line + "\n" for line in lines
                                         if json.loads(line)["scene_file"] != "b.yaml"))
    again = bench()
    assert ran == ["b.yaml"] and again["rows"][1]["seed"] == SEED_START + 1
    assert [_outcome(r) for r in again["rows"]] == [_outcome(r) for r in first["rows"]]
    assert again["rows"][0] == first["rows"][0] and again["rows"][2] == first["rows"][2]

    # a scene file changed since its row: that row is run again on the file as it is now
    save_scenario(generate_scenario("3", SCENES["b.yaml"]), folder / "c.yml")
    rows = bench()["rows"]
    assert ran == ["c.yml"] and rows[2]["scene_digest"] == rows[1]["scene_digest"]

    # --episodes N: the first N files, here both done already
    document = bench("--episodes", "2")
    assert ran == [] and document["scenes"] == ["a.yaml", "b.yaml"]
    assert document["rows"] == rows[:2]


def test_report_names_the_folder(folder_bench, tmp_path, capsys):
    folder, out, _ = folder_bench
    page = tmp_path / "RESULTS.md"
    code, _, stderr = invoke(capsys, ["report", str(out), "--out", str(page)])
    assert code == 0, stderr
    assert f"## Scenario {folder.resolve()}\n" in page.read_text()


def test_bad_folders_are_refused_with_one_line_before_any_work(tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    texts = tmp_path / "texts"
    texts.mkdir()
    (texts / "notes.txt").write_text("not a scene\n")
    broken = tmp_path / "broken"
    broken.mkdir()
    save_scenario(generate_scenario("3", 0), broken / "a.yaml")
    (broken / "b.yaml").write_text("objects: [{name: a, size: [0.1\n")
    out = tmp_path / "out" / "bench.json"
    cases = [(empty, [], "holds no scene file"), (texts, [], "holds no scene file"),
             (broken, [], "b.yaml"), (broken, ["--episodes", "3"], "holds 2 scene files"),
             (broken, ["--occluded"], "a folder of scene files")]
    for folder, extra, said in cases:
        code, stdout, stderr = invoke(capsys, _bench_argv(folder, out, *extra))
        assert_clean((code, stdout, stderr), codes=(2,))
        assert said in stderr, (folder, extra, stderr)
    assert not out.parent.exists()
    # the first file alone loads: a bench of it is not refused for the broken file after it
    assert main(_bench_argv(broken, out, "--episodes", "1")) == 0
    assert json.loads(out.read_text())["scenes"] == ["a.yaml"]
