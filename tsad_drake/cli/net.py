"""`tsad dataset`, `tsad train`, `tsad net-calibrate` and `tsad net-eval`: the prehensile
network's half of the CLI.

Wire-up: `add_net_parsers(sub)` adds the four subparsers; `NET_COMMANDS` maps each command name to
its function (args -> exit status). Bad input raises `tsad_drake.errors.UsageError` (exit 2).
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import json
from pathlib import Path

from tsad_drake.cli.common import (
    add_segmentation_arg,
    add_sensor_arg,
    add_threads_arg,
    check_float,
    check_int,
    check_seeds,
)
from tsad_drake.errors import UsageError
from tsad_drake.outputs import atomic_write_text, prepare_out_dir, prepare_out_file
from tsad_drake.pipeline import OBSERVER_NAMES
from tsad_drake.prehensile.dataset import Sensing
from tsad_drake.prehensile.weights import require_torch

MAX_SCENES = 100_000  #: largest --scenes


def add_calibration_sensing_args(p: argparse.ArgumentParser) -> None:
    """--sensor and --segmentation of the calibration scenes (ray caster; use the data's)."""
    group = p.add_argument_group("calibration scenes (observe them as the training data was)")
    add_sensor_arg(group, noise_from="the scene seed", frames=True)
    add_segmentation_arg(group)


def add_net_parsers(sub) -> None:
    p = sub.add_parser("dataset", help="generate prehensile-network training data (resumable)",
                       description=(
                           "Generate scenes (seeds K..K+N-1; scenario 1, 2, 3, real by seed % 4), "
                           "observe them, add states after random feasible relocations (point-cloud "
                           "simulation) and the re-observed true scene, and label every (object, "
                           "angle) with the oracle: fits/reach, pickable, blockers. Queries are "
                           "class-balanced per state. Writes shards of scenes to DIR; an "
                           "interrupted run resumes where it stopped. Split by scene: (seed // 4) % 10 "
                           "== 8 validation, == 9 test (every scenario type in every split)."))
    p.add_argument("--scenes", type=int, required=True, help="number of scenes")
    p.add_argument("--seed-start", type=int, default=0, help="first scene seed (default 0)")
    p.add_argument("--out", required=True, help="dataset directory")
    p.add_argument("--observer", choices=OBSERVER_NAMES, default="raycast",
                   help="raycast: the NumPy ray caster (fast, same camera and pipeline; default); "
                        "drake: render depth with the Drake station (VTK)")
    add_sensor_arg(p, noise_from="the scene seed", frames=True)
    add_segmentation_arg(p)
    p.add_argument("--shard-size", type=int, default=20, help="scenes per shard file (default 20)")
    add_threads_arg(p)

    p = sub.add_parser("train", help="train the prehensile network on CPU; keep the best checkpoint",
                       description=(
                           "Train the PointNet++ prehensile network on a `tsad dataset` directory "
                           "(seeded, CPU), validate after each epoch and keep the checkpoint with "
                           "the best validation score (mean of pickable accuracy and exact "
                           "blocker-set rate) at --out, then calibrate its decision thresholds on "
                           "fresh scenes. Stops after --epochs or --max-minutes."))
    p.add_argument("--data", required=True, help="dataset directory from `tsad dataset`")
    p.add_argument("--out", required=True, help="weights file to write (.pt)")
    p.add_argument("--epochs", type=int, default=30, help="epochs (default 30)")
    p.add_argument("--batch", type=int, default=32, help="batch size (default 32)")
    p.add_argument("--lr", type=float, default=2e-3, help="peak learning rate, cosine decay (default 2e-3)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--max-minutes", type=float, default=30.0,
                   help="wall-clock limit in minutes (default 30)")
    p.add_argument("--init", default=None,
                   help="weights file to start from (fine-tuning, e.g. the shipped weights on "
                        "data observed with --sensor realistic); default: random initialisation")
    add_calibration_sensing_args(p)
    add_threads_arg(p, default=2)

    p = sub.add_parser("net-calibrate", help="re-tune a weights file's decision thresholds",
                       description=(
                           "Choose the network's decision thresholds on fresh scenes (seeds from "
                           "200000, never used for training or net-eval): reach for the best reach "
                           "accuracy, collision for the best pickable accuracy, then the set "
                           "threshold for the most exact "
                           "blocker sets R_{theta,s}; written into the weights file's meta. "
                           "`tsad train` ends with the same step."))
    p.add_argument("--weights", required=True, help="weights file to update in place (.pt)")
    p.add_argument("--scenes", type=int, default=16, help="calibration scenes (default 16)")
    add_calibration_sensing_args(p)
    add_threads_arg(p)

    p = sub.add_parser("net-eval", help="score the network against the oracle on fresh scenes",
                       description=(
                           "Generate fresh scenes (seeds never used for training), observe them, "
                           "and compare the `net` feasibility model with the oracle on every "
                           "(object, angle): accuracy, precision and recall per scenario type, as "
                           "a table and JSON."))
    p.add_argument("--weights", default=None, help="weights file (default: the shipped weights)")
    p.add_argument("--scenes", type=int, default=40, help="number of scenes (default 40)")
    p.add_argument("--seed-start", type=int, default=100_000,
                   help="first scene seed (default 100000; must not overlap the training seeds)")
    p.add_argument("--observer", choices=OBSERVER_NAMES, default="raycast",
                   help="raycast (default) or drake rendering")
    add_sensor_arg(p, noise_from="the scene seed", frames=True)
    add_segmentation_arg(p)
    p.add_argument("--out", default=None, help="also write the JSON to this file")
    add_threads_arg(p)


def sensing_of(args: argparse.Namespace) -> Sensing:
    """The `Sensing` that --observer (the ray caster where a command has none, as calibration),
    --sensor, --segmentation and --frames name."""
    return Sensing(getattr(args, "observer", "raycast"), args.sensor, args.segmentation,
                   args.frames)


def cmd_dataset(args: argparse.Namespace) -> int:
    from tsad_drake.prehensile.dataset import dataset_shards, generate_dataset, load_dataset

    check_int("--scenes", args.scenes, 1, MAX_SCENES)
    check_int("--shard-size", args.shard_size, 1, 10_000)
    check_seeds("--seed-start", args.seed_start, args.scenes)
    out = prepare_out_dir(args.out)
    if dataset_shards(out.root):
        load_dataset(out.root)  # shards of an earlier run are resumed: one bad shard is one line
    summary = generate_dataset(out.root, args.scenes, args.seed_start, sensing_of(args),
                               args.shard_size)
    print(json.dumps(summary))
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    require_torch("tsad train")
    from tsad_drake.prehensile.dataset import load_dataset
    from tsad_drake.prehensile.training import train

    check_int("--epochs", args.epochs, 1, 10_000)
    check_int("--batch", args.batch, 1, 4096)
    check_seeds("--seed", args.seed)
    check_float("--lr", args.lr, 0.0, 1.0)
    check_float("--max-minutes", args.max_minutes, 0.0, 7 * 24 * 60)
    data = Path(args.data)
    if not data.is_dir():
        raise UsageError(f"--data {data} is not a directory (generate one with `tsad dataset`)")
    out = prepare_out_file(args.out)
    samples = load_dataset(data)
    init = None
    if args.init is not None:
        from tsad_drake.prehensile.checkpoint import load_checkpoint

        load_checkpoint(args.init)  # one clear line on a missing or bad file
        init = Path(args.init)
    try:
        summary = train(data, out, args.epochs, args.batch, args.lr, args.seed, args.max_minutes,
                        args.threads, samples=samples, init=init,
                        sensing=sensing_of(args))
    except ValueError as err:
        raise UsageError(str(err)) from None
    print(json.dumps({k: v for k, v in summary.items() if k != "history"}))
    return 0


def cmd_net_calibrate(args: argparse.Namespace) -> int:
    require_torch("tsad net calibrate")
    from tsad_drake.prehensile.checkpoint import load_checkpoint
    from tsad_drake.prehensile.training import calibrate_thresholds

    check_int("--scenes", args.scenes, 1, 10_000)
    load_checkpoint(args.weights)  # one clear line on a missing or bad file
    prepare_out_file(args.weights, option="--weights")  # updated in place: writable?
    print(json.dumps(calibrate_thresholds(Path(args.weights), args.scenes,
                                          sensing=sensing_of(args))))
    return 0


def cmd_net_eval(args: argparse.Namespace) -> int:
    require_torch("tsad net eval")
    from tsad_drake.prehensile.checkpoint import load_checkpoint
    from tsad_drake.prehensile.feasibility import NetFeasibility
    from tsad_drake.prehensile.training import evaluate_scenes, format_table

    check_int("--scenes", args.scenes, 1, MAX_SCENES)
    check_seeds("--seed-start", args.seed_start, args.scenes)
    _, meta = load_checkpoint(args.weights)  # one clear line on a missing or bad file
    last = args.seed_start + args.scenes - 1
    used = [("training", meta.get("seed_range")), ("calibration", meta.get("calibration", {}).get("seeds"))]
    for what, seeds in used:
        if seeds and args.seed_start <= seeds[1] and last >= seeds[0]:
            raise UsageError(f"seeds {args.seed_start}..{last} overlap the {what} scenes "
                             f"{seeds[0]}..{seeds[1]} of these weights: pick another --seed-start")
    out = prepare_out_file(args.out) if args.out else None
    result = evaluate_scenes(lambda ws: NetFeasibility(ws, args.weights), args.scenes,
                             args.seed_start, sensing_of(args))
    result["sensing"] = dc.asdict(sensing_of(args))
    result["weights"] = str(args.weights or "shipped")
    result["seeds"] = [args.seed_start, args.seed_start + args.scenes - 1]
    result["threads"] = args.threads
    print(format_table(result))
    text = json.dumps(result, indent=1)
    print(text)
    if out:
        atomic_write_text(out, text + "\n")
    return 0


NET_COMMANDS = {"dataset": cmd_dataset, "train": cmd_train, "net-calibrate": cmd_net_calibrate,
                "net-eval": cmd_net_eval}
