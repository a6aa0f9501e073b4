"""Issue 18's mutated scenario YAML files as a table: each mutation of a valid scene either loads
(exit 0) or is refused before any work with one line naming the field (exit 2), never a traceback."""

import copy
import math

import pytest
import yaml
from cli_harness import assert_clean, invoke

from tsad_drake.scenario import load_scenario, save_scenario
from tsad_drake.scenes import generate_scenario

DELETE = object()  #: mutation value: remove the key
NAN, INF = math.nan, math.inf


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> dict:
    """Scenario 3 seed 0 (quick to generate) as plain YAML data."""
    path = tmp_path_factory.mktemp("base") / "scene.yaml"
    save_scenario(generate_scenario("3", 0), path)
    return yaml.safe_load(path.read_text())


def _huge_list(data):
    return [copy.deepcopy(data["objects"][1]) for _ in range(50)]


#: (id, key path, new value or DELETE or a function of the whole data, text the error must hold;
#: "" when the mutated scene is still valid)
MUTATIONS = [
    # the shelf
    ("shelf-depth-nan", ("shelf", "depth"), NAN, "shelf.depth"),
    ("shelf-depth-inf", ("shelf", "depth"), INF, "shelf.depth"),
    ("shelf-depth-negative", ("shelf", "depth"), -0.32, "shelf.depth"),
    ("shelf-depth-zero", ("shelf", "depth"), 0.0, "shelf.depth"),
    ("shelf-depth-huge", ("shelf", "depth"), 1e9, "shelf.depth"),
    ("shelf-width-text", ("shelf", "width"), "wide", "malformed"),
    ("shelf-height-negative", ("shelf", "height"), -1.0, "shelf.height"),
    ("shelf-too-low", ("shelf", "height"), 0.12, "size[2]"),
    ("shelf-below-bounds", ("shelf", "height"), 0.05, "shelf.height"),
    ("shelf-too-wide", ("shelf", "width"), 1.2, "shelf.width"),
    ("shelf-wall-zero", ("shelf", "wall_thickness"), 0.0, "shelf.wall_thickness"),
    ("shelf-wall-nan", ("shelf", "wall_thickness"), NAN, "shelf.wall_thickness"),
    ("floor-nan", ("shelf", "floor_height"), NAN, "shelf.floor_height"),
    ("floor-negative", ("shelf", "floor_height"), -1.0, "shelf.floor_height"),
    ("floor-huge", ("shelf", "floor_height"), 1e6, "shelf.floor_height"),
    # the grid: its size bounds memory
    ("cells-zero", ("grid", "cells_x"), 0, "grid.cells_x"),
    ("cells-negative", ("grid", "cells_x"), -1, "grid.cells_x"),
    ("cells-huge", ("grid", "cells_x"), 10**6, "grid.cells_x"),
    ("cells-y-huge", ("grid", "cells_y"), 100_000, "grid.cells_y"),
    ("cells-float", ("grid", "cells_x"), 2.5, "malformed"),
    ("margin-nan", ("grid", "margin"), NAN, "grid.margin"),
    ("margin-negative", ("grid", "margin"), -0.01, "grid.margin"),
    ("margin-no-room", ("grid", "margin"), 0.3, "grid.margin"),
    ("margin-inf", ("grid", "margin"), INF, "grid.margin"),
    # the gripper
    ("stroke-zero", ("gripper", "stroke"), 0.0, "gripper.stroke"),
    ("stroke-negative", ("gripper", "stroke"), -0.085, "gripper.stroke"),
    ("stroke-nan", ("gripper", "stroke"), NAN, "gripper.stroke"),
    ("grasp-margin-negative", ("gripper", "grasp_margin"), -0.1, "gripper.grasp_margin"),
    ("grasp-margin-above-stroke", ("gripper", "grasp_margin"), 0.1, "gripper.grasp_margin"),
    ("swept-zero", ("gripper", "swept_half_width"), 0.0, "gripper.swept_half_width"),
    ("swept-nan", ("gripper", "swept_half_width"), NAN, "gripper.swept_half_width"),
    ("finger-reach-inf", ("gripper", "finger_reach"), INF, "gripper.finger_reach"),
    ("clearance-negative", ("gripper", "planning_clearance"), -1.0, "gripper.planning_clearance"),
    # approach angles
    ("angles-empty", ("approach_angles_deg",), [], "approach_angles_deg"),
    ("angle-90", ("approach_angles_deg",), [90.0], "approach_angles_deg[0]"),
    ("angle-minus-95", ("approach_angles_deg",), [0.0, -95.0], "approach_angles_deg[1]"),
    ("angle-nan", ("approach_angles_deg",), [NAN], "approach_angles_deg[0]"),
    ("angles-repeated", ("approach_angles_deg",), [0.0, 0.0], "distinct"),
    ("angles-too-many", ("approach_angles_deg",), [float(a) / 10 for a in range(100)],
     "approach_angles_deg"),
    ("angle-text", ("approach_angles_deg",), ["left"], "malformed"),
    # the scene as a whole
    ("target-empty", ("target",), "", "target"),
    ("target-ghost", ("target",), "ghost", "target"),
    ("target-missing", ("target",), DELETE, "target"),
    ("objects-none", ("objects",), [], "objects"),
    ("objects-too-many", ("objects",), _huge_list, "objects"),
    ("min-gap-nan", ("min_gap",), NAN, "min_gap"),
    ("min-gap-negative", ("min_gap",), -1.0, "min_gap"),
    ("seed-negative", ("seed",), -1, "seed"),
    ("label-escape-codes", ("name",), "\x1b[2J", "name"),
    ("label-empty", ("name",), "", "name"),
    ("label-list", ("name",), ["a"], "malformed"),
    ("unknown-key", ("colour",), "red", "malformed"),
    # one object's numbers
    ("radius-nan", ("objects", 2, "size", 0), NAN, "objects[2].size[0]"),
    ("radius-negative", ("objects", 2, "size", 0), -0.02, "objects[2].size[0]"),
    ("side-zero", ("objects", 1, "size", 0), 0.0, "objects[1].size[0]"),
    ("height-nan", ("objects", 0, "size", 2), NAN, "objects[0].size[2]"),
    ("height-tall", ("objects", 0, "size", 2), 10.0, "objects[0].size[2]"),
    ("size-short", ("objects", 2, "size"), [0.03], "objects[2].size"),
    ("size-text", ("objects", 2, "size"), ["big", "small"], "malformed"),
    ("size-huge", ("objects", 1, "size", 1), 1e9, "objects[1].size[1]"),
    ("size-missing", ("objects", 1, "size"), DELETE, "objects[1].size"),
    ("mass-negative", ("objects", 3, "mass"), -1.0, "objects[3].mass"),
    ("mass-zero", ("objects", 3, "mass"), 0.0, "objects[3].mass"),
    ("mass-nan", ("objects", 3, "mass"), NAN, "objects[3].mass"),
    ("mass-inf", ("objects", 3, "mass"), INF, "objects[3].mass"),
    ("x-nan", ("objects", 4, "x"), NAN, "objects[4].x"),
    ("y-inf", ("objects", 4, "y"), INF, "objects[4].y"),
    ("x-outside", ("objects", 4, "x"), -0.5, "outside the shelf"),
    ("y-outside", ("objects", 4, "y"), 0.3, "outside the shelf"),
    ("yaw-nan", ("objects", 4, "yaw"), NAN, "objects[4].yaw"),
    ("yaw-huge", ("objects", 4, "yaw"), 1e10, "objects[4].yaw"),
    ("shape-sphere", ("objects", 4, "shape"), "sphere", "objects[4].shape"),
    ("kind-blob", ("objects", 4, "kind"), "blob", "objects[4].kind"),
    # names: file names, SDFormat and YAML text, Drake model names
    *[(f"name-{label}", ("objects", 5, "name"), name, "objects[5].name")
      for label, name in (("parent-path", "../../x"), ("absolute-path", "/abs/x"),
                          ("slash", "a/b"), ("quote", 'a"b'), ("angle", "a<b"),
                          ("scoped", "a::b"), ("shelf", "shelf"), ("ur5e", "ur5e"),
                          ("gripper", "gripper_2f85"), ("world", "World"), ("ground", "ground"),
                          ("digit-first", "1abc"), ("space", "a b"), ("long", "x" * 40),
                          ("empty", ""), ("accent", "caf\u00e9"), ("newline", "a\nb"))],
    ("name-repeated", ("objects", 5, "name"), lambda d: d["objects"][4]["name"], "objects[5].name"),
    ("name-case-repeated", ("objects", 5, "name"), lambda d: d["objects"][4]["name"].upper(),
     "objects[5].name"),
    ("name-number", ("objects", 5, "name"), 5, "malformed"),
    ("overlap", ("objects", 1, "x"), lambda d: d["objects"][0]["x"], "overlap"),
    # still valid
    ("valid-mass", ("objects", 3, "mass"), 1.5, ""),
    ("valid-label", ("name",), "my scene", ""),
    ("valid-angles", ("approach_angles_deg",), [-20.0, 0.0, 20.0], ""),
    ("valid-grid", ("grid", "cells_x"), 3, ""),
    ("valid-rename", ("objects", 5, "name"), "box_7", ""),
]


