"""Same inputs, same outputs: record `tsad plan` documents for a fixed set of runs, then compare two
recordings field by field with wall-clock timings left out.

    python tools/compare_plans.py record DIR [--jobs 2]   # run every case, write DIR/<case>/plan.json
    python tools/compare_plans.py compare DIR_A DIR_B      # exit 0 when every plan.json agrees
    (compare --allow-added: fields only in DIR_B, new in the newer tree, are listed, not counted)
    (both take --only PREFIX, e.g. --only s1-tsad-net: the network cases, best run alone, --jobs 1)

The cases are the restructuring issue's: `tsad plan` for tsad, gp3, rots, rots-star (geometric model)
and optimal (its default, the oracle) on scenario 2 seeds 0-9, TSAD on the network for scenario 1
seeds 0-4, and the demo (scenario 1 seed 0, TSAD, geometric, Drake observer, --motion). The runs
go through `tsad_drake.cli.main` of whatever `tsad_drake` is importable (PYTHONPATH picks a tree).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

#: keys whose values are wall-clock measurements (or derived from them), left out of comparisons,
#: with every key ending in `_time_s` or `_seconds`
TIMING_KEYS = {"planning_time_s", "network_seconds", "elapsed_s", "time_s", "seconds",
               "iterations_per_s", "wall_s", "time_capped", "planning_time_per_iteration_s"}


def cases() -> dict[str, list[str]]:
    runs = {"demo": ["--scenario", "1", "--seed", "0", "--planner", "tsad", "--feasibility",
                     "geometric", "--observer", "drake", "--motion"]}
    for planner in ("tsad", "gp3", "rots", "rots-star", "optimal"):
        feasibility = ["--feasibility", "geometric"] if planner != "optimal" else []
        for seed in range(10):
            runs[f"s2-{planner}-{seed}"] = ["--scenario", "2", "--seed", str(seed), "--planner",
                                            planner, *feasibility]
    for seed in range(5):
        runs[f"s1-tsad-net-{seed}"] = ["--scenario", "1", "--seed", str(seed), "--planner", "tsad",
                                       "--feasibility", "net"]
    return runs


def _run(name: str, args: list[str], root: Path) -> str:
    out = root / name
    code = ("import sys; from tsad_drake.cli import main; sys.exit(main(sys.argv[1:]))")
    proc = subprocess.run([sys.executable, "-c", code, "plan", *args, "--out", str(out)],
                          capture_output=True, text=True)
    (root / f"{name}.log").write_text(proc.stdout + proc.stderr)
    return f"{name}: exit {proc.returncode}"


def record(root: Path, jobs: int, only: str = "") -> None:
    root.mkdir(parents=True, exist_ok=True)
    chosen = {k: v for k, v in cases().items() if k.startswith(only)}
    with ThreadPoolExecutor(jobs) as pool:
        for line in pool.map(lambda kv: _run(kv[0], kv[1], root), chosen.items()):
            print(line, flush=True)


def _strip(value):
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items()
                if k not in TIMING_KEYS and not k.endswith(("_time_s", "_seconds"))}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    return value


def _diff(a, b, path: str = "", added: list[str] | None = None) -> list[str]:
    """Differences of b from a; keys only in b (a newer recording's new fields) go to `added`
    when a list is given, instead of counting as differences."""
    if isinstance(a, dict) and isinstance(b, dict):
        extra = sorted(set(b) - set(a)) if added is not None else []
        if added is not None:
            added += [f"{path}.{k}" for k in extra]
        out = [f"{path}.{k}: only in one" for k in sorted((set(a) ^ set(b)) - set(extra))]
        for k in sorted(set(a) & set(b)):
            out += _diff(a[k], b[k], f"{path}.{k}", added)
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} vs {len(b)} items"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _diff(x, y, f"{path}[{i}]", added)]
    return [] if a == b else [f"{path}: {a!r} vs {b!r}"]


def _time_capped(document: dict) -> bool:
    """A planning call hit its wall-clock safety stop (`timed_out`; `time_capped` in recordings
    before 2026-12-03): the outcome depends on the machine's load."""
    return any(r.get("stats", {}).get("time_capped") or r.get("stats", {}).get("timed_out")
               for r in document.get("rounds", []))


def compare(a: Path, b: Path, only: str = "", allow_added: bool = False) -> int:
    bad = capped = 0
    added: list[str] | None = [] if allow_added else None
    names = [k for k in cases() if k.startswith(only)]
    for name in names:
        pa, pb = a / name / "plan.json", b / name / "plan.json"
        if not pa.exists() or not pb.exists():
            print(f"{name}: missing plan.json in {'A' if not pa.exists() else 'B'}")
            bad += 1
            continue
        da, db = json.loads(pa.read_text()), json.loads(pb.read_text())
        if _time_capped(da) or _time_capped(db):
            capped += 1
            print(f"{name}: a planning call hit the wall-clock cap; not comparable (run it alone)")
            continue
        diffs = _diff(_strip(da), _strip(db), added=added)
        if diffs:
            bad += 1
            print(f"{name}: {len(diffs)} differences, first: " + "; ".join(diffs[:3]))
    print(f"{len(names) - bad - capped} of {len(names) - capped} comparable plan.json documents "
          f"agree ({capped} time-capped)")
    if added:
        print(f"fields only in B (new, not compared): {', '.join(sorted(set(added)))}")
    return 1 if bad else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("record")
    p.add_argument("out", type=Path)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--only", default="", help="run only the cases whose name starts with this")
    p = sub.add_parser("compare")
    p.add_argument("a", type=Path)
    p.add_argument("b", type=Path)
    p.add_argument("--only", default="", help="compare only the cases whose name starts with this")
    p.add_argument("--allow-added", action="store_true",
                   help="fields only in B (added by the newer tree) are listed, not differences")
    args = parser.parse_args()
    if args.command == "record":
        record(args.out, args.jobs, args.only)
        return 0
    return compare(args.a, args.b, args.only, args.allow_added)


if __name__ == "__main__":
    sys.exit(main())
