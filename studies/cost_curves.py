"""Cost curves: `python -m studies.cost_curves` (`make cost-curves`).

Planning time and counted search work per episode against the number of objects (3-15, on a
0.65 m shelf with 4 x 8 cells: the paper's 0.50 m shelf holds no more than about 12 of scenario
2's objects, the generator finds no 13-object scene for some seeds) and against the grid (24-60
cells on shelves 0.50-0.80 m wide, 10 objects), for TSAD (geometric and network), GP3, ROTS,
ROTS* and `optimal` (oracle). Scenes are scenario 2's generator (mixed shapes, 2-4 blockers,
solvable by `optimal`) with the free-cell window opened, since few objects on a wide shelf leave
many cells free. Sensing is ideal with
label segmentation: the curves show the search's cost, not the sensor's; the world is geometric.
Seeds are held out (1000 on). Rows go to `OUT/rows.jsonl` as they finish (a rerun resumes),
then `OUT/cost_curves.md` (tables) and `OUT/cost_curves.png` (plot) are written from all rows.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import dataclasses as dc
import json
import os
import statistics
import sys
from pathlib import Path

#: (planner, feasibility) pairs, as on the command line
PLANNERS: tuple[tuple[str, str], ...] = (
    ("tsad", "geometric"), ("tsad", "net"), ("gp3", "geometric"), ("rots", "geometric"),
    ("rots-star", "geometric"), ("optimal", "oracle"))
OBJECTS = (3, 5, 7, 9, 11, 13, 15)  #: objects on the objects curve's shelf
OBJECTS_SHELF = (0.65, 4, 8)  #: its width (m) and cells along the depth and across
#: (shelf width m, cells along the depth, cells across), 10 objects
GRIDS: tuple[tuple[float, int, int], ...] = ((0.50, 4, 6), (0.60, 5, 7), (0.70, 5, 8),
                                             (0.80, 6, 10))
GRID_OBJECTS = 10


@dc.dataclass(frozen=True)
class Point:
    """One scene family of a curve: objects, shelf width and grid."""

    curve: str  #: "objects" or "grid"
    num_objects: int
    width: float
    cells_x: int
    cells_y: int

    @property
    def cells(self) -> int:
        return self.cells_x * self.cells_y


def points() -> list[Point]:
    """Every point of both curves."""
    return ([Point("objects", n, *OBJECTS_SHELF) for n in OBJECTS]
            + [Point("grid", GRID_OBJECTS, w, gx, gy) for w, gx, gy in GRIDS])


def scene(point: Point, seed: int):
    """The generated scene of `point` and `seed` (ScenarioError when none can be made)."""
    from tsad_drake.scenario import GridConfig, ShelfConfig
    from tsad_drake.scenario_generator import GeneratorConfig
    from tsad_drake.scenes import generate_scenario

    n = point.num_objects
    config = dc.replace(GeneratorConfig(), num_objects=n, free_cells=(0, 10**6),
                        num_blockers=(min(2, n - 1), min(4, n - 1)))
    return generate_scenario("2", seed, config=config, shelf=ShelfConfig(width=point.width),
                             grid=GridConfig(cells_x=point.cells_x, cells_y=point.cells_y))


def run_one(job: tuple[Point, str, str, int]) -> dict:
    """One episode's row: the point, the planner, and what the episode cost and achieved."""
    import torch

    from tsad_drake.pipeline import EpisodeSettings, run_settings
    from tsad_drake.scenario import ScenarioError

    torch.set_num_threads(1)
    point, planner, feasibility, seed = job
    key = {**dc.asdict(point), "planner": planner, "feasibility": feasibility, "seed": seed}
    try:
        scenario = scene(point, seed)
    except ScenarioError as error:
        return {**key, "scene": f"none: {error}"}
    row = run_settings(scenario, seed, EpisodeSettings(planner=planner, feasibility=feasibility))
    first = row["rounds"][0]["stats"] if row["rounds"] else {}
    return {**key, "scene": "ok", "success": row["success"], "num_actions": row["num_actions"],
            "timed_out": row["timed_out"], "planning_time_s": row["planning_time_s"],
            "search_iterations": row["search_iterations"],
            "network_evaluations": row["network_evaluations"],
            "first_call_s": row["rounds"][0]["planning_time_s"] if row["rounds"] else None,
            "failure_reason": row["failure_reason"], "unsolvable": bool(first.get("unsolvable"))}


