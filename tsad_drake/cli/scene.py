"""`tsad scene`: generate a scenario, settle one in the contact simulation, or import a Drake
model-directives scene, and write it as scenario YAML."""

from __future__ import annotations

import argparse

from tsad_drake.cli.common import add_scenario_args, check_scenario_args, resolve_scenario
from tsad_drake.errors import UsageError
from tsad_drake.outputs import prepare_out_file


def add_scene_parser(sub) -> None:
    p = sub.add_parser("scene", help="generate, settle or import a scenario and write it as YAML",
                       description=(
                           "Write a scenario YAML file: a generated scene of a built-in scenario "
                           "(--scenario, --seed), a scenario file settled in the Drake contact "
                           "simulation (--settle: objects pushed into each other separate and "
                           "come to rest; prints how far each moved), or a scene read back from "
                           "the model directives `tsad plan --motion` exports (--from)."))
    add_scenario_args(p, required=False)
    p.add_argument("--settle", metavar="IN.yaml",
                   help="scenario YAML file to settle: 1 s of contact simulation from rest "
                        "(objects interpenetrating up to 5 mm are pushed apart; the headings "
                        "kept as simulated), written back as a valid scenario")
    p.add_argument("--from", dest="from_dmd", metavar="scene.dmd.yaml",
                   help="Drake model directives of boxes and cylinders (as `tsad plan --motion` "
                        "writes them) to read back into a scenario")
    p.add_argument("--out", required=True, help="scenario YAML file to write")


def cmd_scene(args: argparse.Namespace) -> int:
    from tsad_drake.scenario import save_scenario

    sources = [f for f, v in (("--scenario", args.scenario), ("--settle", args.settle),
                              ("--from", args.from_dmd)) if v is not None]
    if len(sources) != 1:
        raise UsageError("give exactly one of --scenario, --settle and --from"
                         + (f" (got {', '.join(sources)})" if sources else ""))
    if args.scenario is None and (args.seed != 0 or args.occluded):
        raise UsageError(f"--seed and --occluded generate a built-in scenario; they do not apply "
                         f"to {sources[0]}")
    if args.scenario is not None:
        check_scenario_args(args)
    out = prepare_out_file(args.out)
    if args.settle is not None:
        return _settle(args.settle, out)
    if args.from_dmd is not None:
        from tsad_drake.motion.import_dmd import load_scene_directives

        scenario = load_scene_directives(args.from_dmd)
        save_scenario(scenario, out)
        print(f"wrote {out}: {len(scenario.objects)} objects from {args.from_dmd}, "
              f"target {scenario.target}")
        return 0
    scenario = resolve_scenario(args.scenario, args.seed, args.occluded)
    save_scenario(scenario, out)
    print(f"wrote {out}: scenario {scenario.name} seed {scenario.seed}, "
          f"{len(scenario.objects)} objects, target {scenario.target}")
    return 0


def _settle(path: str, out) -> int:
    from tsad_drake.physics.settle import largest_move_mm, settle_lines, settle_scene
    from tsad_drake.scenario import load_scenario, save_scenario

    settled, report = settle_scene(load_scenario(path, overlaps=False))
    for line in settle_lines(report):
        print(line)
    save_scenario(settled, out)
    print(f"wrote {out}: {len(settled.objects)} objects settled (largest move "
          f"{largest_move_mm(report):.2f} mm)")
    return 0
