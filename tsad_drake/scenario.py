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
import re
from pathlib import Path

import numpy as np

from tsad_drake.errors import ScenarioError, first_line
from tsad_drake.geometry2d import footprint_penetration, footprint_polygon
from tsad_drake.outputs import atomic_write_text

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
    """Placement grid: cell centres of Gx x Gy cells over the workspace are placement candidates.

    The defaults are the paper's 4 x 6 grid on the default 0.32 x 0.50 m shelf; a scenario file
    that sets no cell counts gets `for_shelf` (cells of about the same size on its shelf)."""

    cells_x: int = 4  #: Gx, cells along the depth
    cells_y: int = 6  #: Gy, cells along the width
    margin: float = 0.035  #: m, keep-out band along the walls excluded from the grid

    @staticmethod
    def for_shelf(shelf: ShelfConfig, margin: float = 0.035) -> "GridConfig":
        """The grid scaled to `shelf`: cells of about the paper's size (PAPER_CELL) inside the
        margin, at least one along each axis."""
        def count(extent: float, cell: float) -> int:
            return max(1, min(MAX_GRID_CELLS, round((extent - 2 * margin) / cell)))

        return GridConfig(cells_x=count(shelf.depth, PAPER_CELL[0]),
                          cells_y=count(shelf.width, PAPER_CELL[1]), margin=margin)


#: m, the paper's grid cell (depth, width): its 4 x 6 grid on the 0.32 x 0.50 m shelf, inside the
#: 0.035 m margin
PAPER_CELL = ((0.32 - 2 * 0.035) / 4, (0.50 - 2 * 0.035) / 6)


#: m, the planners' clearance: the motion level's 1 mm plus 0.5 mm (see GripperConfig)
SHARED_CLEARANCE = 0.0015


@dc.dataclass
class GripperConfig:
    """The two-finger gripper as the planners see it (a simplified Robotiq 2F-85)."""

    stroke: float = 0.085  #: m, largest object width the fingers can close on
    grasp_margin: float = 0.005  #: m, an object must be at least this much narrower than the stroke
    swept_half_width: float = 0.055  #: m, half the width of the open fingers, swept while approaching
    finger_reach: float = 0.015  #: m, how far past the grasp centre the fingertips' sweep extends
    #: m, the clearance every planning decision keeps: the planners' swept corridor is this much
    #: wider on each side and longer past the fingertips, and the scene generator (its blockers,
    #: free cells and solvability check) leaves room for it. SHARED_CLEARANCE matches the motion
    #: level: its 1 mm `MotionConfig.clearance` plus 0.5 mm of tolerance
    #: (`tests/motion/test_clearance.py`). The worlds judge contact without it.
    planning_clearance: float = SHARED_CLEARANCE

    @property
    def corridor_half_width(self) -> float:
        """m, half the width of the corridor the planners sweep (clearance included)."""
        return self.swept_half_width + self.planning_clearance

    @property
    def corridor_reach(self) -> float:
        """m, how far past the grasp centre the planners' corridor reaches (clearance included)."""
        return self.finger_reach + self.planning_clearance


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


#: object names: a letter, then letters, digits or underscores (they become Drake model instance
#: and body names, SDFormat/YAML text and file names in the motion export)
OBJECT_NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}")
#: names the station, the motion export or Drake already use (compared case-insensitively, so two
#: exported files never differ by case alone)
RESERVED_NAMES = frozenset({"world", "shelf", "ground", "ur5e", "gripper_2f85", "package",
                            "worldmodelinstance", "defaultmodelinstance"})
#: bounds that keep memory and time bounded (a grid of cells_x * cells_y candidates per object
#: and angle, pairwise object checks)
MAX_OBJECTS = 40
MAX_GRID_CELLS = 32  #: per axis
MAX_APPROACH_ANGLES = 36
MAX_SHELF_SIZE = 2.0  #: m, bound of object coordinates (the footprint check is the real one)
#: m, (smallest, largest) inner depth, width and height of a shelf: the range the station can
#: place the UR5e for (`placement.py` checks each shelf's grid by IK; a deeper or wider one
#: within these bounds can still be refused, naming the cells out of reach)
SHELF_BOUNDS = {"depth": (0.15, 0.60), "width": (0.15, 1.00), "height": (0.10, 0.60)}
MIN_OBJECT_SIZE = 0.005  #: m, smallest radius, side or height (smaller is not seen at 128x128)
MAX_MASS = 50.0  #: kg
#: m, deepest interpenetration of two footprints that still counts as contact: objects that touch
#: (on a real shelf, in a settled simulation, where point contact leaves them a fraction of a
#: millimetre inside each other) load; deeper ones are refused (`tsad scene --settle` fixes them)
CONTACT_TOLERANCE = 0.001


def _fail(path: str, message: str) -> None:
    raise ScenarioError(f"{path}: {message}")


