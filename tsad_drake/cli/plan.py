"""`tsad plan`, `tsad bench`, `tsad report` and `tsad config`: the planning half of the command line."""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
from pathlib import Path

from tsad_drake.cli.common import (
    add_segmentation_arg,
    add_sensor_arg,
    add_threads_arg,
    check_int,
    check_occluded,
    check_scenario_args,
    check_seeds,
    resolve_scenario,
)
from tsad_drake.cli.config import add_config_args, effective_config
from tsad_drake.errors import UsageError
from tsad_drake.outputs import prepare_out_dir, prepare_out_file
from tsad_drake.pipeline import FEASIBILITY_NAMES, OBSERVER_NAMES, WORLD_NAMES
from tsad_drake.planners.tsad.config import VARIANTS
from tsad_drake.planning.registry import ABLATIONS, PLANNERS
from tsad_drake.plugins import plugin_reference
from tsad_drake.runtime import detail, show_progress

#: --feasibility when none is given (any other planner: geometric)
DEFAULT_FEASIBILITY = {"tsad": "net", "optimal": "oracle"}
MAX_ACTIONS = 100  #: largest --max-actions
MAX_EPISODES = 10_000  #: largest --episodes
DEFAULT_EPISODES = 30  #: --episodes when none is given (a folder bench: one per scene file)
MAX_WORKERS = 64  #: largest --workers
#: where bench episodes run (`bench.runner.run_bench`)
BACKEND_NAMES = ("process", "ray")


def _add_selector_args(p: argparse.ArgumentParser, sensing: tuple[str, str] = ("ideal", "label")
                       ) -> None:
    """The flags that pick a run's config (`tsad plan`, `bench` and `config`), with --config/--set;
    `sensing`: the default --sensor and --segmentation."""
    p.add_argument("--planner", required=True, choices=tuple(PLANNERS),
                   help="tsad (the paper's method), gp3, rots, rots-star (ROTS's sequence checked "
                        "step by step by the feasibility model, as in the paper), "
                        "rots-star-search (a stronger ROTS*: the model inside the A* search) "
                        "or optimal (exhaustive search on the oracle model, budgeted: the floor "
                        "for action counts)")
    add_sensor_arg(p, default=sensing[0])
    add_segmentation_arg(p, default=sensing[1])
    p.add_argument("--variant", default="full", choices=VARIANTS,
                   help="TSAD variant: full (every option beyond the paper) or paper (the "
                        "paper's algorithm exactly; docs/design.md lists each extra); tsad only "
                        "(default full)")
    p.add_argument("--ablation", default="none", choices=ABLATIONS,
                   help="TSAD reward ablation: no-ro drops r_o, no-re drops r_e (default none; "
                        "only for planners with reward ablations: tsad)")
    p.add_argument("--world", default="geometric", choices=WORLD_NAMES,
                   help="what executes and judges the actions: geometric (the 2-D corridor "
                        "rule) or physics (each action a Drake contact simulation of the "
                        "station, planned on the perceived poses and re-observed from the "
                        "simulated state; implies --motion and --observer drake; about "
                        "5-10 s of wall time per action)")
    add_config_args(p)


def add_parallel_args(p: argparse.ArgumentParser) -> None:
    """--workers and --backend: where and how many episodes run at once (`bench`, `sweep`)."""
    p.add_argument("--workers", type=int, default=1,
                   help=f"episodes run in this many parallel processes (1 to {MAX_WORKERS}; "
                        "default 1)")
    p.add_argument("--backend", choices=BACKEND_NAMES, default="process",
                   help="where episodes run: process (a local process pool, default) or ray (Ray "
                        "tasks on a local Ray with --workers CPUs, or on the cluster at "
                        "RAY_ADDRESS; needs `pip install 'tsad_drake[ray]'`)")


def _add_planner_args(p: argparse.ArgumentParser, default_observer: str,
                      sensing: tuple[str, str] = ("ideal", "label")) -> None:
    _add_selector_args(p, sensing)
    p.add_argument("--feasibility", default=None, choices=FEASIBILITY_NAMES,
                   help="prehensile feasibility model the planner queries: net (the shipped "
                        "PointNet++ prehensile network; default for tsad), geometric (gripper "
                        "swept volume against perceived point clouds; default for gp3 and the "
                        "rots planners) or oracle (true geometry; default for optimal)")
    p.add_argument("--observer", default=default_observer, choices=OBSERVER_NAMES,
                   help="how the robot observes: drake renders depth in the Drake station (VTK), "
                        "raycast renders the same camera with the NumPy ray caster "
                        f"(default {default_observer})")
    p.add_argument("--open-loop", action="store_true",
                   help="execute the whole plan without observing again after each sub-search")
    p.add_argument("--max-actions", type=int, default=12,
                   help=f"episode limit on pick-and-place actions (1 to {MAX_ACTIONS}; default 12)")
    add_threads_arg(p)


