"""Quick evaluation of a planner on generated scenes (closed loop, ray-cast observations).

    python -m studies.quick_eval --planner tsad --feasibility geometric --episodes 10
    python -m studies.quick_eval --sensor realistic --segmentation cluster
    python -m studies.quick_eval --sensor realistic --noise-mm 2

Episodes run as `pipeline.run_settings` runs them (the bench's 12-action limit). Prints, per
scenario, success rate, mean actions and falls (successful / all episodes) and the median planning
time per episode; `--json FILE` writes every episode's result.
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import json
import statistics
import sys
import time

from tsad_drake.perception.sensor import SENSOR_PRESETS
from tsad_drake.pipeline import EpisodeSettings, run_settings
from tsad_drake.run_config import default_run_config
from tsad_drake.scenes import generate_scenario


def _mean(values: list[float]) -> float:
    return statistics.fmean(values) if values else float("nan")


def summary_row(scenario: str, rows: list[dict]) -> str:
    """One line: success, actions and falls (successful / all), median planning time."""
    ok = [r for r in rows if r["success"]]
    return (f"{scenario:>8} {len(rows):>3} {len(ok) / max(len(rows), 1):>7.2f} "
            f"{_mean([r['num_actions'] for r in ok]):>5.2f} / "
            f"{_mean([r['num_actions'] for r in rows]):<5.2f}"
            f" {_mean([r['falls'] for r in ok]):>5.2f} / {_mean([r['falls'] for r in rows]):<5.2f}"
            f" {statistics.median([r['planning_time_s'] for r in rows]):>9.2f}")


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
    parser.add_argument("--segmentation", default="label", choices=["label", "cluster"])
    parser.add_argument("--sensor", default="ideal", choices=list(SENSOR_PRESETS),
                        help="depth sensor model (perception.sensor)")
    parser.add_argument("--noise-mm", type=float, default=None,
                        help="constant depth noise (mm) instead of the sensor's range law")
    parser.add_argument("--look-again", type=int, default=None,
                        help="the loop's look_again (`episode` section): after a plan fails "
                             "with nothing to do, move a neighbour of the target and observe "
                             "again, at most this often (default: the planner variant's)")
    parser.add_argument("--json", default="", help="write every episode's result here")
    args = parser.parse_args(argv)
    overrides = () if args.noise_mm is None else (("noise_sigma0", args.noise_mm / 1000),
                                                   ("noise_sigma2", 0.0))
    try:
        config = default_run_config(args.planner, args.ablation, sensor=args.sensor,
                                    sensor_overrides=dict(overrides))
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if args.look_again is not None:
        config = dc.replace(config, episode=dc.replace(config.episode, look_again=args.look_again))
    settings = EpisodeSettings(planner=args.planner, feasibility=args.feasibility,
                               ablation=args.ablation, closed_loop=not args.open_loop,
                               segmentation=args.segmentation, sensor=args.sensor, config=config)
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
            row = run_settings(scenario, seed, settings)
            results.append(row)
            rows.append(row | {"wall_s": time.perf_counter() - t0})
            print(f"  seed {seed}: success={row['success']} actions={row['num_actions']} "
                  f"falls={row['falls']} plan={row['planning_time_s']:.2f}s "
                  f"{row['failure_reason']}", file=sys.stderr, flush=True)
        print(summary_row(name, results), flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
