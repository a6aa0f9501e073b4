"""The plan format `tsad-plan/1`: a scenario and its pick-and-place actions, as versioned JSON.

Any planner's plan can be written in it and checked by `tsad verify` (docs/plan-format.md). The
JSON Schema ships as `tsad_drake/data/plan.schema.json`; `parse_plan` applies the same rules by
hand (no schema library is a dependency) and names the first offending field
(`actions[1].place_xy: ...`, PlanFormatError, exit status 2 on the command line). Beyond the
schema, `check_actions` refuses an action on an object the scenario does not have and a placement
whose footprint leaves the shelf (following each object's yaw through the plan).

Angles are degrees in the file (as in plan.json) and radians in the `Action`s it yields.
"""

from __future__ import annotations

import dataclasses as dc
import json
import math
from pathlib import Path

from tsad_drake.errors import ScenarioError, UsageError, first_line
from tsad_drake.planning.types import Action
from tsad_drake.scenario import Scenario, validate

#: the format's name and version (the `format` field)
PLAN_FORMAT = "tsad-plan/1"
#: the JSON Schema of the format, shipped in the package
SCHEMA_PATH = Path(__file__).resolve().parent / "data" / "plan.schema.json"
#: deg, largest |approach angle| of a pick or place (the gripper must face into the shelf)
MAX_ANGLE_DEG = 89.0
#: most actions in one plan
MAX_PLAN_ACTIONS = 100
#: largest plan file read
MAX_PLAN_BYTES = 16 * 1024 * 1024

TOP_KEYS = ("format", "scenario", "actions", "retrieve_target", "theta_retrieve_deg", "meta")
ACTION_KEYS = ("object", "theta_pick_deg", "place_xy", "theta_place_deg", "sub_search")
REQUIRED_TOP = ("format", "scenario", "actions")
REQUIRED_ACTION = ("object", "theta_pick_deg", "place_xy", "theta_place_deg")


class PlanFormatError(UsageError):
    """A plan file that is malformed or does not fit its scenario (exit status 2)."""


@dc.dataclass
class PlanDocument:
    """A loaded plan: the scenario, its actions (radians) and whether the target is taken out."""

    scenario: Scenario
    actions: list[Action]
    retrieve_target: bool = False
    theta_retrieve: float | None = None  #: rad, the retrieval angle; None: any angle
    meta: dict = dc.field(default_factory=dict)
    scenario_ref: str | dict = ""  #: the `scenario` field as written (path or inline)


def load_schema() -> dict:
    """The shipped JSON Schema of the format."""
    return json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))


def _fail(where: str, message: str) -> None:
    raise PlanFormatError(f"{where}: {message}")


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _angle(where: str, value) -> float:
    if not _is_number(value) or not math.isfinite(value) or abs(value) > MAX_ANGLE_DEG:
        _fail(where, f"must be a finite number of degrees in [-{MAX_ANGLE_DEG:g}, "
                     f"{MAX_ANGLE_DEG:g}], got {value!r}")
    return math.radians(float(value))


def _keys(where: str, record: dict, allowed: tuple[str, ...], required: tuple[str, ...]) -> None:
    for key in record:
        if key not in allowed:
            _fail(f"{where}.{key}" if where else key,
                  f"unknown field (allowed: {', '.join(allowed)})")
    for key in required:
        if key not in record:
            _fail(f"{where}.{key}" if where else key, "missing")


def parse_action(where: str, record) -> Action:
    """One `actions[i]` record -> Action (radians); PlanFormatError naming the field."""
    if not isinstance(record, dict):
        _fail(where, f"must be an object, got {type(record).__name__}")
    _keys(where, record, ACTION_KEYS, REQUIRED_ACTION)
    name = record["object"]
    if not isinstance(name, str) or not name:
        _fail(f"{where}.object", f"must be an object name, got {name!r}")
    theta_pick = _angle(f"{where}.theta_pick_deg", record["theta_pick_deg"])
    xy = record["place_xy"]
    if (not isinstance(xy, list) or len(xy) != 2
            or not all(_is_number(v) and math.isfinite(v) for v in xy)):
        _fail(f"{where}.place_xy", f"must be [x, y], two finite numbers in metres, got {xy!r}")
    theta_place = _angle(f"{where}.theta_place_deg", record["theta_place_deg"])
    sub = record.get("sub_search", 0)
    if not isinstance(sub, int) or isinstance(sub, bool) or sub < 0:
        _fail(f"{where}.sub_search", f"must be a non-negative integer, got {sub!r}")
    return Action(name, theta_pick, float(xy[0]), float(xy[1]), theta_place, sub)


def scenario_from_dict(data: dict) -> Scenario:
    """An inline scenario (the fields of `Scenario`, as `dc.asdict` gives them), validated."""
    from pydrake.common.yaml import yaml_load_typed

    try:
        scenario = yaml_load_typed(schema=Scenario, data=json.dumps(data))
    except Exception as err:  # Drake raises RuntimeError with a multi-line message
        raise PlanFormatError(f"scenario: {first_line(err)}") from None
    try:
        validate(scenario)
    except ScenarioError as err:
        raise PlanFormatError(f"scenario.{err}") from None
    return scenario


def _scenario(value, base_dir: Path | None) -> Scenario:
    from tsad_drake.scenario import load_scenario

    if isinstance(value, dict):
        return scenario_from_dict(value)
    if isinstance(value, str) and value.strip():
        path = Path(value)
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        try:
            return load_scenario(path)
        except ScenarioError as err:
            raise PlanFormatError(f"scenario: {err}") from None
    _fail("scenario", "must be the path of a scenario YAML file or a scenario object, got "
                      f"{value!r}")
    raise AssertionError  # unreachable


