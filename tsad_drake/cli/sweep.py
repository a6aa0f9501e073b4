"""`tsad sweep GRID.yaml --out DIR`: a grid of config overrides x scenarios x seeds (bench/sweep.py)."""

from __future__ import annotations

import argparse
from pathlib import Path

from tsad_drake.cli.common import Parser, add_scenario_args, add_threads_arg
from tsad_drake.cli.plan import add_parallel_args, add_plan_parsers, bench_specs
from tsad_drake.outputs import prepare_out_dir
from tsad_drake.runtime import detail, show_progress


def add_sweep_parser(sub) -> None:
    p = sub.add_parser("sweep", help="bench a grid of config overrides on scenarios and seeds",
                       description=(
                           "Run `tsad bench` for every grid point (a combination of the grid's "
                           "field values, applied as --set) on every scenario of GRID.yaml, "
                           "resumably, and write one results page: DIR/sweep.md (a table per "
                           "scenario, a column per grid point), sweep.json and sweep.png. The "
                           "format of GRID.yaml is in `tsad_drake/bench/sweep.py` and "
                           "docs/benchmark.md."))
    p.add_argument("grid", help="grid file (YAML)")
    add_parallel_args(p)
    add_threads_arg(p)
    p.add_argument("--out", required=True, help="output directory")


def _bench_argv(sweep, sets: list[str], scenario: str, args, out: Path) -> list[str]:
    """The `tsad bench` command line of one (grid point, scenario)."""
    argv = ["bench", "--scenario", scenario, "--planner", sweep.planner, "--variant", sweep.variant,
            "--ablation", sweep.ablation, "--sensor", sweep.sensor, "--segmentation",
            sweep.segmentation, "--observer", sweep.observer, "--seed-start", str(sweep.seed_start),
            "--episodes", str(sweep.episodes), "--workers", str(args.workers), "--backend",
            args.backend, "--threads", str(args.threads), "--out", str(out)]
    if sweep.feasibility is not None:
        argv += ["--feasibility", sweep.feasibility]
    if not sweep.closed_loop:
        argv.append("--open-loop")
    for item in [*sweep.set, *sets]:
        argv += ["--set", item]
    return argv


def cmd_sweep(args: argparse.Namespace) -> int:
    from tsad_drake.bench.report import write_report
    from tsad_drake.bench.runner import run_bench
    from tsad_drake.bench.sweep import load_sweep

    sweep, points = load_sweep(args.grid)
    out = prepare_out_dir(args.out)
    parser = Parser(prog="tsad")  # the plan commands' parsers: each run is read as `tsad bench`
    add_plan_parsers(parser.add_subparsers(dest="command", parser_class=Parser), add_scenario_args)
    runs = []  # every run checked before the first episode
    for point in points:
        for scenario in sweep.scenarios:
            name = f"{Path(scenario).stem}-p{point.index}.json"
            bench_args = parser.parse_args(_bench_argv(sweep, point.sets, scenario, args,
                                                       out.path(name)))
            runs.append((point, *bench_specs(bench_args)))
    documents = []
    for k, (point, specs, path) in enumerate(runs):
        detail(f"run {k + 1}/{len(runs)}: scenario {specs[0].scenario}, {point.name}")
        document = run_bench(specs, path, workers=args.workers, threads=args.threads,
                             progress=show_progress(), backend=args.backend)
        document["spec"]["label"] = point.name
        documents.append(document)
    page = out.path("sweep.md")
    write_report(documents, page)
    print(f"wrote {page}: {len(points)} grid points x {len(sweep.scenarios)} scenarios x "
          f"{sweep.episodes} episodes")
    return 0


SWEEP_COMMANDS = {"sweep": cmd_sweep}
