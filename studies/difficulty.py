"""Scene-difficulty calibration: are the generated scenes as hard as the paper's?

Per scenario, on generated scenes (perceived by the ray-cast observer, judged with the `oracle`
model): the mean size of R_{theta*} at the start (theta* from GP3's order search), the mean optimal
number of actions (relocations plus the retrieval) where `optimal` finished within its budget, and
GP3's success in the world model (closed loop through `run_episode`). The paper's GP3 succeeds in
only 17-33% of scenes and TSAD needs ~3.7-4.7 actions.

    python -m studies.difficulty --episodes 30
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import json
import sys
import time
from pathlib import Path

import numpy as np

from tsad_drake.execution.episode import run_episode
from tsad_drake.execution.world import GeometricWorld
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.perception.types import PerceivedScene
from tsad_drake.pipeline import make_feasibility
from tsad_drake.planners.gp3 import GP3Config, gp3_optimal_angle
from tsad_drake.planners.optimal import OptimalConfig, plan_optimal
from tsad_drake.planning.interface import angle_index
from tsad_drake.planning.registry import get_planner
from tsad_drake.planning.state import empty_cell_count, make_workspace, state_from_perception
from tsad_drake.scenario import Scenario
from tsad_drake.scenes import generate_scenario


def _observe(scenario: Scenario) -> PerceivedScene:
    return observe_raycast(scenario, segmentation="label").scene


def measure_scene(scenario: Scenario, optimal: OptimalConfig, gp3: GP3Config,
                  feasibility_name: str = "oracle") -> dict:
    """The difficulty figures of one scene (see the module docstring)."""
    workspace = make_workspace(scenario)
    state = state_from_perception(_observe(scenario))
    feasibility = make_feasibility(feasibility_name, scenario, workspace)
    rng = np.random.default_rng(scenario.seed)
    theta, order = gp3_optimal_angle(state, feasibility, workspace, gp3, rng)
    size_r = None
    if theta is not None:
        k = angle_index(workspace.approach_angles, theta)
        size_r = len(feasibility.blockers(state, state.target_index)[k])
    best = plan_optimal(state, feasibility, workspace, optimal)
    episode = run_episode(GeometricWorld(scenario, _observe), get_planner("gp3"),
                          lambda truth, ws: make_feasibility(feasibility_name, truth, ws), gp3,
                          scenario.seed, feasibility_name=feasibility_name)
    return {
        "scenario": scenario.name, "seed": scenario.seed,
        "theta_star_deg": None if theta is None else float(np.degrees(theta)),
        "size_r": size_r, "gp3_removals": len(order),
        "empty_cells": empty_cell_count(state, workspace),
        "optimal_finished": bool(best.stats["optimal_finished"]),
        "optimal_actions": best.stats.get("optimal_actions"),
        "optimal_reason": best.failure_reason, "optimal_time_s": best.planning_time_s,
        "gp3_success": bool(episode.success), "gp3_actions": episode.num_actions,
        "gp3_falls": episode.falls, "gp3_reason": episode.failure_reason,
    }


def _mean(values: list) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def summarise(rows: list[dict]) -> dict:
    """Per-scenario means of the rows of `measure_scene`."""
    return {
        "scenes": len(rows),
        "mean_size_r": _mean([r["size_r"] for r in rows]),
        "optimal_finished": sum(r["optimal_finished"] for r in rows),
        "mean_optimal_actions": _mean([r["optimal_actions"] for r in rows]),
        "gp3_success": _mean([float(r["gp3_success"]) for r in rows]),
        "mean_empty_cells": _mean([r["empty_cells"] for r in rows]),
        "mean_generation_s": _mean([r.get("generation_s") for r in rows]),
    }


def _fmt(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def table(summaries: dict[str, dict]) -> str:
    """Markdown table of the per-scenario summaries."""
    lines = ["| scenario | scenes | mean R_theta* | optimal finished | mean optimal actions "
             "| GP3 success | mean empty cells | generation s |",
             "|---|---|---|---|---|---|---|---|"]
    for name, s in summaries.items():
        lines.append(f"| {name} | {s['scenes']} | {_fmt(s['mean_size_r'])} "
                     f"| {s['optimal_finished']} | {_fmt(s['mean_optimal_actions'])} "
                     f"| {_fmt(s['gp3_success'])} | {_fmt(s['mean_empty_cells'], 1)} "
                     f"| {_fmt(s['mean_generation_s'], 3)} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m studies.difficulty",
        description="Measure generated-scene difficulty: mean |R_theta*|, optimal actions, "
                    "GP3 success (oracle feasibility, world model).")
    parser.add_argument("--episodes", type=int, default=30, help="scenes per scenario")
    parser.add_argument("--scenarios", nargs="+", default=["1", "2", "3"],
                        help="built-in scenario names")
    parser.add_argument("--seed-start", type=int, default=0, help="first generator seed")
    parser.add_argument("--optimal-nodes", type=int, default=OptimalConfig.max_nodes,
                        help="node budget of the optimal planner per scene")
    parser.add_argument("--optimal-time", type=float, default=10.0,
                        help="time budget (s) of the optimal planner per scene")
    parser.add_argument("--out", type=Path, default=None, help="write rows and summary as JSON")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        print("error: --episodes must be at least 1", file=sys.stderr)
        return 2
    optimal = dc.replace(OptimalConfig(), max_nodes=args.optimal_nodes,
                         safety_stop_s=args.optimal_time)
    rows, summaries = [], {}
    for name in args.scenarios:
        scenario_rows = []
        for seed in range(args.seed_start, args.seed_start + args.episodes):
            start = time.perf_counter()
            scenario = generate_scenario(name, seed)
            generation = time.perf_counter() - start
            row = measure_scene(scenario, optimal, GP3Config())
            row["generation_s"] = generation
            scenario_rows.append(row)
            print(f"scenario {name} seed {seed}: |R*|={row['size_r']} "
                  f"optimal={row['optimal_actions']} gp3={'ok' if row['gp3_success'] else 'fail'}"
                  f" ({row['gp3_reason'] or 'success'})", file=sys.stderr, flush=True)
        rows.extend(scenario_rows)
        summaries[name] = summarise(scenario_rows)
    print(table(summaries))
    if args.out is not None:
        args.out.write_text(json.dumps({"rows": rows, "summary": summaries}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
