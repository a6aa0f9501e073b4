"""Motion-planning time per pick-and-place: `python -m studies.motion_timing`.

For each seed of a built-in scenario: run a TSAD episode (ray-cast observation, geometric
feasibility), take its executed actions (true objects) and verify them with `verify_plan`; print
the median and worst planning time per pick-and-place and the share that verified.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="1", help="built-in scenario (default 1)")
    parser.add_argument("--seeds", type=int, default=4, help="number of seeds from 0 (default 4)")
    args = parser.parse_args(argv)

    from tsad_drake.motion.export import actions_from_records
    from tsad_drake.motion.verify import verify_plan
    from tsad_drake.pipeline import EpisodeSettings, run_settings
    from tsad_drake.scenes import generate_scenario

    times, verified, failures = [], 0, []
    for seed in range(args.seeds):
        scenario = generate_scenario(args.scenario, seed)
        row = run_settings(scenario, seed, EpisodeSettings())
        actions = actions_from_records(row["actions"])
        start = time.perf_counter()
        motions = verify_plan(scenario, actions)
        total = time.perf_counter() - start
        for m in motions:
            times.append(m.planning_time_s)
            verified += m.verified
            if not m.verified:
                failures.append(f"seed {seed} {m.action.object}: {m.failure}")
        print(f"seed {seed}: {len(actions)} actions, {sum(m.verified for m in motions)} verified, "
              f"{total:.2f} s in all (ready pose included)", flush=True)
    if not times:
        print("no actions")
        return 0
    print(f"scenario {args.scenario}, {args.seeds} seeds, {len(times)} pick-and-places: "
          f"median {np.median(times):.2f} s, worst {max(times):.2f} s per pick-and-place; "
          f"{verified}/{len(times)} motion-feasible")
    for line in failures:
        print("  " + line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
