"""The package's import layers, and every import that runs up against them.

    python tools/structure.py          # the layers, which unit imports which; exit 1 on an upward import
    python tools/structure.py --modules  # every module with its layer and docstring's first line

The module table is docs/design.md's "Every module" section (tests/test_structure.py keeps the two
equal: after adding or renaming a module, paste the `--modules` output there).

A unit is a subpackage (`planning`, `planners`, `bench`, ...) or a top-level module (`pipeline`,
`run_config`, ...). Units sit in layers, lowest first (`LAYERS`); a unit may import units of its
own layer or below, never above. Every import counts: module level and inside functions alike
(read from the AST of every module). Import cycles are a separate check
(`../shared/tools/structure_report.py`). The order, bottom to top:

0. foundations: errors, outputs, runtime, plugins, geometry2d, scenario, viewpoints
1. perception and the station's models (perception reads depth; its data types feed planning)
2. planning: the framework (state, feasibility models, actions, registry, re-planning policy)
3. the algorithms (`planners`), the scene generator, the motion level
4. the generated scenes (generator + `optimal` as its solvability check), the closed loop
   (`execution`), the station placement
5. the physics world, the network (`prehensile`: it trains on generated scenes), the plan format
6. the run config (every component's settings), rendering output
7. the composition root (`pipeline`) and plan verification
8. the bench
9. the command line
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "tsad_drake"

#: units by layer, lowest first
LAYERS: tuple[tuple[str, ...], ...] = (
    ("tsad_drake", "errors", "outputs", "runtime", "plugins", "geometry2d", "scenario",
     "viewpoints"),
    ("perception", "station_models", "station_ik", "station"),
    ("planning",),
    ("planners", "scenario_generator", "motion"),
    ("scenes", "execution", "placement"),
    ("physics", "prehensile", "plan_format"),
    ("run_config", "render_output"),
    ("pipeline", "verification"),
    ("bench",),
    ("cli", "__main__"),
)
LAYER_OF = {unit: k for k, units in enumerate(LAYERS) for unit in units}


def unit_of(module: str) -> str:
    """`tsad_drake.planning.state` -> `planning`; the package itself -> `tsad_drake`."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def imports(package: Path = PACKAGE) -> dict[str, set[tuple[str, str]]]:
    """unit -> {(imported unit, "file:line")} over every import of the package's modules."""
    found: dict[str, set[tuple[str, str]]] = {}
    for path in sorted(package.rglob("*.py")):
        module = ".".join(path.relative_to(package.parent).with_suffix("").parts)
        unit = unit_of(module.removesuffix(".__init__"))
        found.setdefault(unit, set())
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            for name in names:
                if name == package.name or name.startswith(package.name + "."):
                    target = unit_of(name)
                    if target != unit:
                        where = f"{path.relative_to(package.parent)}:{node.lineno}"
                        found[unit].add((target, where))
    return found


def violations(package: Path = PACKAGE) -> list[str]:
    """One line per unit without a layer and per import of a unit in a higher layer."""
    problems = []
    for unit, targets in sorted(imports(package).items()):
        if unit not in LAYER_OF:
            problems.append(f"{unit}: in no layer (add it to tools/structure.py LAYERS)")
            continue
        for target, where in sorted(targets, key=lambda t: t[1]):
            if target not in LAYER_OF:
                problems.append(f"{where}: imports {target}, which is in no layer")
            elif LAYER_OF[target] > LAYER_OF[unit]:
                problems.append(f"{where}: {unit} (layer {LAYER_OF[unit]}) imports {target} "
                                f"(layer {LAYER_OF[target]}): an import up")
    return problems


def summary(path: Path) -> str:
    """The first sentence of a module's docstring ("-" when it has none)."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or "-"
    paragraph = " ".join(doc.strip().split("\n\n")[0].split())
    return paragraph.split(". ")[0].removesuffix(".").replace("|", "/")


def module_table(package: Path = PACKAGE) -> list[str]:
    """Markdown table rows: every module of the package (packages by their `__init__`), its layer
    and what it holds, in path order."""
    rows = ["| module | layer | what it holds |", "|---|---|---|"]
    for path in sorted(package.rglob("*.py")):
        parts = path.relative_to(package.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        name = ".".join(parts)
        layer = LAYER_OF.get(unit_of(name), "?")
        rows.append(f"| `{name}` | {layer} | {summary(path)} |")
    return rows


def main() -> int:
    if sys.argv[1:] == ["--modules"]:
        print("\n".join(module_table()))
        return 0
    found = imports()
    for k, units in enumerate(LAYERS):
        print(f"layer {k}:")
        for unit in units:
            if unit in found:
                below = sorted({t for t, _ in found[unit]})
                print(f"  {unit:<20} imports {', '.join(below) or '-'}")
    problems = violations()
    for line in problems:
        print(line)
    print(f"{len(problems)} upward imports or units without a layer")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
