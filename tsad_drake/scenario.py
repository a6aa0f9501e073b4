"""Scenario data: shelf, grid, approach angles and objects, YAML I/O and validation.

A scenario is the whole scene as data (the Drake `hardware_sim` convention): it is loaded and saved
with `pydrake.common.yaml`, and `MakeStation` builds the diagram from it. The seeded generator for
the paper's scenarios lives in `tsad_drake.scenario_generator`.

Frames: shelf frame S has its origin at the centre of the shelf's front edge on the shelf floor,
+x into the shelf, +y to the left, +z up. Object poses are planar (x, y, yaw) in S, upright on
the floor.

No `from __future__ import annotations` here: Drake's typed YAML reads the real field types.
"""


import dataclasses as dc
import math
from pathlib import Path

import numpy as np

from tsad_drake.errors import ScenarioError
from tsad_drake.geometry2d import convex_polygon_distance, footprint_polygon

SHAPES = ("cylinder", "box")
#: object kinds: what role an object plays in the paper's scenarios
KINDS = ("cylinder", "square_pillar", "rectangular", "large")


@dc.dataclass
class ShelfConfig:
    """The shelf: floor, back, two side walls and a top, open at the front (+x points inside)."""

    depth: float = 0.32  #: m, inner depth along +x (the paper's simulated workspace)
    width: float = 0.50  #: m, inner width along y
    height: float = 0.36  #: m, inner height from the floor to the top plate
    wall_thickness: float = 0.02  #: m, thickness of every panel
    floor_height: float = 0.10  #: m, height of the shelf floor above the world (robot base) plane


@dc.dataclass
class GridConfig:
    """Placement grid: cell centres of Gx x Gy cells over the workspace are placement candidates."""

    cells_x: int = 4  #: Gx, cells along the depth
    cells_y: int = 6  #: Gy, cells along the width
    margin: float = 0.035  #: m, keep-out band along the walls excluded from the grid


@dc.dataclass
class GripperConfig:
    """The two-finger gripper as the planners see it (a simplified Robotiq 2F-85)."""

    stroke: float = 0.085  #: m, largest object width the fingers can close on
    grasp_margin: float = 0.005  #: m, an object must be at least this much narrower than the stroke
    swept_half_width: float = 0.055  #: m, half the width of the open fingers, swept while approaching
    finger_reach: float = 0.015  #: m, how far past the grasp centre the fingertips' sweep extends
    #: m, safety margin the planners add around the swept corridor (the world model judges contact
    #: without it); raising it keeps planned approaches further from the motion planner's bound
    planning_clearance: float = 0.0


@dc.dataclass
class ObjectConfig:
    """One upright object on the shelf floor."""

    name: str = ""
    kind: str = "cylinder"  #: one of KINDS
    shape: str = "cylinder"  #: "cylinder" (size = [radius, height]) or "box" ([sx, sy, height])
    size: list[float] = dc.field(default_factory=list)  #: m
    x: float = 0.0  #: m, centre in S
    y: float = 0.0  #: m
    yaw: float = 0.0  #: rad, about +z
    mass: float = 0.2  #: kg

    @property
    def height(self) -> float:
        return self.size[-1]

    def footprint(self) -> np.ndarray:
        return footprint_polygon(self.shape, self.size, self.x, self.y, self.yaw)


@dc.dataclass
class Scenario:
    """A whole target-retrieval scene: shelf, grid, angles, objects and which one is the target."""

    name: str = "1"  #: built-in scenario name or a free label
    seed: int = 0  #: generator seed (provenance only once generated)
    shelf: ShelfConfig = dc.field(default_factory=ShelfConfig)
    grid: GridConfig = dc.field(default_factory=GridConfig)
    gripper: GripperConfig = dc.field(default_factory=GripperConfig)
    approach_angles_deg: list[float] = dc.field(
        default_factory=lambda: [-30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0])  #: deg, Theta
    objects: list[ObjectConfig] = dc.field(default_factory=list)
    target: str = ""  #: name of the target object
    occluded: bool = False  #: True when the target is fully hidden in every observation view
    min_gap: float = 0.005  #: m, smallest allowed gap between object footprints

    @property
    def approach_angles(self) -> np.ndarray:
        """Theta in radians."""
        return np.radians(np.asarray(self.approach_angles_deg, dtype=float))

    def object(self, name: str) -> ObjectConfig:
        for obj in self.objects:
            if obj.name == name:
                return obj
        raise KeyError(name)

    def target_index(self) -> int:
        return [o.name for o in self.objects].index(self.target)