def check_actions(scenario: Scenario, actions: list[Action], where: str = "actions") -> None:
    """PlanFormatError unless every action names an object of `scenario` and places it with its
    whole footprint inside the shelf (each object's pose followed through the plan as the world
    model moves it: centre to (x, y), yaw turned by theta_place - theta_pick)."""
    poses = {o.name: o for o in scenario.objects}
    shelf = scenario.shelf
    for i, action in enumerate(actions):
        if action.object not in poses:
            _fail(f"{where}[{i}].object", f"no object named {action.object!r} in scenario "
                  f"{scenario.name} (objects: {', '.join(poses)})")
        obj = poses[action.object]
        moved = dc.replace(obj, x=float(action.x), y=float(action.y),
                           yaw=float(obj.yaw + action.theta_place - action.theta_pick))
        poly = moved.footprint()
        if (poly[:, 0].min() < 0.0 or poly[:, 0].max() > shelf.depth
                or abs(poly[:, 1]).max() > shelf.width / 2):
            _fail(f"{where}[{i}].place_xy", f"({action.x:g}, {action.y:g}) puts {obj.name}'s "
                  f"footprint outside the shelf (x in [0, {shelf.depth:g}], |y| <= "
                  f"{shelf.width / 2:g} m)")
        poses[action.object] = moved


def parse_plan(data, base_dir: str | Path | None = None) -> PlanDocument:
    """A plan document (parsed JSON) -> PlanDocument; PlanFormatError naming the first bad field.

    Args:
        data: the JSON value.
        base_dir: where a relative scenario path is resolved (the plan file's folder).
    """
    if not isinstance(data, dict):
        _fail("plan", f"must be a JSON object, got {type(data).__name__}")
    if "format" in data and data["format"] != PLAN_FORMAT:
        _fail("format", f"must be {PLAN_FORMAT!r}, got {data['format']!r}")
    _keys("", data, TOP_KEYS, REQUIRED_TOP)
    records = data["actions"]
    if not isinstance(records, list) or len(records) > MAX_PLAN_ACTIONS:
        _fail("actions", f"must be a list of at most {MAX_PLAN_ACTIONS} actions")
    actions = [parse_action(f"actions[{i}]", r) for i, r in enumerate(records)]
    retrieve = data.get("retrieve_target", False)
    if not isinstance(retrieve, bool):
        _fail("retrieve_target", f"must be true or false, got {retrieve!r}")
    theta = data.get("theta_retrieve_deg")
    theta_retrieve = None if theta is None else _angle("theta_retrieve_deg", theta)
    meta = data.get("meta", {})
    if not isinstance(meta, dict):
        _fail("meta", f"must be an object, got {type(meta).__name__}")
    scenario = _scenario(data["scenario"], None if base_dir is None else Path(base_dir))
    check_actions(scenario, actions)
    return PlanDocument(scenario, actions, retrieve, theta_retrieve, meta, data["scenario"])


def load_plan(path: str | Path) -> PlanDocument:
    """Read and validate a `tsad-plan/1` file (a relative scenario path is taken from its folder);
    PlanFormatError on any problem."""
    path = Path(path)
    if not path.is_file():
        raise PlanFormatError(f"plan file not found: {path}")
    try:
        if path.stat().st_size > MAX_PLAN_BYTES:
            raise PlanFormatError(f"plan {path}: larger than {MAX_PLAN_BYTES // 2**20} MiB")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise PlanFormatError(f"cannot read plan {path}: {err}") from None
    try:
        data = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as err:
        raise PlanFormatError(f"plan {path}: malformed JSON: {err}") from None
    try:
        return parse_plan(data, path.parent)
    except PlanFormatError as err:
        raise PlanFormatError(f"plan {path}: {err}") from None


def action_json(action: Action) -> dict:
    """An Action as a `tsad-plan/1` action record (degrees; full precision, so that the file
    reads back to the same action up to the last bit of the angle conversion)."""
    return {"object": action.object, "theta_pick_deg": math.degrees(action.theta_pick),
            "place_xy": [float(action.x), float(action.y)],
            "theta_place_deg": math.degrees(action.theta_place),
            "sub_search": int(action.sub_search)}


def plan_json(scenario: Scenario | str, actions: list[Action], retrieve_target: bool = False,
              theta_retrieve: float | None = None, meta: dict | None = None) -> dict:
    """A `tsad-plan/1` document: `scenario` inline (a Scenario) or as a path (a str, relative to
    where the plan file will be); angles in radians (written in degrees)."""
    document = {"format": PLAN_FORMAT,
                "scenario": scenario if isinstance(scenario, str) else dc.asdict(scenario),
                "actions": [action_json(a) for a in actions],
                "retrieve_target": bool(retrieve_target)}
    if theta_retrieve is not None:
        document["theta_retrieve_deg"] = math.degrees(theta_retrieve)
    if meta:
        document["meta"] = meta
    return document


def plan_from_episode(scenario: Scenario, row: dict) -> dict:
    """The `tsad-plan/1` document of a `tsad plan` run (plan.json `row`): its executed actions on
    true objects, the target retrieval when the episode retrieved it, the scene inline."""
    from tsad_drake.execution.record import ActionRecord

    actions = [ActionRecord.from_json(a).true_action() for a in row["actions"]]
    meta = {"source": "tsad plan", "planner": row.get("planner"),
            "feasibility": row.get("feasibility"), "seed": row.get("seed"),
            "world": row.get("world"), "theta_star_deg": row.get("theta_star_deg"),
            "success": row.get("success")}
    return plan_json(scenario, actions, retrieve_target=bool(row.get("success")), meta=meta)
