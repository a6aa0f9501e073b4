"""`tsad sweep`: every grid point x scenario is a bench run with its overrides applied and
recorded; one page with a column per grid point; a malformed grid is refused before any work."""

import json

from cli_harness import assert_clean, invoke

GRID = """planner: gp3
feasibility: oracle
scenarios: ["3"]
seed_start: 0
episodes: 1
set: [planner.safety_stop_s=30]
grid:
  planner.avoid_target_corridor: [false, true]
"""


def test_sweep_runs_every_grid_point_and_writes_one_page(tmp_path, capsys):
    grid = tmp_path / "grid.yaml"
    grid.write_text(GRID)
    result = invoke(capsys, ["-q", "sweep", grid, "--out", tmp_path / "sweep"])
    assert_clean(result, codes=(0,))
    runs = [json.loads((tmp_path / "sweep" / f"3-p{k}.json").read_text()) for k in (0, 1)]
    assert [r["config"]["planner"]["avoid_target_corridor"] for r in runs] == [False, True]
    assert all(r["config"]["planner"]["safety_stop_s"] == 30.0 for r in runs)
    assert runs[0]["spec"]["config_digest"] != runs[1]["spec"]["config_digest"]
    page = (tmp_path / "sweep" / "sweep.md").read_text()
    assert "p0: avoid_target_corridor=false" in page and "p1: avoid_target_corridor=true" in page
    assert (tmp_path / "sweep" / "sweep.png").stat().st_size > 1000
    # a second run resumes: every episode is there, nothing runs again
    again = invoke(capsys, ["-q", "sweep", grid, "--out", tmp_path / "sweep"])
    assert_clean(again, codes=(0,))
    rows = (tmp_path / "sweep" / "3-p0.json.rows.jsonl").read_text().splitlines()
    assert len(rows) == 1


def test_bad_grids_are_one_line_and_exit_2_before_work(tmp_path, capsys):
    bad = {"no-grid": "planner: gp3\n",
           "empty-values": "planner: gp3\ngrid: {planner.iterations: []}\n",
           "unknown-field": "planner: gp3\ngrid: {planner.no_such_field: [1]}\n",
           "wrong-type": "planner: gp3\ngrid: {planner.iterations: [fast]}\n",
           "unknown-key": "planner: gp3\nepisodez: 3\ngrid: {planner.iterations: [1]}\n",
           "bad-planner": "planner: gpt\ngrid: {planner.iterations: [1]}\n",
           "not-yaml": "grid: [\n"}
    for name, text in bad.items():
        grid = tmp_path / f"{name}.yaml"
        grid.write_text(text)
        result = invoke(capsys, ["sweep", grid, "--out", tmp_path / name])
        assert_clean(result, codes=(2,))
        assert not any((tmp_path / name).glob("*.json*")), name
