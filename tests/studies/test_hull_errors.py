"""Perceived-footprint error measurement (`bench.studies.hull_errors`)."""

import numpy as np

from studies.hull_errors import hull_errors, summary, support
from tsad_drake.scenes import generate_scenario


def test_support_of_a_square():
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    np.testing.assert_allclose(support(square, np.array([0.0, np.pi / 2, np.pi, np.pi / 4])),
                               [1.0, 1.0, 0.0, np.sqrt(2)], atol=1e-12)


def test_perceived_hulls_are_close_to_the_true_footprints():
    scenario = generate_scenario("2", 0)
    rows = hull_errors(scenario)
    assert {r.name for r in rows} <= {o.name for o in scenario.objects} and len(rows) >= 8
    for r in rows:
        assert r.shortfall >= 0.0 and r.excess >= 0.0
        # a side where the hull falls short is a shortfall, one where it sticks out an excess
        assert r.shortfall >= -min(r.sides.values()) - 1e-12
        assert r.excess >= max(r.sides.values()) - 1e-12
    stats = summary(rows)
    assert stats["all"]["objects"] == len(rows)
    assert stats["all"]["shortfall_median_mm"] < 3.0  # seen objects are perceived to mm
    assert set(stats) >= {"cylinder", "all"}


def test_the_study_document_becomes_a_table_of_the_results_page(tmp_path, capsys):
    """`hull_errors --json` writes a document that `tsad report` turns into a table row with the
    median / p90 / worst shortfall and excess of the run it measured."""
    import json

    from cli_harness import invoke

    from studies.hull_errors import main
    from tsad_drake.bench.metrics import summarise

    study = tmp_path / "footprints.json"
    main(["--scenarios", "2", "--seeds", "1", "--sensor", "realistic", "--segmentation",
          "cluster", "--frames", "1", "--json", str(study)])
    doc = json.loads(study.read_text())
    e = doc["summary"]["all"]
    assert doc["settings"]["sensor"] == "realistic" and e["objects"] >= 8
    assert e["shortfall_median_mm"] <= e["shortfall_p90_mm"] <= e["shortfall_max_mm"]
    assert e["excess_median_mm"] <= e["excess_p90_mm"] <= e["excess_max_mm"]
    rows = [{"seed": 0, "success": True, "num_actions": 3, "falls": 0, "failure_reason": "",
             "planning_time_s": 1.0}]
    bench = {"spec": {"scenario": "2", "planner": "tsad", "feasibility": "geometric"},
             "seeds": [0], "rows": rows, "summary": summarise(rows)}
    (tmp_path / "bench.json").write_text(json.dumps(bench))
    fused = tmp_path / "footprints-fused.json"
    main(["--scenarios", "2", "--seeds", "1", "--sensor", "realistic", "--segmentation",
          "cluster", "--frames", "4", "--json", str(fused)])
    assert json.loads(fused.read_text())["settings"]["frames"] == 4
    code, _, err = invoke(capsys, ["report", tmp_path / "bench.json", study, fused,
                                   "--out", tmp_path / "page.md"])
    assert code == 0, err
    page = (tmp_path / "page.md").read_text()
    assert "## Perceived footprints against the truth" in page
    row = next(line for line in page.splitlines() if line.startswith("| realistic, cluster"))
    assert (f"| {e['shortfall_median_mm']:.1f} / {e['shortfall_p90_mm']:.1f} / "
            f"{e['shortfall_max_mm']:.1f} |") in row and "| 2 x 0-0 |" in row
    assert any(line.startswith("| realistic x 4 frames, cluster") for line in page.splitlines())


def test_fused_frames_bring_the_perceived_footprints_closer_to_the_truth():
    """Eight frames per view instead of one: the perceived footprints overreach the truth less
    (the noise that grows them averages out) on fixed scenes, under `cluster` segmentation."""
    from tsad_drake.perception.sensor import sensor_config

    def excess(frames: int) -> float:
        sensor = sensor_config("realistic", frames=frames)
        errors = [e for seed in (0, 1) for e in hull_errors(generate_scenario("2", seed), sensor,
                                                            "cluster", noise_seed=seed)]
        return float(np.median([e.excess for e in errors]))

    one, eight = excess(1), excess(8)
    assert eight < 0.7 * one, (one, eight)
