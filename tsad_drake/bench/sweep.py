"""`tsad sweep GRID.yaml`: a grid of config overrides x scenarios x seeds, on either bench backend.

A grid file names the run (the selectors of `tsad bench`), fixed overrides and the grid: each
grid field (a `--set` path such as `planner.iteration_budget`) with its values; every combination
is one grid point. Each (grid point, scenario) is one `tsad bench` run written to
`DIR/<scenario>-p<k>.json` (resumable, one row per seed), and the whole sweep is one results page
(`DIR/sweep.md`: one table per scenario, a column per grid point; `sweep.json`, `sweep.png`).

    planner: tsad
    feasibility: geometric
    scenarios: ["1", "2"]
    seed_start: 0
    episodes: 10
    set: [planner.safety_stop_s=600]
    grid:
      planner.iterations: [60, 120, 240]
      planner.exploration: [0.3, 1.0]
"""

import dataclasses as dc
import itertools
import json
from pathlib import Path

import yaml
from pydrake.common.yaml import yaml_dump, yaml_load_typed

from tsad_drake.errors import UsageError

#: at most this many grid points x scenarios (each is a bench run)
MAX_RUNS = 200


# no `from __future__ import annotations` here: Drake's typed YAML reads the field types
@dc.dataclass
class SweepFile:
    """A grid file (everything but `grid`, which maps field paths to lists of values)."""

    planner: str = "tsad"
    feasibility: str | None = None  #: None: the planner's default model
    variant: str = "full"
    ablation: str = "none"
    sensor: str = "ideal"
    segmentation: str = "label"
    observer: str = "raycast"
    closed_loop: bool = True
    scenarios: list[str] = dc.field(default_factory=lambda: ["1"])
    seed_start: int = 0
    episodes: int = 5
    set: list[str] = dc.field(default_factory=list)  #: overrides every grid point shares


@dc.dataclass
class SweepPoint:
    """One grid point: its `--set` overrides and a short name for tables."""

    index: int
    sets: list[str]

    @property
    def name(self) -> str:
        return f"p{self.index}: " + ", ".join(s.split(".", 1)[1] for s in self.sets)


def load_sweep(path: str | Path) -> tuple[SweepFile, list[SweepPoint]]:
    """The grid file at `path` and its grid points (UsageError for anything malformed)."""
    where = f"sweep file {path}"
    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except OSError as err:
        raise UsageError(f"{where}: cannot read it: {err.strerror}") from None
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        raise UsageError(f"{where}: not valid YAML: {' '.join(str(err).split())}") from None
    if not isinstance(data, dict):
        raise UsageError(f"{where}: expected a mapping (planner, scenarios, grid, ...)")
    grid = data.pop("grid", None)
    if not isinstance(grid, dict) or not grid:
        raise UsageError(f"{where}: grid must map at least one field (e.g. "
                         "planner.iteration_budget) to a list of values")
    try:
        sweep = yaml_load_typed(schema=SweepFile, data=yaml_dump(data) if data else "{}")
    except (RuntimeError, ValueError, TypeError) as err:
        raise UsageError(f"{where}: {' '.join(str(err).split())}") from None
    axes = []
    for field, values in grid.items():
        if not isinstance(values, list) or not values or any(
                isinstance(v, (dict, list)) for v in values):
            raise UsageError(f"{where}: grid.{field} must be a non-empty list of values")
        axes.append([f"{field}={json.dumps(v)}" for v in values])
    points = [SweepPoint(k, list(sets)) for k, sets in enumerate(itertools.product(*axes))]
    runs = len(points) * len(sweep.scenarios)
    if runs > MAX_RUNS:
        raise UsageError(f"{where}: {len(points)} grid points x {len(sweep.scenarios)} scenarios "
                         f"is {runs} bench runs, more than {MAX_RUNS}")
    return sweep, points
