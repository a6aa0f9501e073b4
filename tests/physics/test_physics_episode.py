"""`--world physics` wiring: settings, plan.json records, bench figures, the agreement classes,
and (slow) a whole closed-loop episode on the simulated station."""

import dataclasses as dc

import pytest

from studies.physics_agreement import classify
from tsad_drake.bench.metrics import paper_table, summarise
from tsad_drake.execution.record import PhysicsSummary
from tsad_drake.execution.world import ActionOutcome
from tsad_drake.pipeline import EpisodeSettings, physics_settings


def _measured(**fields) -> ActionOutcome:
    base = dict(object="a", moved=True, placement_error_mm=2.0, slip_mm=1.0, lifted=True,
                tracking_error=0.01, sim_seconds=3.0, wall_seconds=2.0)
    base.update(fields)
    return ActionOutcome(**base)


def test_physics_implies_the_motion_level_and_the_drake_observer():
    settings = physics_settings(EpisodeSettings(world="physics"))
    assert settings.motion and settings.observer == "drake"
    assert physics_settings(EpisodeSettings()) == EpisodeSettings()
    with pytest.raises(ValueError):
        physics_settings(EpisodeSettings(world="dreams"))


def test_physics_figures_and_bench_summary():
    outcomes = [_measured(),
                _measured(moved=False, placement_error_mm=30.0, disturbed=["b"]),
                _measured(moved=False, placement_error_mm=None, slip_mm=None, lifted=None,
                          tracking_error=None, sim_seconds=0.0, wall_seconds=0.0,
                          reason="no motion: ...")]
    figures = PhysicsSummary.of(outcomes).to_json()
    assert figures["actions"] == 3 and figures["simulated"] == 2 and figures["moved"] == 1
    assert figures["disturbed"] == 1
    assert figures["placement_error_mm"] == pytest.approx(2.0)  # over moved objects only
    assert figures["real_time_factor"] == pytest.approx(1.5)
    row = {"success": True, "num_actions": 3, "falls": 0, "physics": figures}
    summary = summarise([row, dict(row)])
    assert summary["physics_moved_share"] == pytest.approx(1 / 3)
    assert summary["physics_real_time_factor"] == pytest.approx(1.5)
    assert "Physics: placement error [mm]" in paper_table({"tsad": summary})
    assert "Physics" not in paper_table({"tsad": summarise([{"success": True, "num_actions": 1,
                                                             "falls": 0}])})


def test_agreement_classes():
    rule = ActionOutcome("a", True, fallen=["b"])
    assert classify(rule, ActionOutcome("a", True, disturbed=["b"])) == [
        "rule-fall-physics-stands:disturbed:b"]
    assert classify(ActionOutcome("a", True),
                    ActionOutcome("a", False, fallen=["c"], sim_seconds=3.0)) == [
        "physics-fall-rule-missed:c", "moved-rule-only"]
    assert classify(ActionOutcome("a", True), ActionOutcome("a", False)) == ["no-motion"]
    assert classify(ActionOutcome("a", True), ActionOutcome("a", True, disturbed=["d"])) == [
        "disturbed-only:d"]
    assert classify(ActionOutcome("a", True), ActionOutcome("a", True)) == []


@pytest.mark.slow
def test_closed_loop_episode_on_the_physics_world():
    """Scenario 1 seed 0, TSAD on the geometric model: every action simulated and recorded."""
    from tsad_drake.pipeline import run_settings
    from tsad_drake.scenes import generate_scenario

    row = run_settings(generate_scenario("1", 0), 0,
                       EpisodeSettings(feasibility="geometric", world="physics"))
    assert row["world"] == "physics" and row["actions"]
    for action in row["actions"]:
        assert set(dc.asdict(ActionOutcome("x", False))) <= set(action["physics"])
    assert row["physics"]["actions"] == len(row["actions"])
    assert row["success"], row["failure_reason"]
