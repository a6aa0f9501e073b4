"""Bench runner: rows stream, runs resume, episodes that raise become failure rows; report page."""

import json

import pytest

from tsad_drake.bench.metrics import paper_table, summarise
from tsad_drake.bench.report import write_report
from tsad_drake.bench.runner import SPEC_KEYS, EpisodeSpec, run_bench
from tsad_drake.pipeline import EpisodeSettings


def _specs(planner, seeds, feasibility="oracle"):
    # scenario 3: its seeds 0 and 1 generate in under a second (scenario 1 seed 0 takes ~13 s)
    return [EpisodeSpec("3", s, EpisodeSettings(planner=planner, feasibility=feasibility))
            for s in seeds]


def test_resume_skips_finished_seeds_and_errors_are_rows(tmp_path):
    out = tmp_path / "bench.json"
    rows_path = tmp_path / "bench.json.rows.jsonl"
    from tsad_drake.bench.runner import spec_scenario
    from tsad_drake.scenario import scene_digest

    # a finished row from an "interrupted" earlier run (same scene), marked so we can see it is
    # reused
    specs = _specs("no-such-planner", [0, 1])
    earlier = {"scenario": "3", "planner": "no-such-planner", "feasibility": "oracle",
               "ablation": "none", "observer": "raycast", "occluded": False, "closed_loop": True,
               "seed": 0, "success": True, "num_actions": 3, "falls": 0,
               "planning_time_s": 0.5, "marker": "reused",
               "scene_digest": scene_digest(spec_scenario(specs[0]))}
    rows_path.write_text(json.dumps(earlier) + "\n" + '{"truncated": ')
    document = run_bench(specs, out, progress=False)
    rows = {r["seed"]: r for r in document["rows"]}
    assert rows[0]["marker"] == "reused"
    assert not rows[1]["success"]
    assert rows[1]["failure_reason"].startswith("error: ValueError: unknown planner")
    assert document["summary"]["episodes"] == 2
    assert document["summary"]["success_rate"] == 0.5
    assert document["summary"]["errors"] == 1
    assert json.loads(out.read_text())["summary"] == document["summary"]


def test_real_episodes_and_report(tmp_path):
    out = tmp_path / "s3-gp3.json"
    document = run_bench(_specs("gp3", [0, 1]), out, progress=False)
    for row in document["rows"]:
        assert row["num_actions"] >= 1 and row["planner"] == "gp3"
        assert row["initial_rearrangement_set_size"] >= 1
        assert row["success"] == (row["failure_reason"] == "")
    table = paper_table({"gp3": document["summary"]})
    assert "Success Rate" in table and "Avg. of Falls" in table
    page = tmp_path / "RESULTS.md"
    write_report([document], page)
    assert "## Scenario 3" in page.read_text()
    assert page.with_suffix(".png").stat().st_size > 1000
    assert "3" in json.loads(page.with_suffix(".json").read_text())


def test_summary_separates_successful_and_all_episodes():
    rows = [{"success": True, "num_actions": 3, "falls": 0, "planning_time_s": 1.0},
            {"success": False, "num_actions": 7, "falls": 2, "planning_time_s": 3.0,
             "failure_reason": "target fell"}]
    s = summarise(rows)
    assert s["success_rate"] == 0.5
    assert s["actions_success"] == 3 and s["actions_all"] == 5
    assert s["falls_success"] == 0 and s["falls_all"] == 1
    assert s["planning_time_median_s"] == 2.0
    assert s["failure_reasons"] == {"target fell": 1}


def _document(planner: str, outcomes: list[tuple[bool, int]], feasibility: str = "geometric",
              time_s: float = 1.0, scenario: str = "2") -> dict:
    rows = [{"seed": seed, "success": ok, "num_actions": n, "falls": 0, "planning_time_s": time_s,
             "optimal_finished": planner == "optimal" and ok,
             "failure_reason": "" if ok else "planning failed: sub-search 0"}
            for seed, (ok, n) in enumerate(outcomes)]
    return {"spec": {"scenario": scenario, "planner": planner, "feasibility": feasibility},
            "rows": rows, "summary": summarise(rows)}