def _key(row: dict) -> tuple:
    return (row["curve"], row["num_objects"], row["width"], row["cells_x"], row["cells_y"],
            row["planner"], row["feasibility"], row["seed"])


def _label(planner: str, feasibility: str) -> str:
    return planner if feasibility in ("geometric", "oracle") else f"{planner} [{feasibility}]"


def _median(values: list[float]) -> float | None:
    return statistics.median(values) if values else None


def summarise(rows: list[dict]) -> dict:
    """Per curve, planner and point: episodes, successes, median/max planning time, median
    iterations, seconds per iteration, scenes the generator could not make."""
    out: dict = {}
    for row in rows:
        point = (row["num_objects"] if row["curve"] == "objects"
                 else f'{row["width"]:.2f} m, {row["cells_x"] * row["cells_y"]} cells')
        cell = out.setdefault(row["curve"], {}).setdefault(
            _label(row["planner"], row["feasibility"]), {}).setdefault(point, [])
        cell.append(row)
    table: dict = {}
    for curve, by_planner in out.items():
        for label, by_point in by_planner.items():
            for point, cell in by_point.items():
                ran = [r for r in cell if r["scene"] == "ok"]
                times = [r["planning_time_s"] for r in ran]
                iters = [r["search_iterations"] for r in ran]
                table.setdefault(curve, {}).setdefault(label, {})[point] = {
                    "episodes": len(ran), "no_scene": len(cell) - len(ran),
                    "successes": sum(r["success"] for r in ran),
                    "timed_out": sum(r["timed_out"] for r in ran),
                    "time_median_s": _median(times), "time_max_s": max(times, default=None),
                    "iterations_median": _median(iters),
                    "s_per_iteration": (sum(times) / sum(iters)) if sum(iters) else None}
    return table


