"""Bench runner: rows stream to disk, a rerun resumes, stale rows are never mixed in."""

import json

from tsad_drake.bench.runner import EpisodeSpec, run_bench


def _specs(seeds):
    return [EpisodeSpec(scenario="1", seed=s, planner="gp3", feasibility="geometric")
            for s in seeds]


def test_rerun_resumes_and_reruns_rows_of_another_scene(tmp_path):
    out = tmp_path / "gp3.json"
    rows_path = tmp_path / "gp3.json.rows.jsonl"
    first = run_bench(_specs([0, 1]), out, progress=False)
    assert [r["seed"] for r in first["rows"]] == [0, 1]
    assert all(len(r["scene_digest"]) == 12 for r in first["rows"])
    assert len(rows_path.read_text().splitlines()) == 2

    # same settings again: nothing is run, the document is rebuilt from the rows
    again = run_bench(_specs([0, 1]), out, progress=False)
    assert len(rows_path.read_text().splitlines()) == 2
    assert again["rows"] == first["rows"]

    # a row whose scene an older generator made (other digest) and a line cut off mid-write
    lines = rows_path.read_text().splitlines()
    stale = json.loads(lines[1])
    stale["scene_digest"] = "000000000000"
    stale["num_actions"] = 99
    rows_path.write_text(lines[0] + "\n" + json.dumps(stale) + "\n" + '{"seed": 1, "succ')
    third = run_bench(_specs([0, 1]), out, progress=False)
    assert third["rows"][0] == first["rows"][0]  # kept
    assert third["rows"][1]["num_actions"] != 99  # run again on the current scene
    assert third["rows"][1]["scene_digest"] == first["rows"][1]["scene_digest"]
    assert json.loads(out.read_text())["summary"]["episodes"] == 2
