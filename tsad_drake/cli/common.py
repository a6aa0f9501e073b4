"""Helpers every `tsad` command shares: the parser that exits with status 2, scenario, seed and
thread arguments, and the range checks every number on the command line passes before any work."""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from tsad_drake.errors import EXIT_BAD_INPUT, UsageError

#: largest seed accepted anywhere (numpy, torch and the generator all take it)
MAX_SEED = 2**31 - 1
#: built-in scenarios that have an occluded variant (the `real` shelf holds too few objects to
#: hide its target behind a front row: the generator would search for 30 s and give up)
OCCLUDED_SCENARIOS = ("1", "2", "3")
#: largest --threads
MAX_THREADS = 64


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse prints usage too)
        print(f"tsad: error: {message}", file=sys.stderr)
        raise SystemExit(EXIT_BAD_INPUT)


def check_int(option: str, value: int, low: int, high: int) -> int:
    """`value` when low <= value <= high; UsageError naming `option` otherwise."""
    if not low <= value <= high:
        raise UsageError(f"{option} must be between {low} and {high}, got {value}")
    return value


def check_float(option: str, value: float, low: float, high: float) -> float:
    """`value` when it is finite and low < value <= high; UsageError otherwise."""
    if not (math.isfinite(value) and low < value <= high):
        raise UsageError(f"{option} must be a finite number above {low:g} and at most {high:g}, "
                         f"got {value}")
    return value


def check_seeds(option: str, first: int, count: int = 1) -> None:
    """Seeds first..first+count-1 all within [0, MAX_SEED]."""
    check_int(option, first, 0, MAX_SEED)
    if first + count - 1 > MAX_SEED:
        raise UsageError(f"{option} {first} with {count} scenes runs past the largest seed {MAX_SEED}")


def is_builtin(spec: str) -> bool:
    from tsad_drake.scenario_generator import BUILTIN_SCENARIOS

    return spec in BUILTIN_SCENARIOS


def check_occluded(scenario: str, occluded: bool) -> None:
    """--occluded only with a built-in scenario that has an occluded variant."""
    if occluded and scenario not in OCCLUDED_SCENARIOS:
        if is_builtin(scenario):
            what = f"scenario {scenario}"
        else:
            what = "a folder of scene files" if Path(scenario).is_dir() else "a scenario YAML file"
        raise UsageError(f"--occluded generates scenes of scenario {', '.join(OCCLUDED_SCENARIOS)}; "
                         f"it does not apply to {what}")


def check_scenario_args(args: argparse.Namespace) -> None:
    """--seed in range and --occluded where it applies (the arguments of `add_scenario_args`)."""
    check_seeds("--seed", args.seed)
    check_occluded(args.scenario, args.occluded)


def resolve_scenario(spec: str, seed: int, occluded: bool = False):
    """A built-in scenario name ("1", "2", "3", "real", "wide") with a seed, or a scenario YAML path."""
    from tsad_drake.scenario import load_scenario
    from tsad_drake.scenes import BUILTIN_SCENARIOS, generate_scenario

    if spec in BUILTIN_SCENARIOS:
        check_seeds("--seed", seed)
        return generate_scenario(spec, seed, occluded=occluded)
    if spec.strip() and (spec.endswith((".yaml", ".yml")) or os.sep in spec or Path(spec).exists()):
        return load_scenario(spec)
    raise UsageError(f"unknown scenario {spec!r}: use one of {', '.join(BUILTIN_SCENARIOS)} "
                     "or the path of a scenario YAML file")


def add_scenario_args(p: argparse.ArgumentParser, required: bool = True) -> None:
    p.add_argument("--scenario", required=required,
                   help="built-in scenario 1, 2, 3, real or wide, or the path of a scenario YAML file "
                        "(as written by `tsad scene`)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the generated scene for a built-in scenario, and of the planner "
                        f"(0 to {MAX_SEED}; default 0)")
    p.add_argument("--occluded", action="store_true",
                   help="generate a scene whose target is fully hidden from every view "
                        f"(scenarios {', '.join(OCCLUDED_SCENARIOS)})")


def int_between(text: str, low: int, high: int) -> int:
    """`text` as an integer from `low` to `high` (argparse.ArgumentTypeError otherwise)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid int value: {text!r}") from None
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"must be between {low} and {high}, got {value}")
    return value


def thread_count(text: str) -> int:
    """argparse type of --threads: an integer from 1 to MAX_THREADS (checked while parsing, since
    the threads are pinned before the command starts)."""
    return int_between(text, 1, MAX_THREADS)


def add_sensor_arg(p: argparse.ArgumentParser, noise_from: str = "--seed",
                   default: str = "ideal", frames: bool = False) -> None:
    """--sensor (and, with `frames`, --frames for commands without --set sensor.frames)."""
    p.add_argument("--sensor", choices=("ideal", "realistic"), default=default,
                   help="depth sensor model: ideal (the exact rendered depth) or realistic (a "
                        "structured-light camera: sigma(z) = 0.5 mm + 5 mm/m^2 z^2, 1 mm "
                        "quantisation, dropout and flying pixels at depth edges, eight frames "
                        f"fused per view; perception/sensor.py); the noise is drawn from "
                        f"{noise_from} (default {default})")
    if frames:
        p.add_argument("--frames", type=frame_count, default=0, metavar="N",
                       help="depth frames fused per view (default: the sensor's, 8 for "
                            "realistic; the shipped realistic weights' data took 1)")


#: most depth frames a view may fuse (--frames)
MAX_FRAMES = 64


def frame_count(text: str) -> int:
    """argparse type of --frames: an integer from 1 to MAX_FRAMES."""
    return int_between(text, 1, MAX_FRAMES)


def add_segmentation_arg(p: argparse.ArgumentParser, default: str = "label") -> None:
    p.add_argument("--segmentation", choices=("label", "cluster"), default=default,
                   help="label: the renderer's label image (stands in for instance "
                        f"segmentation); cluster: the fused point cloud alone (default {default})")


def add_threads_arg(p: argparse.ArgumentParser, default: int = 1) -> None:
    p.add_argument("--threads", type=thread_count, default=default,
                   help="CPU threads for torch and the BLAS libraries (per worker process), so "
                        "time budgets and plans do not depend on the machine's load "
                        f"(default {default})")
