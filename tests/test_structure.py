"""The package's imports run one way (tools/structure.py): no unit imports a unit above it."""

from pathlib import Path

from tools.structure import LAYER_OF, module_table, violations


def test_no_import_runs_up_and_every_unit_has_a_layer():
    assert violations() == []


def test_an_import_up_is_found_in_function_bodies_too(tmp_path):
    package = tmp_path / "tsad_drake"
    (package / "planning").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "planning" / "__init__.py").write_text("")
    (package / "planning" / "state.py").write_text(
        "from tsad_drake.geometry2d import x\n\ndef f():\n    from tsad_drake.bench import runner\n")
    (package / "newthing.py").write_text("import tsad_drake.scenario\n")
    found = violations(package)
    assert LAYER_OF["bench"] > LAYER_OF["planning"] > LAYER_OF["geometry2d"]
    assert found == ["newthing: in no layer (add it to tools/structure.py LAYERS)",
                     "tsad_drake/planning/state.py:4: planning (layer 2) imports bench (layer 8): "
                     "an import up"]


def test_the_design_document_lists_every_module():
    # docs/design.md's module table is `python tools/structure.py --modules`, kept up to date
    text = (Path(__file__).resolve().parents[1] / "docs" / "design.md").read_text(encoding="utf-8")
    section = text.split("## Every module", 1)[1].split("\n## ", 1)[0]
    listed = [line for line in section.splitlines() if line.startswith("|")]
    assert listed == module_table(), "paste `python tools/structure.py --modules` into docs/design.md"
