"""`tsad` command line: render, scene, plan, verify, bench, report, config and the network commands.

Bad input ends with one line on stderr and exit status 2; a planning failure is a result
(exit status 1, the JSON says why).
"""

from __future__ import annotations

import argparse
import os
import sys

from tsad_drake.cli.common import (
    Parser,
    add_scenario_args,
    add_segmentation_arg,
    add_sensor_arg,
    check_scenario_args,
    resolve_scenario,
)
from tsad_drake.errors import EXIT_BAD_INPUT, EXIT_INTERRUPTED, RunFailure, UsageError
from tsad_drake.outputs import prepare_out_dir
from tsad_drake.plugins import load_plugin, plugins_in
from tsad_drake.runtime import NORMAL, QUIET, VERBOSE, pin_threads, set_verbosity


def version_line() -> str:
    """`tsad --version`: this package's version and the versions it runs on."""
    from importlib import metadata

    from tsad_drake import __version__

    def version(name: str) -> str:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            return "not installed"

    return (f"tsad_drake {__version__} (drake {version('drake')}, torch {version('torch')}, "
            f"open3d {version('open3d')}, python {sys.version.split()[0]})")


class VersionAction(argparse.Action):
    """--version: one unwrapped line (argparse's own action wraps it at the terminal's width)."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS,
                         help="print the versions of tsad_drake, Drake, torch, open3d and Python")

    def __call__(self, parser, namespace, values, option_string=None):
        print(version_line())
        parser.exit(0)


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="tsad", description=(
        "TSAD on Drake: target retrieval from a shelf with lateral access. A UR5e with a wrist "
        "depth camera observes the shelf, perception segments the objects, and TSAD plans which "
        "blockers to move, where, and from which angle."))
    parser.add_argument("--version", action=VersionAction)
    parser.add_argument("--plugin", action="append", default=[], metavar="FILE.py|MODULE",
                        help="import a file or module of your own first (repeatable): planners it "
                             "registers (`planning.registry.register`) run with plan and bench "
                             "by name (examples/own_planner.py registers `greedy`)")
    loud = parser.add_mutually_exclusive_group()
    loud.add_argument("-q", "--quiet", action="store_true",
                      help="print results and errors only: no progress bars or per-step lines")
    loud.add_argument("-v", "--verbose", action="store_true",
                      help="also print a line per finished bench episode and Drake's INFO log "
                           "(on stderr)")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    from tsad_drake.cli.scene import add_scene_parser

    add_scene_parser(sub)

    p = sub.add_parser("render", help="render depth from every approach angle and segment it",
                       description=(
                           "Build the Drake station for the scene, render 128x128 depth from the "
                           "wrist camera at each approach angle, fuse the views into a point cloud "
                           "in the shelf frame and segment it. Writes depth.npy (V,H,W float32 "
                           "metres, inf where nothing), depth.png, labels.npy, cloud.ply, "
                           "segments.npy (P,4: x, y, z, segment index), segments.json and "
                           "scene.yaml into --out."))
    add_scenario_args(p)
    p.add_argument("--out", required=True, help="output directory")
    add_segmentation_arg(p)
    add_sensor_arg(p)
    from tsad_drake.cli.net import add_net_parsers
    from tsad_drake.cli.plan import add_plan_parsers
    from tsad_drake.cli.sweep import add_sweep_parser
    from tsad_drake.cli.verify import add_verify_parser

    add_plan_parsers(sub, add_scenario_args)
    add_verify_parser(sub)
    add_sweep_parser(sub)
    add_net_parsers(sub)
    return parser


def cmd_render(args: argparse.Namespace) -> int:
    from tsad_drake.render_output import render_and_write

    check_scenario_args(args)
    out = prepare_out_dir(args.out)
    scenario = resolve_scenario(args.scenario, args.seed, args.occluded)
    render_and_write(scenario, out, args.segmentation, args.sensor, args.seed)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run one `tsad` command; returns its exit status (0 done, 1 a failure that is a result,
    2 bad input, 130 interrupted)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        for name in plugins_in(argv):  # before the parser: they add names to its choices
            load_plugin(name)
    except UsageError as err:
        print(f"tsad: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    parser = build_parser()
    args = parser.parse_args(argv)
    pin_threads(getattr(args, "threads", 1))  # before numpy, torch or Drake load where possible
    os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")
    import pydrake.common  # noqa: F401  (hooks the "drake" logger's level to Drake's own)

    # Drake's INFO lines are not for users unless they ask (--verbose)
    set_verbosity(QUIET if args.quiet else VERBOSE if args.verbose else NORMAL)
    from tsad_drake.cli.net import NET_COMMANDS
    from tsad_drake.cli.plan import PLAN_COMMANDS
    from tsad_drake.cli.scene import cmd_scene
    from tsad_drake.cli.sweep import SWEEP_COMMANDS
    from tsad_drake.cli.verify import VERIFY_COMMANDS

    commands = {"scene": cmd_scene, "render": cmd_render, **PLAN_COMMANDS, **VERIFY_COMMANDS,
                **SWEEP_COMMANDS, **NET_COMMANDS}
    try:
        return commands[args.command](args)
    except UsageError as err:
        print(f"tsad: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as err:
        print(f"tsad: interrupted{f': {err}' if str(err) else ''}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (RunFailure, OSError) as err:  # a worker killed, the disk full while the command ran
        print(f"tsad: error: {err}", file=sys.stderr)
        return 1
