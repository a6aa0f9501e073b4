"""`tsad scene --from`: the model directives `tsad plan --motion` exports read back into the
scenario they came from (every field within 1e-6), and bad directives refused with one line."""

import dataclasses as dc
import math

import pytest
from cli_harness import assert_clean, invoke
from touching_scenes import touching_scene

from tsad_drake.motion.export import SETTINGS_FILE, write_scene_directives
from tsad_drake.motion.import_dmd import load_scene_directives
from tsad_drake.scenario import load_scenario
from tsad_drake.scenes import generate_scenario


def assert_close(a, b, path="scenario"):
    """Equal field by field, numbers within 1e-6."""
    if isinstance(a, float | int) and not isinstance(a, bool):
        assert math.isclose(a, b, abs_tol=1e-6), (path, a, b)
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            assert_close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_close(x, y, f"{path}[{i}]")
    else:
        assert a == b, (path, a, b)


@pytest.mark.parametrize("make", [touching_scene, lambda: generate_scenario("3", 0)],
                         ids=["touching", "scenario-3-seed-0"])
def test_exported_scene_imports_back_to_the_original(make, tmp_path, capsys):
    scenario = make()
    path = write_scene_directives(scenario, tmp_path / "export")
    assert_close(dc.asdict(load_scene_directives(path)), dc.asdict(scenario))
    out = tmp_path / "imported.yaml"
    code, stdout, _ = invoke(capsys, ["scene", "--from", path, "--out", out])
    assert code == 0 and f"target {scenario.target}" in stdout
    assert_close(dc.asdict(load_scenario(out)), dc.asdict(scenario))


def test_without_the_settings_file_geometry_target_and_kinds_still_come_back(tmp_path):
    scenario = touching_scene()
    path = write_scene_directives(scenario, tmp_path / "export")
    (path.parent / SETTINGS_FILE).unlink()
    back = load_scene_directives(path)
    assert back.target == "target" and back.shelf == scenario.shelf
    assert_close([dc.asdict(o) for o in back.objects], [dc.asdict(o) for o in scenario.objects])


def _edit(path, old, new):
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


@pytest.mark.parametrize("case, needle", [
    ("missing", "not found"),
    ("sphere", "unknown model kind: a Sphere"),
    ("no-target", "no target recorded"),
    ("bad-model-file", "cannot load the model directives"),
    ("not-yaml", "cannot load the model directives"),
])
def test_bad_directives_exit_2_with_one_line(case, needle, tmp_path, capsys):
    path = write_scene_directives(touching_scene(), tmp_path / "export")
    if case == "missing":
        path = tmp_path / "nope.dmd.yaml"
    elif case == "sphere":
        _edit(path.parent / "blocker.sdf", "<box><size>0.05 0.05 0.14</size></box>",
              "<sphere><radius>0.02</radius></sphere>")
    elif case == "no-target":
        text = path.read_text()
        path.write_text(text[:text.index("- add_frame:")])
    elif case == "bad-model-file":
        _edit(path, "package://tsad_drake_scene/blocker.sdf", "package://tsad_drake_scene/x.sdf")
    elif case == "not-yaml":
        path.write_text("directives: [ {add_model: \n")
    result = invoke(capsys, ["scene", "--from", path, "--out", tmp_path / "out.yaml"])
    assert_clean(result, codes=(2,))
    assert needle in result[2], result[2]
    assert not (tmp_path / "out.yaml").exists()