def test_report_says_which_targets_are_missed_by_how_much_and_why(tmp_path):
    # 10 scenes: optimal solves 8 with 4 actions each; TSAD solves 7 of those with 5 actions
    optimal = _document("optimal", [(True, 4)] * 8 + [(False, 0)] * 2, "oracle")
    tsad = _document("tsad", [(True, 5)] * 7 + [(False, 12)] * 3, time_s=6.0)
    baselines = [_document(p, [(True, 3)] * k + [(False, 3)] * (10 - k))
                 for p, k in (("gp3", 3), ("rots", 2), ("rots-star", 5))]
    page = tmp_path / "RESULTS.md"
    write_report([optimal, tsad, *baselines], page)
    text = page.read_text()
    assert "- success 0.70 (target 0.93): **missed** by 0.23" in text
    assert "`optimal` solves 8/10 of these scenes, TSAD 7/8 of those and 0/2 of the rest" in text
    # 5 vs 4 actions: +25% over optimal, 5 points beyond the 20% allowed; 5.00 vs the paper's 3.96
    assert "+25% (target at most +20%): **missed** by 5 points" in text
    assert "actions over successful episodes 5.00 (paper 3.96): **missed** by 1.04" in text
    # optimal's 4 actions are above the paper's count too; without the retrieval 4 of them
    assert ("`optimal` itself needs 4.00 on the scenes it solves: these scenes need more actions "
            "than the paper's (without the final retrieval 4.00;") in text
    assert "median planning time 6.00 s (target under 5 s): **missed** by 1.00 s" in text
    # rots (0.20) below gp3 (0.30): not the paper's order
    assert ("gp3 0.30 < rots 0.20 < rots-star 0.50 < tsad 0.70): **missed**: gp3 0.30 not below "
            "rots 0.20 (paper 0.17 < 0.63)") in text

    # a tie is not the paper's order either; strictly increasing is; every scene solvable: no
    # "of the rest"
    for rots_k, verdict in ((3, "**missed**"), (4, "met")):
        rots = _document("rots", [(True, 3)] * rots_k + [(False, 3)] * (10 - rots_k))
        solvable = _document("optimal", [(True, 4)] * 10, "oracle")
        write_report([solvable, tsad, baselines[0], rots, baselines[2]], page)
        text = page.read_text()
        assert f"rots 0.{rots_k}0 < rots-star 0.50 < tsad 0.70): {verdict}" in text
        assert "`optimal` solves 10/10 of these scenes, TSAD 7/10 of those\n" in text
        assert "of the rest" not in text


def test_baseline_order_follows_the_papers_ties_and_strict_steps(tmp_path):
    # scenario 1 of the paper: gp3 0.33 < rots 0.87 = rots-star 0.87 < tsad 0.97
    def order_line(rates):
        docs = [_document(p, [(True, 3)] * k + [(False, 3)] * (10 - k), scenario="1")
                for p, k in rates]
        write_report(docs, tmp_path / "RESULTS.md")
        text = (tmp_path / "RESULTS.md").read_text()
        return next(line for line in text.splitlines() if "paper's order" in line)

    tie = order_line([("gp3", 3), ("rots", 8), ("rots-star", 8), ("tsad", 10)])
    assert tie.endswith("rots 0.80 <= rots-star 0.80 < tsad 1.00): met"), tie
    assert order_line([("gp3", 3), ("rots", 8), ("rots-star", 9), ("tsad", 10)]).endswith(": met")
    assert order_line([("gp3", 3), ("rots", 9), ("rots-star", 8), ("tsad", 10)]).endswith(
        "**missed**: rots 0.90 above rots-star 0.80 (paper 0.87 = 0.87)")  # where the paper ties
    assert order_line([("gp3", 3), ("rots", 8), ("rots-star", 10), ("tsad", 10)]).endswith(
        "**missed**: rots-star 1.00 not below tsad 1.00 (paper 0.87 < 0.97)")  # a tie, paper strict


