"""What each of TSAD's extras buys: `full` without one extra, or `paper` with one (`--add`).

    python -m studies.extras --scenarios 1,2,3 --episodes 10 --workers 2 \
        --json results/extras.json

Runs closed-loop episodes (ray-cast observations, label segmentation, geometric model) of TSAD
`full`, `paper`, and `full` without each extra (`planners.tsad.config.EXTRAS` and the loop's
`EPISODE_VARIANTS`; that field at its paper value), on the same scenes (seeds `--seed-start` ..;
`--open-loop`: one plan per episode, executed whole), and prints one markdown row per config:
success, actions of the successful
episodes, falls, median planning time per episode, and how often the extras were used.
`--only NAME,...` restricts the leave-one-out rows to some extras.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import dataclasses as dc
import json
import statistics
import sys

from tsad_drake.execution.episode import EpisodeConfig
from tsad_drake.outputs import atomic_write_text
from tsad_drake.pipeline import EpisodeSettings, run_settings
from tsad_drake.planners.tsad.config import EPISODE_VARIANTS, EXTRAS, TSADExtras, with_extras
from tsad_drake.run_config import default_run_config
from tsad_drake.runtime import pin_threads
from tsad_drake.scenes import generate_scenario

#: the extras that steer the closed loop (fields of the run's `episode` section), at `full`'s values
LOOP_EXTRAS: dict[str, object] = EPISODE_VARIANTS["full"]
#: every extra: TSAD's own, then the loop's
ALL_EXTRAS: tuple[str, ...] = (*EXTRAS, *LOOP_EXTRAS)


def _settings(variant: str, closed_loop: bool, safety_stop_s: float, name: str = "",
              value: object = None) -> EpisodeSettings:
    """TSAD in `variant` with extra `name` (a planner or an `episode` field) set to `value`."""
    config = default_run_config("tsad", variant=variant,
                                planner_overrides={"safety_stop_s": safety_stop_s})
    if name in EXTRAS:
        config = dc.replace(config, planner=with_extras(config.planner, **{name: value}))
    if name in LOOP_EXTRAS:
        config = dc.replace(config, episode=dc.replace(config.episode, **{name: value}))
    return EpisodeSettings(closed_loop=closed_loop, variant=variant, config=config)


def configs(only: list[str], closed_loop: bool = True, add: bool = False,
            safety_stop_s: float = 600.0) -> dict[str, EpisodeSettings]:
    """The compared configurations by row label: `full`, `paper`, and per extra either `full`
    without it (at its paper value) or, with `add`, `paper` with it (at its full value).
    Every row gets the same wall-clock cap, so the iteration budget ends the searches."""
    out = {"full": _settings("full", closed_loop, safety_stop_s),
           "paper": _settings("paper", closed_loop, safety_stop_s)}
    for name in only:
        if not closed_loop and name in LOOP_EXTRAS:
            continue
        if name in LOOP_EXTRAS:
            full_value, paper_value = LOOP_EXTRAS[name], getattr(EpisodeConfig(), name)
        else:
            full_value, paper_value = getattr(TSADExtras(), name), getattr(TSADExtras.paper(), name)
        if add:
            out[f"paper + {name}"] = _settings("paper", closed_loop, safety_stop_s, name,
                                               full_value)
        else:
            out[f"full - {name}"] = _settings("full", closed_loop, safety_stop_s, name,
                                              paper_value)
    return out


def _episode(job: tuple[str, str, int, EpisodeSettings]) -> dict:
    pin_threads(1)
    label, scenario_name, seed, settings = job
    row = run_settings(generate_scenario(scenario_name, seed), seed, settings)
    used: dict[str, int] = {}
    for rnd in row["rounds"]:
        for name, count in rnd["stats"].get("extras_used", {}).items():
            used[name] = used.get(name, 0) + count
    return {"label": label, "scenario": scenario_name, "seed": seed, "success": row["success"],
            "num_actions": row["num_actions"], "falls": row["falls"],
            "planning_time_s": row["planning_time_s"], "extras_used": used,
            "failure_reason": row["failure_reason"]}


def table(rows: list[dict], labels: list[str]) -> str:
    """One markdown row per config label, over every scenario."""
    lines = ["| config | episodes | success | actions (successful) | falls | plan s (median) |"
             " extras used (total) |", "|---|---|---|---|---|---|---|"]
    for label in labels:
        mine = [r for r in rows if r["label"] == label]
        ok = [r for r in mine if r["success"]]
        used: dict[str, int] = {}
        for r in mine:
            for name, count in r["extras_used"].items():
                used[name] = used.get(name, 0) + count
        uses = ", ".join(f"{k} {v}" for k, v in sorted(used.items()) if v) or "none"
        actions = statistics.fmean(r["num_actions"] for r in ok) if ok else float("nan")
        lines.append(f"| {label} | {len(mine)} | {len(ok) / max(len(mine), 1):.2f} | "
                     f"{actions:.2f} | {sum(r['falls'] for r in mine)} | "
                     f"{statistics.median(r['planning_time_s'] for r in mine):.1f} | {uses} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", default="1,2,3", help="comma-separated built-in scenarios")
    parser.add_argument("--episodes", type=int, default=10, help="episodes (seeds) per scenario")
    parser.add_argument("--seed-start", type=int, default=0, help="first seed")
    parser.add_argument("--only", default="", help="comma-separated extras (default: every one)")
    parser.add_argument("--open-loop", action="store_true",
                        help="one plan per episode, executed whole (cheaper; the loop extras drop out)")
    parser.add_argument("--variants-only", action="store_true",
                        help="only the full and paper rows")
    parser.add_argument("--add", action="store_true",
                        help="rows `paper + extra` instead of `full - extra`")
    parser.add_argument("--time-cap", type=float, default=600.0,
                        help="s, wall-clock cap of one planning call (default 600: the "
                             "iteration budget decides, not the machine's load)")
    parser.add_argument("--workers", type=int, default=1, help="worker processes")
    parser.add_argument("--json", default="", help="write every episode's row here")
    args = parser.parse_args(argv)
    only = [] if args.variants_only else [n for n in args.only.split(",") if n] or list(ALL_EXTRAS)
    unknown = sorted(set(only) - set(ALL_EXTRAS))
    if unknown or args.episodes < 1 or args.workers < 1:
        print(f"error: unknown extras {unknown}" if unknown else
              "error: --episodes and --workers must be at least 1", file=sys.stderr)
        return 2
    settings = configs(only, not args.open_loop, args.add, args.time_cap)
    jobs = [(label, s, seed, cfg) for label, cfg in settings.items()
            for s in args.scenarios.split(",")
            for seed in range(args.seed_start, args.seed_start + args.episodes)]
    rows = []
    with cf.ProcessPoolExecutor(args.workers) as pool:
        for i, row in enumerate(pool.map(_episode, jobs), 1):
            rows.append(row)
            print(f"[{i}/{len(jobs)}] {row['label']} s{row['scenario']} seed {row['seed']}: "
                  f"{'ok' if row['success'] else row['failure_reason']} "
                  f"({row['num_actions']} actions)", file=sys.stderr, flush=True)
    print(table(rows, list(settings)))
    if args.json:
        atomic_write_text(args.json, json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
