"""Helpers every `tsad` command shares: the parser that exits with status 2, scenario and output
arguments."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from tsad_drake.errors import EXIT_BAD_INPUT, UsageError


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse prints usage too)
        print(f"tsad: error: {message}", file=sys.stderr)
        raise SystemExit(EXIT_BAD_INPUT)


def resolve_scenario(spec: str, seed: int, occluded: bool = False):
    """A built-in scenario name ("1", "2", "3", "real") with a seed, or a scenario YAML path."""
    from tsad_drake.scenario import load_scenario
    from tsad_drake.scenes import BUILTIN_SCENARIOS, generate_scenario

    if spec in BUILTIN_SCENARIOS:
        if seed < 0:
            raise UsageError("--seed must be non-negative")
        return generate_scenario(spec, seed, occluded=occluded)
    if spec.endswith((".yaml", ".yml")) or os.sep in spec or Path(spec).exists():
        return load_scenario(spec)
    raise UsageError(f"unknown scenario {spec!r}: use one of {', '.join(BUILTIN_SCENARIOS)} "
                     "or the path of a scenario YAML file")


def prepare_out_dir(path: str | Path) -> Path:
    """Create the output directory and prove it is writable before any work is done."""
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".tsad_write_probe"
        probe.write_text("")
        probe.unlink()
    except OSError as err:
        raise UsageError(f"cannot write to output directory {out}: {err.strerror}") from None
    return out


def prepare_out_file(path: str | Path) -> Path:
    """Make sure the parent of an output file exists and is writable."""
    out = Path(path)
    prepare_out_dir(out.parent if str(out.parent) else ".")
    return out


def add_scenario_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scenario", required=True,
                   help="built-in scenario 1, 2, 3 or real, or the path of a scenario YAML file "
                        "(as written by `tsad scene`)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the generated scene for a built-in scenario (default 0)")
    p.add_argument("--occluded", action="store_true",
                   help="generate a scene whose target is fully hidden from every view")