def add_plan_parsers(sub, add_scenario_args) -> None:
    p = sub.add_parser("plan", help="observe, plan and execute one episode; write plan.json",
                       description=(
                           "Observe the scene (by default as a robot would: realistic depth, "
                           "eight frames per view, cluster segmentation), plan with the chosen "
                           "planner and feasibility model, execute in the world model (closed "
                           "loop: re-observe after each sub-search) and write DIR/plan.json, and the "
                           "executed plan as DIR/plan.tsad.json (the tsad-plan/1 format "
                           "`tsad verify` checks). "
                           "Exit 0 on success, 1 when the target could not be retrieved (the "
                           "JSON says why)."))
    add_scenario_args(p)
    # a plan observes as the robot would: realistic depth, segmentation without labels
    _add_planner_args(p, default_observer="drake", sensing=("realistic", "cluster"))
    p.add_argument("--motion", action="store_true",
                   help="verify every action at the motion level (IK keyframes, trajectory "
                        "optimisation, dense collision check) before executing it; a rejected "
                        "action is excluded and TSAD plans again. Also writes DIR/replay.html "
                        "(offline Meshcat recording) and DIR/scene.dmd.yaml")
    p.add_argument("--meshcat", action="store_true",
                   help="view live in a browser: Meshcat on localhost (its URL is printed first) "
                        "shows the scene, then plays the verified motion; implies --motion; "
                        "waits for Enter before exiting when run from a terminal")
    p.add_argument("--out", default="out/plan", help="output directory (default out/plan)")

    p = sub.add_parser("bench", help="run many episodes; print a table in the paper's format",
                       description=(
                           "Run N episodes (seeds K..K+N-1) of one planner on one scenario, print "
                           "a table like the paper's Table I and write per-episode rows plus a "
                           "summary to FILE.json. Rows stream to FILE.json.rows.jsonl, so an "
                           "interrupted bench resumes where it stopped."))
    p.add_argument("--scenario", required=True,
                   help="built-in scenario 1, 2, 3, real or wide (a scene generated per seed), a "
                        "scenario YAML file (the same scene every episode; the seeds vary the "
                        "planner and the sensor noise), or a folder of scene files (*.yaml, "
                        "*.yml directly in it; one episode per file in name order, file i with seed "
                        "--seed-start + i)")
    p.add_argument("--episodes", type=int, default=None,
                   help=f"number of episodes (1 to {MAX_EPISODES}; default "
                        f"{DEFAULT_EPISODES}, with a folder every file in it: N runs its first "
                        f"N files)")
    p.add_argument("--seed-start", type=int, default=0, help="first seed (default 0)")
    p.add_argument("--occluded", action="store_true",
                   help="scenes with the target fully hidden (the paper's section VI-D)")
    _add_planner_args(p, default_observer="raycast")
    p.add_argument("--motion", action="store_true",
                   help="verify every action at the motion level before executing it (as "
                        "`tsad plan --motion`); rows and summary report the share of checked "
                        "actions that were motion-feasible")
    add_parallel_args(p)
    p.add_argument("--out", required=True, help="result JSON file")

    p = sub.add_parser("config", help="print the effective config as YAML (for --config)",
                       description=(
                           "Print every setting a `tsad plan` or `tsad bench` with these flags "
                           "runs with, as YAML: the defaults the selector flags pick, then "
                           "--config, then each --set. The output loads back with --config (and "
                           "the same --planner) to the identical config."))
    _add_selector_args(p)
    p.add_argument("--dump", action="store_true", help="print the effective config as YAML")

    p = sub.add_parser("report", help="collect bench JSON files into a results page",
                       description="Collect `tsad bench` JSON files into markdown tables in the "
                                   "paper's format, a JSON digest and a plot. Files of the same "
                                   "settings (a run split by seed ranges across machines) are "
                                   "merged by seed; the same seed with different results in two "
                                   "files is refused. A physics agreement study "
                                   "(studies/physics_agreement.py) among the inputs becomes "
                                   "a section with its confusion matrices, footprint error studies "
                                   "(studies/hull_errors.py --json) a table.")
    p.add_argument("inputs", nargs="+", help="bench result JSON files")
    p.add_argument("--out", required=True, help="markdown file to write (plot and JSON beside it)")


