"""Plugins: a Python file or module of your own, imported before the command line is built, that
registers planners (`planning.registry.register`) so `tsad plan` and `tsad bench` run them by name.

`tsad --plugin examples/own_planner.py plan --planner greedy ...`; bench workers import the same
plugins before each episode (`bench.runner.EpisodeSpec.plugins`).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path

from tsad_drake.errors import UsageError, first_line

#: plugins imported in this process: name as given -> module
_LOADED: dict[str, object] = {}


def plugin_reference(name: str) -> str:
    """How `name` is imported again (by a bench worker): a file as its absolute path, a module
    by its dotted name."""
    return str(Path(name).resolve()) if name.endswith(".py") else name


def load_plugin(name: str):
    """Import plugin `name` once per process: a `.py` file path or a module name. UsageError in
    one line when it is missing or fails to import."""
    reference = plugin_reference(name)
    if reference in _LOADED:
        return _LOADED[reference]
    try:
        if reference.endswith(".py"):
            path = Path(reference)
            if not path.is_file():
                raise UsageError(f"--plugin {name}: no such file")
            module_name = f"tsad_plugin_{path.stem}"
            spec = importlib.util.spec_from_file_location(module_name, path)
            module = importlib.util.module_from_spec(spec)
            sys.modules[module_name] = module
            spec.loader.exec_module(module)
        else:
            module = importlib.import_module(reference)
    except UsageError:
        raise
    except Exception as err:  # a plugin's own error, quoted in one line
        raise UsageError(f"--plugin {name}: cannot import it: {type(err).__name__}: "
                         f"{first_line(err)}") from None
    _LOADED[reference] = module
    return module


def plugins_in(argv: list[str]) -> list[str]:
    """The values of every `--plugin X` / `--plugin=X` in `argv` (read before the parser exists,
    since the plugins add names to its choices)."""
    found = []
    for k, arg in enumerate(argv):
        if arg == "--plugin" and k + 1 < len(argv):
            found.append(argv[k + 1])
        elif arg.startswith("--plugin="):
            found.append(arg.split("=", 1)[1])
    return found
