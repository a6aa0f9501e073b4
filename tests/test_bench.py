"""Bench runner: rows stream to disk, a rerun resumes, stale rows are never mixed in."""

import json

from tsad_drake.bench.runner import SPEC_KEYS, EpisodeSpec, run_bench


def _specs(seeds):
    # scenario 3: its seeds 0 and 1 generate in under a second (scenario 1 seed 0 takes ~13 s)
    return [EpisodeSpec(scenario="3", seed=s, planner="gp3", feasibility="geometric")
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

    # the cut-off line was ended before the new row was appended, so every row reads back
    from tsad_drake.bench.runner import _load_rows

    lines = rows_path.read_text().splitlines()
    assert json.loads(lines[-1]) == third["rows"][1]
    assert set(_load_rows(rows_path, _specs([0, 1]))) == {0, 1}
    # a row from before rows recorded their scene's digest cannot be matched: it is run again
    undigested = {k: v for k, v in json.loads(lines[-1]).items() if k != "scene_digest"}
    rows_path.write_text(lines[0] + "\n" + json.dumps(undigested) + "\n")
    assert set(_load_rows(rows_path, _specs([0, 1]))) == {0}


def test_rows_of_other_network_weights_are_run_again(tmp_path):
    """A `--feasibility net` row records the shipped weights' digest; resuming keeps the rows of
    these weights and drops those of other weights or with no digest (read back without running
    an episode)."""
    from tsad_drake.bench.episodes import spec_scenario, weights_digest
    from tsad_drake.bench.runner import _load_rows
    from tsad_drake.scenario import scene_digest

    specs = [EpisodeSpec(scenario="3", seed=s, planner="tsad", feasibility="net") for s in (0, 1)]
    rows_path = tmp_path / "net.json.rows.jsonl"
    rows = [{**dict(zip(SPEC_KEYS, spec.key())), "seed": spec.seed,
             "scene_digest": scene_digest(spec_scenario(spec)), "weights_digest": digest}
            for spec, digest in zip(specs, (weights_digest(), "000000000000"))]
    undigested = {**rows[1], "weights_digest": None}  # a row from before rows recorded it
    rows_path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert len(weights_digest()) == 12
    assert set(_load_rows(rows_path, specs)) == {0}
    rows_path.write_text("".join(json.dumps(r) + "\n" for r in (rows[0], undigested)))
    assert set(_load_rows(rows_path, specs)) == {0}
