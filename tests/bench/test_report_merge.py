"""`tsad report` on a run split by seed ranges: the same page as the whole run; conflicting
halves refused with one line; documents of different settings never share a column."""

import json

from cli_harness import assert_clean, invoke

from tsad_drake.bench.metrics import summarise as summarise_rows
from tsad_drake.bench.report import group_by_scenario, merge_documents


def _bench(capsys, out, seed_start, episodes):
    result = invoke(capsys, ["bench", "--scenario", "3", "--planner", "gp3", "--feasibility",
                             "oracle", "--seed-start", seed_start, "--episodes", episodes,
                             "--out", out])
    assert_clean(result, codes=(0,))


def _tables(page):
    """The page's tables without what differs between two runs of the same episodes: the header
    (the machine), the plot's file name and wall-clock planning times."""
    text = page.read_text()
    return [line for line in text[text.index("## Scenario"):].splitlines()
            if "planning time" not in line.lower() and not line.startswith("![")]


def _untimed(digest):
    return {s: {label: {k: v for k, v in summary.items() if "time" not in k}
                for label, summary in columns.items()} for s, columns in digest.items()}


def test_two_halves_report_the_same_table_as_the_whole_run(tmp_path, capsys):
    whole, first, second = (tmp_path / f"{n}.json" for n in ("whole", "first", "second"))
    _bench(capsys, whole, 0, 2)
    _bench(capsys, first, 0, 1)
    _bench(capsys, second, 1, 1)
    code, out, _ = invoke(capsys, ["report", whole, "--out", tmp_path / "page_whole.md"])
    assert code == 0
    code, out, _ = invoke(capsys, ["report", second, first, "--out", tmp_path / "page_split.md"])
    assert code == 0 and "1 merged from split runs" in out
    assert _tables(tmp_path / "page_split.md") == _tables(tmp_path / "page_whole.md")
    digest = json.loads((tmp_path / "page_split.md").with_suffix(".json").read_text())
    whole_digest = json.loads((tmp_path / "page_whole.md").with_suffix(".json").read_text())
    assert _untimed(digest) == _untimed(whole_digest)
    assert digest["3"]["gp3 [oracle]"]["episodes"] == 2

    # the same seed with another result in a third file: one line, exit 2, nothing written
    doc = json.loads(first.read_text())
    doc["rows"][0]["success"] = not doc["rows"][0]["success"]
    doc["rows"][0]["failure_reason"] = "" if doc["rows"][0]["success"] else "edited"
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(doc))
    result = invoke(capsys, ["report", first, second, edited, "--out", tmp_path / "bad.md"])
    assert_clean(result, codes=(2,))
    assert "disagree on seed 0" in result[2] and "edited.json" in result[2]
    assert not (tmp_path / "bad.md").exists()


def _doc(spec: dict, seeds: list[int]) -> dict:
    rows = [{"seed": s, "success": True, "num_actions": 2, "falls": 0, "planning_time_s": 1.0}
            for s in seeds]
    return {"spec": spec, "rows": rows, "summary": {"episodes": len(rows), "success_rate": 1.0}}


def test_different_settings_stay_apart_and_identical_rows_merge_once():
    base = {"scenario": "1", "planner": "tsad", "feasibility": "geometric"}
    docs = merge_documents([("a", _doc(base, [0, 1])), ("b", _doc(base, [1, 2])),
                            ("c", _doc({**base, "world": "physics"}, [0])),
                            ("d", _doc({**base, "config": "f00d"}, [0]))])
    assert [len(d["rows"]) for d in docs] == [3, 1, 1]  # seed 1 in both a and b counted once
    assert docs[0]["summary"]["episodes"] == 3 and docs[0]["sources"] == ["a", "b"]
    columns = group_by_scenario(docs)["1"]
    assert set(columns) == {"tsad", "tsad physics world", "tsad #2"}


def test_realistic_columns_name_the_depth_frames_their_sensor_fused():
    spec = {"scenario": "2", "planner": "tsad", "sensor": "realistic", "segmentation": "cluster"}
    one = {**_doc({**spec, "config_digest": "a"}, [0]), "config": {"sensor": {"noise_sigma0": 1}}}
    eight = {**_doc({**spec, "config_digest": "b"}, [0]), "config": {"sensor": {"frames": 8}}}
    ideal = {**_doc({"scenario": "2", "planner": "tsad"}, [0]), "config": {"sensor": {}}}
    columns = group_by_scenario(merge_documents([("a", one), ("b", eight), ("c", ideal)]))["2"]
    assert set(columns) == {"tsad realistic sensor x1 frame cluster",
                            "tsad realistic sensor x8 frames cluster", "tsad"}