def test_a_missed_network_target_names_the_failed_seeds(tmp_path):
    tsad = _document("tsad", [(True, 4)] * 10)
    net = _document("tsad", [(True, 4)] * 8 + [(False, 12)] * 2, "net")
    oracle = _document("tsad", [(True, 4)] * 10, "oracle")
    write_report([tsad, net, oracle], tmp_path / "RESULTS.md")
    text = (tmp_path / "RESULTS.md").read_text()
    assert ("success 0.20 below TSAD on the oracle model (target at most 0.03): **missed** by 0.17 "
            "(planning failed: sub-search 0: seeds 8, 9)") in text


@pytest.mark.slow  # a timing study's printout (37 s)
def test_net_timing_prints_a_row_per_batch_and_thread_count(capsys):
    from studies.net_timing import main

    assert main(["--batches", "1,3", "--threads", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = [line.split() for line in lines[1:3]]
    assert [r[:2] for r in rows] == [["1", "1"], ["3", "1"]]
    assert all(float(r[2]) > 0 for r in rows) and lines[3].startswith("encoding:")


def test_report_blames_tsad_when_optimal_is_under_the_papers_count(tmp_path):
    # optimal needs 3 actions everywhere (under the paper's 3.96); TSAD 6 on seed 1, 4 elsewhere
    optimal = _document("optimal", [(True, 3)] * 10, "oracle")
    tsad = _document("tsad", [(True, 4), (True, 6)] + [(True, 4)] * 8)
    page = tmp_path / "RESULTS.md"
    write_report([optimal, tsad], page)
    text = page.read_text()
    assert "actions over successful episodes 4.20 (paper 3.96): **missed** by 0.24" in text
    assert ("`optimal` needs 3.00 on these scenes, so the excess is TSAD's own: most of it on "
            "seed 1 +3, seed 9 +1, seed 8 +1") in text
    assert "these scenes need more actions than the paper's" not in text


def _gp3_specs(seeds):
    # scenario 3: its seeds 0 and 1 generate in under a second (scenario 1 seed 0 takes ~13 s)
    return [EpisodeSpec("3", s, EpisodeSettings(planner="gp3", feasibility="geometric"))
            for s in seeds]


def test_rerun_resumes_and_reruns_rows_of_another_scene(tmp_path):
    out = tmp_path / "gp3.json"
    rows_path = tmp_path / "gp3.json.rows.jsonl"
    first = run_bench(_gp3_specs([0, 1]), out, progress=False)
    assert [r["seed"] for r in first["rows"]] == [0, 1]
    assert all(len(r["scene_digest"]) == 12 for r in first["rows"])
    assert len(rows_path.read_text().splitlines()) == 2

    # same settings again: nothing is run, the document is rebuilt from the rows
    again = run_bench(_gp3_specs([0, 1]), out, progress=False)
    assert len(rows_path.read_text().splitlines()) == 2
    assert again["rows"] == first["rows"]

    # a row whose scene an older generator made (other digest) and a line cut off mid-write
    lines = rows_path.read_text().splitlines()
    stale = json.loads(lines[1])
    stale["scene_digest"] = "000000000000"
    stale["num_actions"] = 99
    rows_path.write_text(lines[0] + "\n" + json.dumps(stale) + "\n" + '{"seed": 1, "succ')
    third = run_bench(_gp3_specs([0, 1]), out, progress=False)
    assert third["rows"][0] == first["rows"][0]  # kept
    assert third["rows"][1]["num_actions"] != 99  # run again on the current scene
    assert third["rows"][1]["scene_digest"] == first["rows"][1]["scene_digest"]
    assert json.loads(out.read_text())["summary"]["episodes"] == 2

    # the cut-off line was ended before the new row was appended, so every row reads back
    from tsad_drake.bench.runner import _load_rows

    lines = rows_path.read_text().splitlines()
    assert json.loads(lines[-1]) == third["rows"][1]
    assert set(_load_rows(rows_path, _gp3_specs([0, 1]))) == {("3", 0), ("3", 1)}
    # a row from before rows recorded their scene's digest cannot be matched: it is run again
    undigested = {k: v for k, v in json.loads(lines[-1]).items() if k != "scene_digest"}
    rows_path.write_text(lines[0] + "\n" + json.dumps(undigested) + "\n")
    assert set(_load_rows(rows_path, _gp3_specs([0, 1]))) == {("3", 0)}


def test_rows_of_other_network_weights_are_run_again(tmp_path):
    """A `--feasibility net` row records the shipped weights' digest; resuming keeps the rows of
    these weights and drops those of other weights or with no digest (read back without running
    an episode)."""
    from tsad_drake.bench.runner import _load_rows, spec_scenario
    from tsad_drake.prehensile.weights import weights_digest
    from tsad_drake.scenario import scene_digest

    specs = [EpisodeSpec("3", s, EpisodeSettings(planner="tsad", feasibility="net")) for s in (0, 1)]
    rows_path = tmp_path / "net.json.rows.jsonl"
    rows = [{**dict(zip(SPEC_KEYS, spec.key())), "seed": spec.seed, "success": True,
             "num_actions": 2, "falls": 0, "planning_time_s": 0.5,
             "scene_digest": scene_digest(spec_scenario(spec)), "weights_digest": digest}
            for spec, digest in zip(specs, (weights_digest(), "000000000000"))]
    undigested = {**rows[1], "weights_digest": None}  # a row from before rows recorded it
    rows_path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert len(weights_digest()) == 12
    assert set(_load_rows(rows_path, specs)) == {("3", 0)}
    rows_path.write_text("".join(json.dumps(r) + "\n" for r in (rows[0], undigested)))
    assert set(_load_rows(rows_path, specs)) == {("3", 0)}


def test_bench_on_a_scenario_yaml_runs_the_same_scene_every_seed(tmp_path):
    from tsad_drake.scenario import save_scenario
    from tsad_drake.scenes import generate_scenario

    path = tmp_path / "scene.yaml"
    save_scenario(generate_scenario("3", 1), path)
    specs = [EpisodeSpec(str(path), s, EpisodeSettings(planner="gp3", feasibility="oracle"))
             for s in (5, 6)]
    document = run_bench(specs, tmp_path / "bench.json", progress=False)
    assert [r["seed"] for r in document["rows"]] == [5, 6]
    assert len({r["scene_digest"] for r in document["rows"]}) == 1
    assert all(r["num_actions"] >= 1 for r in document["rows"])


def test_a_row_from_before_configs_were_recorded_counts_as_the_default_config(tmp_path):
    from tsad_drake.bench.runner import spec_scenario
    from tsad_drake.run_config import apply_sets, default_run_config
    from tsad_drake.scenario import scene_digest

    default = default_run_config("gp3")
    spec = EpisodeSpec("3", 0, EpisodeSettings(planner="gp3", feasibility="oracle", config=default))
    old_row = {**{k: v for k, v in spec.identity().items() if k != "config_digest"}, "seed": 0,
               "success": True, "num_actions": 2, "falls": 0, "planning_time_s": 0.1,
               "marker": "old", "scene_digest": scene_digest(spec_scenario(spec))}
    for name, config, reused in (("default", default, True),
                                 ("changed", apply_sets(default, ["planner.iterations=50"]), False)):
        out = tmp_path / f"{name}.json"
        out.with_name(out.name + ".rows.jsonl").write_text(json.dumps(old_row) + "\n")
        document = run_bench([EpisodeSpec("3", 0, EpisodeSettings("gp3", "oracle", config=config))], out,
                             progress=False)
        assert (document["rows"][0].get("marker") == "old") == reused, name