def _mutate(data: dict, path: tuple, value) -> dict:
    data = copy.deepcopy(data)
    holder = data
    for key in path[:-1]:
        holder = holder[key]
    if value is DELETE:
        del holder[path[-1]]
    else:
        holder[path[-1]] = value(data) if callable(value) else value
    if path == ("objects", 1, "x"):  # the overlap mutation: the same y too
        holder["y"] = data["objects"][0]["y"]
    return data


@pytest.mark.parametrize("mutation", MUTATIONS, ids=[m[0] for m in MUTATIONS])
def test_mutated_scenario(mutation, base, tmp_path, capsys):
    name, path, value, needle = mutation
    source = tmp_path / "mutated.yaml"
    source.write_text(yaml.safe_dump(_mutate(base, path, value), allow_unicode=True))
    out = tmp_path / "out" / "scene.yaml"
    code, stdout, stderr = result = invoke(capsys, ["scene", "--scenario", source, "--out", out])
    assert_clean(result, codes=(2,) if needle else (0,))
    if needle:
        assert needle in stderr, stderr
        assert not out.exists()
    else:
        assert load_scenario(out) == load_scenario(source)


def test_the_table_is_issue_18s_size():
    assert len(MUTATIONS) >= 57
    assert sum(1 for m in MUTATIONS if m[3]) >= 57