def test_each_row_is_set_against_its_table_in_the_paper_with_its_interval():
    from tsad_drake.bench.metrics import summarise
    from tsad_drake.bench.report import _paper_lines, paper_counterpart

    def doc(spec, successes, n=30):
        rows = [{"seed": s, "success": s < successes, "num_actions": 3, "falls": 0,
                 "planning_time_s": 1.0, "failure_reason": "" if s < successes else "x"}
                for s in range(n)]
        return {"spec": spec, "rows": rows, "summary": summarise(rows)}

    tsad = {"scenario": "2", "planner": "tsad", "feasibility": "geometric"}
    assert paper_counterpart("2", tsad)[0] == "Table I"
    assert paper_counterpart("1", {**tsad, "ablation": "no-re"}) == ("Table II",
                                                                       (0.90, 4.30, 4.33, 0.22, 0.23))
    assert paper_counterpart("2", {**tsad, "occluded": True})[0] == "Table III"
    assert paper_counterpart("real", {**tsad, "scenario": "real"})[1][0] == 0.87
    assert paper_counterpart("2", {**tsad, "world": "physics"}) is None  # not the paper's setting
    lines = _paper_lines("2", {"tsad-paper": doc({**tsad, "variant": "paper"}, 21),
                               "tsad": doc(tsad, 29)})
    # 21/30 = 0.70 has the interval 0.52-0.83: the paper's 0.93 lies above it; 29/30 contains it
    assert "tsad-paper: success 0.70 (95% 0.52-0.83, 30 episodes)" in lines[2]
    assert lines[2].endswith("outside: above ours") and lines[3].endswith("inside: not told apart")


def test_an_agreement_study_becomes_a_section_with_its_confusion_matrices(tmp_path, capsys):
    from studies.physics_agreement import summarise

    def action(rule_moved, physics_moved, physics_fallen=()):
        return {"object": "a", "diverged": False,
                "rule": {"moved": rule_moved, "fallen": [], "reason": ""},
                "physics": {"moved": physics_moved, "fallen": list(physics_fallen),
                            "disturbed": [], "sim_seconds": 2.0, "wall_seconds": 4.0},
                "disagreements": [] if rule_moved == physics_moved else ["moved-rule-only"]}

    episodes = [{"scenario": "1", "seed": 0, "actions": [action(True, True), action(True, False),
                                                          action(True, True, ["b"])]}]
    study = {"settings": {"scenarios": ["1"], "seeds": [0], "feasibility": "geometric",
                          "aim": "true"}, "summary": summarise(episodes), "episodes": episodes}
    assert study["summary"]["confusion"]["moved"] == {
        "rule yes / physics yes": 2, "rule yes / physics no": 1,
        "rule no / physics yes": 0, "rule no / physics no": 0}
    (tmp_path / "agreement.json").write_text(json.dumps(study))
    bench = _doc({"scenario": "1", "planner": "tsad", "feasibility": "geometric"}, [0])
    bench["summary"] = summarise_rows(bench["rows"])
    (tmp_path / "bench.json").write_text(json.dumps(bench))
    code, _, err = invoke(capsys, ["report", tmp_path / "bench.json", tmp_path / "agreement.json",
                                   "--out", tmp_path / "page.md"])
    assert code == 0, err
    page = (tmp_path / "page.md").read_text()
    assert "## Physics against the 2-D rule" in page
    assert "| rule yes | 2 | 1 |" in page and "| rule yes | 0 | 1 |" not in page
    assert "| rule no | 1 | 2 |" in page  # falls: physics saw one the rule did not
    assert "3 actions of TSAD (geometric model)" in page  # studies before --planner were TSAD's
    from tsad_drake.bench.study_pages import agreement_markdown
    study["settings"]["planner"] = "rots"
    assert agreement_markdown(study)[0].startswith("3 actions of ROTS (geometric model)")
    result = invoke(capsys, ["report", tmp_path / "agreement.json", "--out", tmp_path / "p2.md"])
    assert_clean(result, codes=(2,))  # a study alone has no table to report