def _fmt(value, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def markdown(table: dict) -> str:
    """The tables of `summarise`, one per curve: a row per planner, a column per point."""
    lines = []
    for curve, title in (("objects", "Planning per episode against the number of objects "
                          f"({OBJECTS_SHELF[0]:.2f} m shelf, {OBJECTS_SHELF[1]} x "
                          f"{OBJECTS_SHELF[2]} cells)"),
                         ("grid", f"Planning per episode against the grid ({GRID_OBJECTS} objects)")):
        if curve not in table:
            continue
        columns = sorted({p for cells in table[curve].values() for p in cells},
                         key=lambda p: (p if isinstance(p, int) else float(p.split()[0])))
        lines += [f"#### {title}", "",
                  "median s (max s) / median iterations / successes of episodes", "",
                  "| planner | " + " | ".join(str(c) for c in columns) + " |",
                  "|---|" + "---|" * len(columns)]
        for label, cells in table[curve].items():
            entries = []
            for c in columns:
                s = cells.get(c)
                if s is None or not s["episodes"]:
                    entries.append("-")
                    continue
                stop = f", {s['timed_out']} stopped" if s["timed_out"] else ""
                entries.append(f"{_fmt(s['time_median_s'])} ({_fmt(s['time_max_s'], 1)}) / "
                               f"{_fmt(s['iterations_median'], 0)} / "
                               f"{s['successes']}/{s['episodes']}{stop}")
            lines.append(f"| {label} | " + " | ".join(entries) + " |")
        lines.append("")
    return "\n".join(lines)


def plot(table: dict, path: Path) -> None:
    """Median planning time per episode against objects and against cells, a line per planner."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, curve, xlabel in ((axes[0], "objects", f"objects ({OBJECTS_SHELF[0]:.2f} m shelf, "
                                                f"{OBJECTS_SHELF[1] * OBJECTS_SHELF[2]} cells)"),
                              (axes[1], "grid", f"grid cells ({GRID_OBJECTS} objects, "
                                                "shelves 0.50-0.80 m)")):
        for label, cells in table.get(curve, {}).items():
            pts = sorted((p if isinstance(p, int) else int(p.split()[2]), s["time_median_s"])
                         for p, s in cells.items() if s["time_median_s"] is not None)
            if pts:
                ax.plot([p for p, _ in pts], [t for _, t in pts], marker="o", label=label)
        ax.set_xlabel(xlabel)
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("median planning per episode (s)")
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     epilog="Rows resume: a rerun with the same OUT runs only "
                                            "the missing episodes.")
    parser.add_argument("--out", type=Path, default=Path("results/cost_curves"),
                        help="folder for rows.jsonl, cost_curves.md and cost_curves.png")
    parser.add_argument("--episodes", type=int, default=5, help="seeds per point and planner")
    parser.add_argument("--seed-start", type=int, default=1000, help="first seed (held out)")
    parser.add_argument("--planners", default=",".join(f"{p}:{f}" for p, f in PLANNERS),
                        help="comma-separated planner:feasibility pairs")
    parser.add_argument("--curves", default="objects,grid", help="objects, grid or both")
    parser.add_argument("--workers", type=int, default=2, help="episodes run at once")
    args = parser.parse_args(argv)
    try:
        planners = [tuple(p.split(":")) for p in args.planners.split(",")]
        if any(len(p) != 2 for p in planners):
            raise ValueError("each planner is planner:feasibility, e.g. tsad:net")
        curves = set(args.curves.split(","))
        if not curves <= {"objects", "grid"} or args.episodes < 1 or args.workers < 1:
            raise ValueError("--curves takes objects and/or grid; --episodes, --workers >= 1")
    except ValueError as error:
        print(f"cost_curves: {error}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    rows_path = args.out / "rows.jsonl"
    rows = ([json.loads(line) for line in rows_path.read_text().splitlines() if line.strip()]
            if rows_path.exists() else [])
    done = {_key(r) for r in rows}
    jobs = [(pt, p, f, s) for pt in points() if pt.curve in curves for p, f in planners
            for s in range(args.seed_start, args.seed_start + args.episodes)]
    todo = [j for j in jobs if _key({**dc.asdict(j[0]), "planner": j[1], "feasibility": j[2],
                                     "seed": j[3]}) not in done]
    print(f"{len(jobs)} episodes, {len(jobs) - len(todo)} done before, {len(todo)} to run",
          flush=True)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    with rows_path.open("a") as sink, cf.ProcessPoolExecutor(args.workers) as pool:
        for k, row in enumerate(pool.map(run_one, todo), 1):
            sink.write(json.dumps(row) + "\n")
            sink.flush()
            rows.append(row)
            print(f"[{k}/{len(todo)}] {row['curve']} n={row['num_objects']} "
                  f"w={row['width']:.2f} {_label(row['planner'], row['feasibility'])} "
                  f"seed {row['seed']}: "
                  + (f"{row['planning_time_s']:.2f} s, {row['search_iterations']} it, "
                     f"{'ok' if row['success'] else row['failure_reason'][:50]}"
                     if row["scene"] == "ok" else row["scene"][:60]), flush=True)
    wanted = {_key({**dc.asdict(j[0]), "planner": j[1], "feasibility": j[2], "seed": j[3]})
              for j in jobs}
    table = summarise([r for r in rows if _key(r) in wanted])
    (args.out / "cost_curves.md").write_text(markdown(table))
    (args.out / "cost_curves.json").write_text(json.dumps(table, indent=1))
    plot(table, args.out / "cost_curves.png")
    print(f"wrote {args.out / 'cost_curves.md'} and {args.out / 'cost_curves.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