def validate(scenario: Scenario) -> None:
    """Raise ScenarioError with one clear sentence when the scenario is malformed or impossible."""
    shelf = scenario.shelf
    if min(shelf.depth, shelf.width, shelf.height, shelf.wall_thickness) <= 0:
        raise ScenarioError("shelf dimensions must be positive")
    if scenario.grid.cells_x < 1 or scenario.grid.cells_y < 1:
        raise ScenarioError("grid must have at least one cell along each axis")
    if not scenario.approach_angles_deg:
        raise ScenarioError("approach_angles_deg must not be empty")
    if any(abs(a) >= 90 for a in scenario.approach_angles_deg):
        raise ScenarioError("approach angles must lie strictly between -90 and 90 degrees")
    if not scenario.objects:
        raise ScenarioError("scenario has no objects")
    names = [o.name for o in scenario.objects]
    if len(set(names)) != len(names) or any(not n for n in names):
        raise ScenarioError("object names must be unique and non-empty")
    if scenario.target not in names:
        raise ScenarioError(f"target {scenario.target!r} is not one of the objects")
    for obj in scenario.objects:
        if obj.shape not in SHAPES:
            raise ScenarioError(f"object {obj.name}: unknown shape {obj.shape!r} (use {SHAPES})")
        if obj.kind not in KINDS:
            raise ScenarioError(f"object {obj.name}: unknown kind {obj.kind!r} (use {KINDS})")
        expected = 2 if obj.shape == "cylinder" else 3
        if len(obj.size) != expected or min(obj.size) <= 0:
            raise ScenarioError(
                f"object {obj.name}: {obj.shape} needs {expected} positive sizes, got {obj.size}")
        if obj.height > shelf.height - 0.02:
            raise ScenarioError(f"object {obj.name} is taller than the shelf")
        if not all(math.isfinite(v) for v in (obj.x, obj.y, obj.yaw)):
            raise ScenarioError(f"object {obj.name}: pose must be finite")
        poly = obj.footprint()
        if (poly[:, 0].min() < 0 or poly[:, 0].max() > shelf.depth
                or abs(poly[:, 1]).max() > shelf.width / 2):
            raise ScenarioError(f"object {obj.name} lies outside the shelf workspace")
    polys = [o.footprint() for o in scenario.objects]
    for i in range(len(polys)):
        for j in range(i + 1, len(polys)):
            if convex_polygon_distance(polys[i], polys[j]) < 1e-4:
                raise ScenarioError(
                    f"objects {names[i]} and {names[j]} overlap")


def scene_digest(scenario: Scenario) -> str:
    """Short fingerprint of a scene (every field): bench rows record it so a resumed run never
    mixes in rows from scenes an older generator made for the same seed."""
    import hashlib
    import json

    text = json.dumps(dc.asdict(scenario), sort_keys=True, default=float)
    return hashlib.sha1(text.encode()).hexdigest()[:12]


def save_scenario(scenario: Scenario, path: str | Path) -> None:
    """Write the scenario as YAML readable by `load_scenario` (and Drake's yaml_load_typed)."""
    from pydrake.common.yaml import yaml_dump_typed

    Path(path).write_text(yaml_dump_typed(scenario))


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario YAML file; raise ScenarioError on any problem."""
    from pydrake.common.yaml import yaml_load_typed

    path = Path(path)
    if not path.is_file():
        raise ScenarioError(f"scenario file not found: {path}")
    try:
        scenario = yaml_load_typed(schema=Scenario, filename=str(path))
    except Exception as err:  # Drake raises RuntimeError with a multi-line message
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise ScenarioError(f"malformed scenario YAML {path}: {first}") from None
    validate(scenario)
    return scenario
