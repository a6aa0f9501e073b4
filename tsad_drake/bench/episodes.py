"""Named episodes: planner/feasibility/observer names -> a run of `execution.episode.run_episode`.

This is where the command line and the bench meet the planning layer; the observers live here
because they are the only place where the planner's world touches rendering.
"""

from __future__ import annotations

import dataclasses as dc

from tsad_drake.perception.types import PerceivedScene
from tsad_drake.scenario import Scenario


@dc.dataclass(frozen=True)
class EpisodeSettings:
    """How to run an episode (names as on the command line)."""

    planner: str = "tsad"
    feasibility: str = "geometric"
    ablation: str = "none"
    observer: str = "raycast"  #: raycast (NumPy ray caster) | drake (VTK renders in the station)
    closed_loop: bool = True
    max_actions: int = 12  #: pick-and-places allowed in the episode, random ones included
    segmentation: str = "label"
    motion: bool = False  #: verify each action at the motion level before executing it


class RaycastObserver:
    """Observation with the NumPy ray caster (same camera, same pipeline, no Drake)."""

    def __init__(self, segmentation: str = "label") -> None:
        self.segmentation = segmentation

    def __call__(self, truth: Scenario) -> PerceivedScene:
        from tsad_drake.perception.observe import observe_raycast

        return observe_raycast(truth, segmentation=self.segmentation).scene


class DrakeObserver:
    """Observation through the Drake station: built once, objects moved for each new observation."""

    def __init__(self, scenario: Scenario, segmentation: str = "label") -> None:
        from tsad_drake.station import MakeStation

        self.station = MakeStation(scenario)
        self.segmentation = segmentation

    def __call__(self, truth: Scenario) -> PerceivedScene:
        from tsad_drake.perception.observe import observe

        self.station.set_objects(truth.objects)
        return observe(self.station, segmentation=self.segmentation).scene


def make_observer(name: str, scenario: Scenario, segmentation: str = "label"):
    if name == "raycast":
        return RaycastObserver(segmentation)
    if name == "drake":
        return DrakeObserver(scenario, segmentation)
    raise ValueError(f"unknown observer {name!r}: use raycast or drake")


def initial_rearrangement_set_size(scenario: Scenario) -> int:
    """|R_theta*| on the true scene at the start, theta* = the angle with the fewest blockers."""
    from tsad_drake.scenario_generator import target_blockers

    return min(len(target_blockers(scenario, th)) for th in scenario.approach_angles)


def run_settings(scenario: Scenario, seed: int, settings: EpisodeSettings) -> dict:
    """Run one episode and return its JSON row (plan.json fields plus difficulty figures)."""
    from tsad_drake.execution.episode import run_episode
    from tsad_drake.planning.registry import get_planner, make_config

    planner = get_planner(settings.planner)
    config = make_config(settings.planner, settings.ablation)
    observer = make_observer(settings.observer, scenario, settings.segmentation)
    action_check = None
    if settings.motion:
        from tsad_drake.motion.verify import is_pick_failure, motion_check

        def action_check(truth: Scenario, action) -> tuple[bool, str]:
            ok, why = motion_check(truth, action)
            return ok, ("" if ok else ("pick: " if is_pick_failure(why) else "place: ") + why)
    result = run_episode(scenario, planner, settings.feasibility, observer, config, seed,
                         closed_loop=settings.closed_loop, max_actions=settings.max_actions,
                         planner_name=settings.planner, action_check=action_check)
    row = result.to_json()
    if settings.motion:
        checks = row["motion_checks"]
        row["motion_feasible_share"] = (sum(c["verified"] for c in checks) / len(checks)
                                        if checks else None)
    row["ablation"] = settings.ablation
    row["observer"] = settings.observer
    row["initial_rearrangement_set_size"] = initial_rearrangement_set_size(scenario)
    first_stats = row["rounds"][0]["stats"] if row["rounds"] else {}
    if settings.planner == "optimal":
        row["optimal_finished"] = bool(first_stats.get("optimal_finished", False))
    return row


def run_named_episode(spec) -> dict:
    """Bench entry point: an `EpisodeSpec` (built-in scenario name + seed) -> JSON row."""
    from tsad_drake.scenario import scene_digest

    scenario = spec_scenario(spec)
    settings = EpisodeSettings(planner=spec.planner, feasibility=spec.feasibility,
                               ablation=spec.ablation, observer=spec.observer,
                               closed_loop=spec.closed_loop, motion=spec.motion)
    row = run_settings(scenario, spec.seed, settings)
    row["scene_digest"] = scene_digest(scenario)
    if spec.feasibility == "net":
        row["weights_digest"] = weights_digest()
    return row


def weights_digest() -> str:
    """Short fingerprint of the shipped network weights: `--feasibility net` rows record it so a
    resumed bench never mixes in rows planned with an older network."""
    import hashlib

    from tsad_drake.perception.prehensile_train import DEFAULT_WEIGHTS

    return hashlib.sha1(DEFAULT_WEIGHTS.read_bytes()).hexdigest()[:12]


def spec_scenario(spec) -> Scenario:
    """The scene an `EpisodeSpec` names (generated from its scenario name and seed)."""
    from tsad_drake.scenario_generator import generate_scenario

    return generate_scenario(spec.scenario, spec.seed, occluded=spec.occluded)


def run_episode_for_cli(scenario: Scenario, seed: int, settings: EpisodeSettings,
                        out_dir=None) -> dict:
    """`tsad plan`: one episode on a given scene, as the plan.json document.

    With `settings.motion`, the executed actions are verified again as one continuous motion from
    the ready pose; `motion` holds the segments, and `out_dir` gets `replay.html` (an offline
    Meshcat recording) and `scene.dmd.yaml` (Drake model directives of the scene).
    """
    row = run_settings(scenario, seed, settings)
    if settings.motion:
        from tsad_drake.motion.export import (
            actions_from_records,
            motion_section,
            write_scene_directives,
        )
        from tsad_drake.motion.replay import write_replay_html
        from tsad_drake.motion.verify import verify_plan

        actions = actions_from_records(row["actions"])
        motions = verify_plan(scenario, actions)
        row["motion"] = motion_section(scenario, motions)
        if out_dir is not None:
            write_replay_html(scenario, actions, motions, out_dir / "replay.html")
            write_scene_directives(scenario, out_dir)
    row["scenario"] = scenario.name
    row["theta_star_deg"] = (None if row.get("theta_star_deg") is None
                             else round(float(row["theta_star_deg"]), 6))
    row["settings"] = dc.asdict(settings)
    return row
