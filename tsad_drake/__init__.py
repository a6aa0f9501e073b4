"""TSAD on Drake: target retrieval from a shelf by tree search with approaching direction.

The public API, importable from `tsad_drake` directly (each name is loaded on first use, so
`import tsad_drake` stays cheap and the command line starts fast):

    scenes        generate_scenario(name, seed), load_scenario(path), Scenario
    station       MakeStation(scenario) -> Station (render depth + labels per approach angle)
    perception    observe(station), observe_raycast(scenario) -> Observation (.scene)
    planning      get_planner(name), make_config(name, ablation, variant, **fields), register,
                  PlannerSpec, FeasibilityModel, make_feasibility(name, scenario, workspace),
                  make_workspace(scenario), state_from_perception(scene)
    config        RunConfig (every setting, YAML), default_run_config(planner, ablation, variant,
                  sensor), merge_file(config, path), apply_sets(config, ["a.b=v"]),
                  dump_run_config(config); EpisodeSettings(config=...) runs with it
    episodes      EpisodeSettings, plan_episode(scenario, seed, settings) -> EpisodeRecord
                  (.to_json(): the plan.json document), run_episode(world, planner,
                  model_factory, config, seed) -> EpisodeRecord, World, GeometricWorld
    verification  verify_plan(scenario, actions, world="none"|"geometric"|"physics") ->
                  VerificationReport (.to_json(): `tsad verify`'s report.json); plans as files:
                  load_plan(path) -> PlanDocument, plan_json(scenario, actions) (tsad-plan/1)
    motion        write_replay_html(scenario, actions, motions, path); the motion level alone:
                  tsad_drake.motion.verify.verify_plan(scenario, actions) -> [ActionMotion]

    >>> import tsad_drake as td
    >>> doc = td.plan_episode(td.generate_scenario("1", 0), 0, td.EpisodeSettings()).to_json()
"""

from __future__ import annotations

import importlib
from importlib import metadata
from typing import Any

try:
    __version__ = metadata.version("tsad_drake")
except metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"

#: public name -> module that defines it
_PUBLIC = {
    "generate_scenario": "tsad_drake.scenes",
    "load_scenario": "tsad_drake.scenario",
    "Scenario": "tsad_drake.scenario",
    "MakeStation": "tsad_drake.station",
    "observe": "tsad_drake.perception.observe",
    "observe_raycast": "tsad_drake.perception.observe",
    "get_planner": "tsad_drake.planning.registry",
    "make_config": "tsad_drake.planning.registry",
    "register": "tsad_drake.planning.registry",
    "PlannerSpec": "tsad_drake.planning.registry",
    "FeasibilityModel": "tsad_drake.planning.interface",
    "make_feasibility": "tsad_drake.pipeline",
    "make_workspace": "tsad_drake.planning.state",
    "state_from_perception": "tsad_drake.planning.state",
    "EpisodeSettings": "tsad_drake.pipeline",
    "RunConfig": "tsad_drake.run_config",
    "default_run_config": "tsad_drake.run_config",
    "merge_file": "tsad_drake.run_config",
    "apply_sets": "tsad_drake.run_config",
    "dump_run_config": "tsad_drake.run_config",
    "plan_episode": "tsad_drake.pipeline",
    "EpisodeRecord": "tsad_drake.execution.record",
    "run_episode": "tsad_drake.execution.episode",
    "World": "tsad_drake.execution.world",
    "GeometricWorld": "tsad_drake.execution.world",
    "verify_plan": "tsad_drake.verification",
    "VerificationReport": "tsad_drake.verification",
    "load_plan": "tsad_drake.plan_format",
    "plan_json": "tsad_drake.plan_format",
    "PlanDocument": "tsad_drake.plan_format",
    "write_replay_html": "tsad_drake.motion.replay",
}

__all__ = [*_PUBLIC, "__version__"]


def __getattr__(name: str) -> Any:
    if name not in _PUBLIC:
        raise AttributeError(f"module 'tsad_drake' has no attribute {name!r}")
    value = getattr(importlib.import_module(_PUBLIC[name]), name)
    globals()[name] = value  # loaded once
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
