"""Motion failures as data: the cause of each rejected action, and the bench's count by cause."""

from __future__ import annotations

from tsad_drake.bench.metrics import paper_table, summarise
from tsad_drake.motion.causes import cause_label, failure_cause

#: failures as the motion level words them (taken from bench rows of 2026-12-02)
OPTIMISER = ("place: segment place->post_place failed to optimise: SNOPT failed (path position "
             "constraint at s=0.27[0]: -inf <= 1.09 <= 1.00); without the distance constraints: "
             "collision at t = 0.059 s between gripper_2f85::left_finger and shelf_right "
             "(-0.1 mm from the bound)")
KEYFRAME = ("pick: keyframe grasp: no collision-free IK solution; closest: "
            "gripper_2f85::right_finger vs obj5 (-0.6 mm from the bound)")
HELD = ("place: keyframe place_above: no collision-free IK solution; closest: obj4 vs obj1 "
        "(-1.9 mm from the bound)")


def test_causes_name_the_half_the_place_the_pair_and_the_margin():
    cause = failure_cause(OPTIMISER)
    assert cause["half"] == "place" and cause["where"] == "place->post_place"
    assert cause["kind"] == "clearance" and cause["margin_mm"] == -0.1
    assert cause["bodies"] == ["gripper_2f85::left_finger", "shelf_right"]
    assert cause_label(cause) == "clearance: finger vs shelf"
    assert cause_label(failure_cause(KEYFRAME)) == "clearance: finger vs object"
    assert failure_cause(KEYFRAME)["where"] == "grasp"
    assert cause_label(failure_cause(HELD)) == "clearance: object vs object"
    unreachable = failure_cause("pick: keyframe pre_grasp: unreachable (no IK solution for the "
                                "tcp pose)")
    assert unreachable["kind"] == "unreachable" and unreachable["bodies"] == []
    assert failure_cause("segment a->b failed to optimise: SNOPT failed")["kind"] == "optimiser"


def _row(seed: int, failures: list[str]) -> dict:
    checks = [{"verified": not f, "failure": f} for f in failures]
    return {"seed": seed, "success": True, "num_actions": len(failures), "falls": 0,
            "planning_time_s": 1.0, "motion_checks": checks,
            "motion_feasible_share": sum(not f for f in failures) / len(failures)}


def test_bench_summary_counts_rejections_by_cause():
    rows = [_row(0, ["", KEYFRAME, ""]), _row(1, [OPTIMISER, KEYFRAME])]
    summary = summarise(rows)
    assert summary["motion_rejections"] == {"clearance: finger vs object": 2,
                                            "clearance: finger vs shelf": 1}
    table = paper_table({"tsad": summary})
    assert "Motion rejections by cause" in table
    assert "2 clearance: finger vs object, 1 clearance: finger vs shelf" in table
