"""Where a plan's time goes: observe a generated scene once, then plan it with TSAD (or another
planner), timing the observation and the search, optionally under cProfile.

    python tools/profile_plan.py --scenario 2 --seeds 1000-1004 [--feasibility net]
        [--sensor realistic] [--frames 8] [--profile out.prof] [--set planner.field=value]
        [--threads 1]

Prints one line per seed: observation seconds, planning seconds, iterations, network queries,
actions, success, then each attempt's iterations (TSAD: the pass over the angles, the angle's
rank); the `--profile` file is read with `python -m pstats`.
"""

from __future__ import annotations

import argparse
import cProfile
import time

import numpy as np

from tsad_drake.perception.sensor import sensor_config
from tsad_drake.pipeline import RaycastObserver, make_feasibility
from tsad_drake.planners.tsad.config import with_extras
from tsad_drake.planning.registry import get_planner, make_config
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.runtime import pin_threads
from tsad_drake.scenes import generate_scenario


def seed_range(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="2")
    parser.add_argument("--seeds", default="1000-1004")
    parser.add_argument("--planner", default="tsad")
    parser.add_argument("--feasibility", default="geometric")
    parser.add_argument("--sensor", default="realistic")
    parser.add_argument("--segmentation", default="cluster")
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--profile", default="")
    parser.add_argument("--set", action="append", default=[],
                        help="planner field=value (a TSAD extra: extras.field=value)")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch and BLAS threads, as the commands' --threads (default 1)")
    args = parser.parse_args()
    pin_threads(args.threads)
    overrides, extras = {}, {}
    for item in args.set:
        key, _, value = item.partition("=")
        name = key.removeprefix("extras.")
        (extras if name != key else overrides)[name] = eval(value)  # noqa: S307 - a developer tool
    sensor = sensor_config(args.sensor, **({"frames": args.frames} if args.sensor != "ideal" else {}))
    segmentation = args.segmentation if args.sensor != "ideal" else "label"
    spec = get_planner(args.planner)
    profiler = cProfile.Profile() if args.profile else None
    for seed in seed_range(args.seeds):
        scenario = generate_scenario(args.scenario, seed)
        observer = RaycastObserver(segmentation, sensor, seed)
        t0 = time.perf_counter()
        state = state_from_perception(observer(scenario))
        t_obs = time.perf_counter() - t0
        workspace = make_workspace(scenario)
        model = make_feasibility(args.feasibility, scenario, workspace, args.sensor)
        config = make_config(args.planner, **overrides)
        config = with_extras(config, **extras) if extras else config
        t0 = time.perf_counter()
        if profiler:
            profiler.enable()
        plan = spec.plan(state, model, workspace, config, np.random.default_rng(seed))
        if profiler:
            profiler.disable()
        t_plan = time.perf_counter() - t0
        print(f"s{args.scenario} seed {seed}: observe {t_obs:.2f} s  plan {t_plan:.2f} s  "
              f"iterations {plan.stats.get('iterations_total')}  queries {model.evaluations}  "
              f"reused {getattr(model, 'reused_inputs', 0)}  "
              f"net {getattr(model, 'network_seconds', 0):.2f} s  "
              f"actions {len(plan.actions)}  success {plan.success}  {plan.failure_reason}",
              flush=True)
        for a in plan.stats.get("attempts", []):
            print(f"    attempt {a['attempt']}, angle rank {a['angle_rank']}: "
                  f"{a['iterations']} iterations")
    if profiler:
        profiler.dump_stats(args.profile)


if __name__ == "__main__":
    main()