def check_selectors(args: argparse.Namespace):
    """The flags that pick the config (`_add_selector_args`), checked before any work; returns
    the effective config (`cli.config.effective_config`)."""
    from tsad_drake.pipeline import EpisodeSettings, physics_settings
    from tsad_drake.planning.registry import get_planner

    if args.ablation != "none" and not get_planner(args.planner).ablations:
        raise UsageError(f"--ablation {args.ablation} applies to planners with reward ablations "
                         f"(tsad), not to {args.planner}")
    if args.variant not in get_planner(args.planner).variants:
        raise UsageError(f"--variant {args.variant} applies to tsad, not to {args.planner}")
    config = effective_config(args)
    try:  # the settings a physics world can run with (pipeline.physics_settings decides)
        physics_settings(EpisodeSettings(world=args.world, sensor=args.sensor, config=config))
    except ValueError as err:
        raise UsageError(f"--world {args.world} --sensor {args.sensor}: {err}") from None
    return config


def _check_planner_args(args: argparse.Namespace):
    """The flags `plan` and `bench` share, checked before any work; returns the effective config.
    The network's weights are loaded once here so a missing or bad file is one line, not a
    failure in every episode."""
    if args.feasibility is None:
        args.feasibility = DEFAULT_FEASIBILITY.get(args.planner, "geometric")
    check_int("--max-actions", args.max_actions, 1, MAX_ACTIONS)
    config = check_selectors(args)
    if args.feasibility == "net":
        from tsad_drake.prehensile.weights import require_torch, shipped_weights

        require_torch()  # the `net` extra
        from tsad_drake.prehensile.checkpoint import load_checkpoint

        # a missing or mismatched weights file: one line, exit 2
        load_checkpoint(shipped_weights(args.sensor))
    return config


def episode_settings_of(args: argparse.Namespace, config):
    """The `EpisodeSettings` the `plan` and `bench` flags name, with the effective `config`."""
    from tsad_drake.pipeline import EpisodeSettings

    return EpisodeSettings(planner=args.planner, feasibility=args.feasibility,
                           ablation=args.ablation, variant=args.variant, sensor=args.sensor,
                           segmentation=args.segmentation, observer=args.observer,
                           closed_loop=not args.open_loop, max_actions=args.max_actions,
                           motion=(args.motion or getattr(args, "meshcat", False)
                                   or args.world == "physics"),
                           world=args.world, config=config)


def cmd_plan(args: argparse.Namespace) -> int:
    check_scenario_args(args)
    config = _check_planner_args(args)
    from tsad_drake.pipeline import plan_episode

    out = prepare_out_dir(args.out)
    scenario = resolve_scenario(args.scenario, args.seed, args.occluded)
    meshcat = start_meshcat(scenario, config) if args.meshcat else None
    record = plan_episode(scenario, args.seed, episode_settings_of(args, config), out,
                          meshcat=meshcat)
    record.threads = args.threads
    result = record.to_json()
    from tsad_drake.plan_format import plan_from_episode

    # the executed plan in the tsad-plan/1 format, for `tsad verify` (docs/plan-format.md)
    plan_path = out.write_text("plan.tsad.json",
                               json.dumps(plan_from_episode(scenario, result), indent=2))
    path = out.write_text("plan.json", json.dumps(result, indent=2))
    print(f"planner {args.planner} ({args.feasibility}) on scenario {scenario.name} seed "
          f"{args.seed}: theta* = {result.get('theta_star_deg')} deg")
    for i, a in enumerate(result["actions"]):
        detail(f"  {i + 1:2d}. move {a['object']:<8} pick at {a['theta_pick_deg']:+5.0f} deg -> "
              f"({a['place_xy'][0]:.3f}, {a['place_xy'][1]:.3f}) place at "
              f"{a['theta_place_deg']:+5.0f} deg  [sub-search {a['sub_search']}]")
    if args.world == "physics":
        for i, a in enumerate(result["actions"]):
            if "physics" in a:
                detail(f"  physics {i + 1:2d}: {physics_line(a['physics'])}")
    if args.motion or args.world == "physics":
        motion = result["motion"]
        share = result.get("motion_feasible_share")
        print(f"motion: {sum(m['verified'] for m in motion)}/{len(motion)} executed actions "
              f"verified as one continuous motion; "
              f"{'-' if share is None else f'{share:.0%}'} of checked actions motion-feasible")
        for i, m in enumerate(motion):
            if not m["verified"]:
                detail(f"  action {i + 1}: {m['failure']}")
        if args.world == "physics":
            print(f"wrote {out / 'replay.html'} (the contact simulation as it ran), "
                  f"{out / 'planned_replay.html'} (the verified plan) and {out / 'scene.dmd.yaml'}")
        else:
            print(f"wrote {out / 'replay.html'} and {out / 'scene.dmd.yaml'}")
    print(f"wrote {plan_path} (the executed plan, for `tsad verify`)")
    verdict = "target retrieved" if result["success"] else f"FAILED: {result['failure_reason']}"
    print(f"{verdict}; {result['num_actions']} actions (target retrieval included), "
          f"{result['falls']} falls, planning {result['planning_time_s']:.2f} s")
    print(f"wrote {path}")
    if meshcat is not None:
        hold_meshcat(meshcat)
    return 0 if result["success"] else 1


