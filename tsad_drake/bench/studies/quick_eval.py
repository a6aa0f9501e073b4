"""Quick evaluation of a planner on generated scenes (closed loop, ray-cast observations).

    python -m tsad_drake.bench.studies.quick_eval --planner tsad --feasibility geometric --episodes 10

Prints, per scenario, success rate, mean actions and falls (successful / all episodes) and the
median planning time per episode; `--json FILE` writes every episode's result.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

from tsad_drake.execution.episode import EpisodeResult, run_episode
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.planning.registry import get_planner, make_config
from tsad_drake.scenes import generate_scenario


def _mean(values: list[float]) -> float:
    return statistics.fmean(values) if values else float("nan")


def summary_row(scenario: str, results: list[EpisodeResult]) -> str:
    """One line: success, actions and falls (successful / all), median planning time."""
    ok = [r for r in results if r.success]
    return (f"{scenario:>8} {len(results):>3} {len(ok) / max(len(results), 1):>7.2f} "
            f"{_mean([r.num_actions for r in ok]):>5.2f} / {_mean([r.num_actions for r in results]):<5.2f}"
            f" {_mean([r.falls for r in ok]):>5.2f} / {_mean([r.falls for r in results]):<5.2f}"
            f" {statistics.median([r.planning_time_s for r in results]):>9.2f}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--planner", default="tsad", help="registered planner name")
    parser.add_argument("--feasibility", default="geometric", choices=["oracle", "geometric"])
    parser.add_argument("--ablation", default="none", help="tsad reward ablation: none|no-ro|no-re")
    parser.add_argument("--scenarios", default="1,2,3", help="comma-separated built-in scenarios")
    parser.add_argument("--episodes", type=int, default=10, help="episodes (seeds) per scenario")
    parser.add_argument("--seed-start", type=int, default=0, help="first seed")
    parser.add_argument("--open-loop", action="store_true", help="execute whole plans once")
    parser.add_argument("--occluded", action="store_true", help="fully occluded targets")
    parser.add_argument("--json", default="", help="write every episode's result here")
    args = parser.parse_args(argv)
    try:
        planner = get_planner(args.planner)
        config = make_config(args.planner, args.ablation)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if args.episodes < 1:
        print("error: --episodes must be at least 1", file=sys.stderr)
        return 2
    print(f"{'scenario':>8} {'n':>3} {'success':>7} {'actions ok/all':>13} {'falls ok/all':>13} "
          f"{'plan [s]':>9}")
    rows = []
    for name in args.scenarios.split(","):
        results = []
        for seed in range(args.seed_start, args.seed_start + args.episodes):
            scenario = generate_scenario(name, seed, occluded=args.occluded)
            t0 = time.perf_counter()
            result = run_episode(scenario, planner, args.feasibility,
                                 lambda s: observe_raycast(s).scene, config, seed,
                                 closed_loop=not args.open_loop, planner_name=args.planner)
            results.append(result)
            rows.append(result.to_json() | {"wall_s": time.perf_counter() - t0})
            print(f"  seed {seed}: success={result.success} actions={result.num_actions} "
                  f"falls={result.falls} plan={result.planning_time_s:.2f}s "
                  f"{result.failure_reason}", file=sys.stderr, flush=True)
        print(summary_row(name, results), flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