def _number(path: str, value, low: float, high: float, low_open: bool = False) -> float:
    """`value` when it is a finite number in [low, high] ((low, high] with `low_open`)."""
    is_number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if (not is_number or not math.isfinite(value) or value > high
            or (value <= low if low_open else value < low)):
        bracket = "(" if low_open else "["
        _fail(path, f"must be a finite number in {bracket}{low:g}, {high:g}], got {value!r}")
    return float(value)


def _integer(path: str, value, low: int, high: int) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not low <= value <= high:
        _fail(path, f"must be an integer in [{low}, {high}], got {value!r}")
    return value


def check_object_name(path: str, name) -> None:
    """ScenarioError (naming `path`) unless `name` is a safe identifier no one else uses."""
    if not isinstance(name, str) or not OBJECT_NAME_PATTERN.fullmatch(name):
        _fail(path, f"must be a letter followed by at most 31 letters, digits or underscores, "
                    f"got {name!r}")
    if name.lower() in RESERVED_NAMES:
        _fail(path, f"{name!r} is reserved (the station uses it)")


def _validate_frame(scenario: Scenario) -> None:
    """Shelf, grid, gripper, angles and the scalar fields."""
    if not isinstance(scenario.name, str) or not scenario.name.isprintable() or not (
            0 < len(scenario.name) <= 64):
        _fail("name", f"must be 1 to 64 printable characters, got {scenario.name!r}")
    _integer("seed", scenario.seed, 0, 2**63 - 1)
    shelf = scenario.shelf
    for field, (low, high) in SHELF_BOUNDS.items():
        _number(f"shelf.{field}", getattr(shelf, field), low, high)
    _number("shelf.wall_thickness", shelf.wall_thickness, 0.0, 0.2, low_open=True)
    _number("shelf.floor_height", shelf.floor_height, 0.0, 1.5)
    grid = scenario.grid
    _integer("grid.cells_x", grid.cells_x, 1, MAX_GRID_CELLS)
    _integer("grid.cells_y", grid.cells_y, 1, MAX_GRID_CELLS)
    _number("grid.margin", grid.margin, 0.0, SHELF_BOUNDS["width"][1])
    if grid.margin >= min(shelf.depth, shelf.width) / 2:
        _fail("grid.margin", "leaves no room for the grid")
    gripper = scenario.gripper
    stroke = _number("gripper.stroke", gripper.stroke, 0.0, 0.3, low_open=True)
    if _number("gripper.grasp_margin", gripper.grasp_margin, 0.0, stroke) >= stroke:
        _fail("gripper.grasp_margin", f"must be smaller than gripper.stroke ({stroke:g})")
    _number("gripper.swept_half_width", gripper.swept_half_width, stroke / 2, 0.3)
    _number("gripper.finger_reach", gripper.finger_reach, 0.0, 0.2)
    _number("gripper.planning_clearance", gripper.planning_clearance, 0.0, 0.1)
    _number("min_gap", scenario.min_gap, 0.0, 0.1)
    angles = scenario.approach_angles_deg
    if not isinstance(angles, list) or not 1 <= len(angles) <= MAX_APPROACH_ANGLES:
        _fail("approach_angles_deg", f"must hold 1 to {MAX_APPROACH_ANGLES} angles")
    for k, angle in enumerate(angles):
        _number(f"approach_angles_deg[{k}]", angle, -89.0, 89.0)
    if len(set(angles)) != len(angles):
        _fail("approach_angles_deg", "angles must be distinct")


def _validate_object(k: int, obj: ObjectConfig, shelf: ShelfConfig) -> None:
    where = f"objects[{k}]"
    check_object_name(f"{where}.name", obj.name)
    if obj.shape not in SHAPES:
        _fail(f"{where}.shape", f"must be one of {', '.join(SHAPES)}, got {obj.shape!r}")
    if obj.kind not in KINDS:
        _fail(f"{where}.kind", f"must be one of {', '.join(KINDS)}, got {obj.kind!r}")
    expected = 2 if obj.shape == "cylinder" else 3
    if not isinstance(obj.size, list) or len(obj.size) != expected:
        _fail(f"{where}.size", f"a {obj.shape} needs {expected} sizes "
                               f"({'[radius, height]' if expected == 2 else '[sx, sy, height]'})")
    footprint_limits = [shelf.depth / 2] if obj.shape == "cylinder" else [shelf.depth, shelf.width]
    for j, limit in enumerate(footprint_limits):
        _number(f"{where}.size[{j}]", obj.size[j], MIN_OBJECT_SIZE, max(limit, MIN_OBJECT_SIZE))
    _number(f"{where}.size[{expected - 1}]", obj.height, MIN_OBJECT_SIZE,
            max(shelf.height - 0.02, MIN_OBJECT_SIZE))
    _number(f"{where}.x", obj.x, -MAX_SHELF_SIZE, MAX_SHELF_SIZE)  # inside: the footprint below
    _number(f"{where}.y", obj.y, -MAX_SHELF_SIZE, MAX_SHELF_SIZE)
    _number(f"{where}.yaw", obj.yaw, -100.0, 100.0)
    _number(f"{where}.mass", obj.mass, 0.0, MAX_MASS, low_open=True)
    poly = obj.footprint()
    if (poly[:, 0].min() < 0 or poly[:, 0].max() > shelf.depth
            or abs(poly[:, 1]).max() > shelf.width / 2):
        _fail(where, f"object {obj.name} lies outside the shelf workspace")