def start_meshcat(scenario, config):
    """Meshcat on localhost showing the scene at once (its URL printed before planning starts),
    with the shelf where the run's station config puts it."""
    from pydrake.geometry import Meshcat, MeshcatParams

    from tsad_drake.motion.export import SceneLayout
    from tsad_drake.placement import placed_config

    meshcat = Meshcat(MeshcatParams(host="localhost"))
    station = placed_config(scenario, config).station
    layout = SceneLayout(scenario, station.X_WS(scenario.shelf.floor_height), meshcat)
    layout.set_objects(scenario.objects)
    layout.diagram.ForcedPublish(layout.context)
    print(f"meshcat: {meshcat.web_url()} (the motion plays there once planned)", flush=True)
    return meshcat


def hold_meshcat(meshcat) -> None:
    """Keep Meshcat serving until Enter or Ctrl-C when a person is at the terminal."""
    if not sys.stdin.isatty():
        return
    try:
        input(f"meshcat: replay at {meshcat.web_url()}; press Enter to close it ")
    except (EOFError, KeyboardInterrupt):
        print()


def physics_line(m: dict) -> str:
    """One action's physics outcome in words."""
    parts = ["moved" if m["moved"] else "NOT moved"]
    if m["placement_error_mm"] is not None:
        parts.append(f"placed {m['placement_error_mm']:.1f} mm off")
    if m["slip_mm"] is not None:
        parts.append(f"slip {m['slip_mm']:.1f} mm")
    if m["fallen"]:
        parts.append("fell: " + ", ".join(m["fallen"]))
    if m["disturbed"]:
        parts.append("disturbed: " + ", ".join(m["disturbed"]))
    if m["reason"]:
        parts.append(m["reason"])
    parts.append(f"{m['sim_seconds']:.1f} s simulated in {m['wall_seconds']:.1f} s")
    return "; ".join(parts)


def folder_scenes(folder: Path, episodes: int | None) -> list[Path]:
    """A folder bench's scene files: the `*.yaml` and `*.yml` files directly in `folder` (resolved),
    sorted by name, the first `episodes` of them (None: all); each loaded before any work, so a
    folder without one, or a file that does not load, is one line naming it."""
    from tsad_drake.scenario import load_scenario

    folder = folder.resolve()
    try:
        files = sorted((p for p in folder.iterdir()
                        if p.suffix in (".yaml", ".yml") and p.is_file()), key=lambda p: p.name)
    except OSError as err:
        raise UsageError(f"cannot read the scene folder {folder}: {err.strerror}") from None
    if not files:
        raise UsageError(f"--scenario {folder}: the folder holds no scene file (*.yaml, *.yml)")
    if episodes is not None and episodes > len(files):
        raise UsageError(f"--episodes {episodes}: the folder {folder} holds {len(files)} scene "
                         "files")
    files = files[:episodes]
    for path in files:
        load_scenario(path)  # ScenarioError naming the file
    return files


