"""`--config FILE.yaml` and `--set section.field=value`: the flags of plan, bench, config and
verify."""

from __future__ import annotations

import argparse

from tsad_drake.errors import UsageError


def add_config_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--config", metavar="FILE.yaml", default=None,
                   help="YAML file of settings (as `tsad config --dump` prints): sections planner, "
                        "sensor, perception, station (with station.camera), motion, world; the "
                        "fields it names replace the defaults the other flags pick, the rest "
                        "keep them")
    p.add_argument("--set", metavar="SECTION.FIELD=VALUE", action="append", default=[],
                   dest="set",
                   help="replace one field after --config, e.g. --set planner.iteration_budget=5000 "
                        "or --set station.camera.width=64 (the value is YAML, checked against "
                        "the field's type; repeatable)")


def effective_config(args: argparse.Namespace):
    """The run's config: the defaults of --planner, --ablation, --variant and --sensor, then
    --config, then each --set (UsageError for anything unknown or ill-typed)."""
    from tsad_drake.run_config import default_run_config

    try:
        config = default_run_config(args.planner, args.ablation, args.variant, args.sensor)
    except ValueError as err:
        raise UsageError(str(err)) from None
    return apply_config_args(config, args)


def apply_config_args(config, args: argparse.Namespace):
    """`config` with --config merged and each --set applied (UsageError for anything unknown or
    ill-typed)."""
    from tsad_drake.run_config import apply_sets, merge_file

    if args.config is not None:
        config = merge_file(config, args.config)
    return apply_sets(config, args.set)