def validate(scenario: Scenario, overlaps: bool = True) -> None:
    """Raise ScenarioError naming the field (`objects[3].size[0]: ...`) when the scenario is
    malformed, out of range or physically impossible: every number finite and in range, names
    safe and not reserved, sizes bounded, objects inside the shelf and apart or touching (no
    deeper than CONTACT_TOLERANCE inside each other, unless `overlaps` is False: a scene to
    settle), the target one of them."""
    _validate_frame(scenario)
    objects = scenario.objects
    if not isinstance(objects, list) or not 1 <= len(objects) <= MAX_OBJECTS:
        _fail("objects", f"must hold 1 to {MAX_OBJECTS} objects")
    seen: dict[str, int] = {}
    for k, obj in enumerate(objects):
        _validate_object(k, obj, scenario.shelf)
        if obj.name.lower() in seen:
            _fail(f"objects[{k}].name", f"{obj.name!r} repeats objects[{seen[obj.name.lower()]}]"
                                        " (names are compared ignoring case)")
        seen[obj.name.lower()] = k
    names = [o.name for o in objects]
    if scenario.target not in names:
        _fail("target", f"{scenario.target!r} is not the name of one of the objects")
    for i, j, depth in interpenetrations(scenario) if overlaps else []:
        _fail("objects", f"objects[{i}] ({names[i]}) and objects[{j}] ({names[j]}) "
                         f"overlap: they interpenetrate by {depth * 1000:.1f} mm (touching is "
                         f"allowed, up to {CONTACT_TOLERANCE * 1000:g} mm; `tsad scene --settle` "
                         "separates them)")


def footprint_pose(obj: ObjectConfig) -> tuple:
    """(shape, size, x, y, yaw): the footprint as `geometry2d.footprint_penetration` takes it."""
    return obj.shape, obj.size, obj.x, obj.y, obj.yaw


def interpenetrations(scenario: Scenario, tolerance: float = CONTACT_TOLERANCE
                      ) -> list[tuple[int, int, float]]:
    """(i, j, depth in m) of every pair of objects whose footprints interpenetrate deeper than
    `tolerance` (contact, within it, is not overlap)."""
    poses = [footprint_pose(o) for o in scenario.objects]
    found = []
    for i in range(len(poses)):
        for j in range(i + 1, len(poses)):
            depth = footprint_penetration(poses[i], poses[j])
            if depth > tolerance:
                found.append((i, j, depth))
    return found


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

    atomic_write_text(path, yaml_dump_typed(scenario))


def _scale_unset_grid(scenario: Scenario, data) -> None:
    """The grid's cell counts the file does not set, scaled to its shelf (`GridConfig.for_shelf`)."""
    grid = data.get("grid") if isinstance(data, dict) else None
    grid = grid if isinstance(grid, dict) else {}
    if isinstance(scenario.grid.margin, (int, float)) and isinstance(scenario.shelf, ShelfConfig):
        try:
            scaled = GridConfig.for_shelf(scenario.shelf, float(scenario.grid.margin))
        except (TypeError, ValueError, ArithmeticError):  # malformed: validation names it
            return
        for field in ("cells_x", "cells_y"):
            if field not in grid:
                setattr(scenario.grid, field, getattr(scaled, field))


def load_scenario(path: str | Path, overlaps: bool = True) -> Scenario:
    """Load and validate a scenario YAML file (`validate`, with `overlaps`); raise ScenarioError
    on any problem."""
    from pydrake.common.yaml import yaml_load, yaml_load_typed

    path = Path(path)
    if not path.is_file():
        raise ScenarioError(f"scenario file not found: {path}")
    try:
        scenario = yaml_load_typed(schema=Scenario, filename=str(path))
        data = yaml_load(filename=str(path))
    except Exception as err:  # Drake raises RuntimeError with a multi-line message
        raise ScenarioError(f"malformed scenario YAML {path}: {first_line(err)}") from None
    _scale_unset_grid(scenario, data)
    try:
        validate(scenario, overlaps)
    except ScenarioError as err:
        raise ScenarioError(f"scenario {path}: {err}") from None
    return scenario