def bench_specs(args: argparse.Namespace) -> tuple[list, Path]:
    """`tsad bench`'s flags checked (everything, before any work): its episodes and its --out.
    A folder as --scenario runs one episode per scene file (`folder_scenes`), file i with seed
    --seed-start + i."""
    from tsad_drake.bench.runner import EpisodeSpec, check_bench_out
    from tsad_drake.scenes import BUILTIN_SCENARIOS

    check_occluded(args.scenario, args.occluded)
    scenes = None  # a folder bench's folder
    if args.scenario not in BUILTIN_SCENARIOS and Path(args.scenario).is_dir():
        if args.episodes is not None:
            check_int("--episodes", args.episodes, 1, MAX_EPISODES)
        scenarios = [str(p) for p in folder_scenes(Path(args.scenario), args.episodes)]
        scenes = str(Path(args.scenario).resolve())
        args.episodes = len(scenarios)
    elif args.scenario not in BUILTIN_SCENARIOS:  # a YAML scene: checked (and refused) before work
        resolve_scenario(args.scenario, 0)
        args.scenario = str(Path(args.scenario).resolve())
    if args.episodes is None:
        args.episodes = DEFAULT_EPISODES
    check_int("--episodes", args.episodes, 1, MAX_EPISODES)
    check_int("--workers", args.workers, 1, MAX_WORKERS)
    if args.backend == "ray" and importlib.util.find_spec("ray") is None:
        raise UsageError("--backend ray needs Ray: pip install 'tsad_drake[ray]'")
    check_seeds("--seed-start", args.seed_start, args.episodes)
    config = _check_planner_args(args)
    out = check_bench_out(args.out)
    if scenes is None:  # a built-in scenario or one YAML file: the same name every episode
        scenarios = [args.scenario] * args.episodes
    settings = episode_settings_of(args, config)
    plugins = tuple(plugin_reference(p) for p in getattr(args, "plugin", []))
    specs = [EpisodeSpec(scenario, args.seed_start + i, settings, occluded=args.occluded,
                         plugins=plugins, scenes=scenes)
             for i, scenario in enumerate(scenarios)]
    return specs, out


def cmd_bench(args: argparse.Namespace) -> int:
    from tsad_drake.bench.metrics import paper_table
    from tsad_drake.bench.runner import run_bench

    specs, out = bench_specs(args)
    document = run_bench(specs, out, workers=args.workers, threads=args.threads,
                         progress=show_progress(), backend=args.backend)
    label = args.planner if args.ablation == "none" else f"{args.planner} ({args.ablation})"
    if "scenes" in document:  # a folder bench: the table is the folder's
        print(f"scenes: {Path(document['spec']['scenario']).name}/ "
              f"({len(document['scenes'])} scene files)")
    print(paper_table({label: document["summary"]}))
    print(f"wrote {out}")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from tsad_drake.bench.report import (
        load_report_input,
        merge_documents,
        report_outputs,
        write_report,
    )

    out = prepare_out_file(args.out)
    read = {Path(name).resolve() for name in args.inputs}
    for path in report_outputs(out):
        if path.resolve() in read:
            raise UsageError(f"--out {out} would overwrite the input {path}: choose another name")
    inputs = [(name, *load_report_input(name)) for name in args.inputs]
    benches = [(name, doc) for name, kind, doc in inputs if kind == "bench"]
    if not benches:
        raise UsageError("report: no `tsad bench` result among the inputs")
    documents = merge_documents(benches)
    write_report(documents, out, [doc for _, kind, doc in inputs if kind == "agreement"],
                 [doc for _, kind, doc in inputs if kind == "footprints"])
    split = sum(len(d["sources"]) > 1 for d in documents)
    print(f"wrote {out}: {len(args.inputs)} files, {len(documents)} settings"
          + (f" ({split} merged from split runs)" if split else ""))
    return 0


def cmd_config(args: argparse.Namespace) -> int:
    from tsad_drake.run_config import dump_run_config

    config = check_selectors(args)
    if not args.dump:
        raise UsageError("config: nothing to do: --dump prints the effective config")
    print(f"# tsad config --planner {args.planner} --ablation {args.ablation} --variant "
          f"{args.variant} --sensor {args.sensor}; load with --config and the same --planner and "
          f"--sensor (`plan` observes with --sensor realistic unless told)")
    print(dump_run_config(config), end="")
    return 0


PLAN_COMMANDS = {"plan": cmd_plan, "bench": cmd_bench, "report": cmd_report,
                 "config": cmd_config}
