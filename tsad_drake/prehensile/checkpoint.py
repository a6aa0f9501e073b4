"""Prehensile network checkpoints: the file format, the shipped weights' path, save and load.

A checkpoint is a torch file {"format": CHECKPOINT_FORMAT, "config": NetConfig fields,
"encoding": the input constants it was trained with, "state_dict": ..., "meta": {...}}; loading
checks all of them (every config size bounded, every weight finite, the meta fields the commands
read well formed), so a file from another version or a corrupted one fails with one clear line.
"""

from __future__ import annotations

import dataclasses as dc
import math
from pathlib import Path

import torch

from tsad_drake.errors import WeightsError
from tsad_drake.outputs import atomic_write
from tsad_drake.prehensile import encoding
from tsad_drake.prehensile.network import NetConfig, PrehensileNet
from tsad_drake.prehensile.weights import DEFAULT_WEIGHTS

#: format tag, changed whenever the network or its input encoding changes
CHECKPOINT_FORMAT = "tsad-prehensile-net-v5"
def encoding_signature() -> dict:
    """The input-encoding constants a checkpoint must agree with."""
    return {name: getattr(encoding, name) for name in (
        "NUM_POINTS", "MAX_QUERY_POINTS", "QUERY_EDGE_POINTS", "GRID", "WALL_GRID", "COORD_SCALE",
        "HEIGHT_SCALE", "CROP_BACK", "CROP_FRONT", "CROP_HALF_WIDTH", "NUM_FEATURES")}


def save_checkpoint(net: PrehensileNet, path: Path, meta: dict) -> None:
    """Write the network and `meta` to `path` atomically (a temporary file, then a rename)."""
    document = {"format": CHECKPOINT_FORMAT, "config": dc.asdict(net.config),
                "encoding": encoding_signature(), "state_dict": net.state_dict(), "meta": meta}
    atomic_write(path, lambda tmp: torch.save(document, tmp))


def load_checkpoint(path: str | Path | None = None) -> tuple[PrehensileNet, dict]:
    """(network in eval mode, meta) from `path` (default: the shipped weights).

    Raises:
        WeightsError: the file is missing, unreadable or from another model/encoding version.
    """
    path = Path(path) if path is not None else DEFAULT_WEIGHTS
    if not path.is_file():
        raise WeightsError(f"prehensile network weights not found: {path} "
                           "(train them with `tsad train --data DIR --out FILE`)")
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # noqa: BLE001 - any unpickling failure means a bad file
        raise WeightsError(f"cannot read prehensile network weights {path}: "
                           f"{type(err).__name__}") from None
    if not isinstance(ckpt, dict) or ckpt.get("format") != CHECKPOINT_FORMAT:
        raise WeightsError(f"{path} is not a prehensile network checkpoint ({CHECKPOINT_FORMAT})")
    if ckpt.get("encoding") != encoding_signature():
        raise WeightsError(f"{path} was trained with another input encoding; retrain with `tsad train`")
    config = _config(path, ckpt.get("config"))
    try:
        net = PrehensileNet(config)
        net.load_state_dict(ckpt["state_dict"])
    except Exception as err:  # noqa: BLE001 - a state_dict of another shape, kind or layout
        raise WeightsError(f"{path} does not match the prehensile network: "
                           f"{str(err).splitlines()[0][:120] if str(err) else type(err).__name__}"
                           ) from None
    for name, tensor in net.state_dict().items():
        if tensor.is_floating_point() and not bool(torch.isfinite(tensor).all()):
            raise WeightsError(f"{path}: weight {name} holds values that are not finite")
    meta = ckpt.get("meta", {})
    _check_meta(path, meta)
    net.eval()
    return net, dict(meta)


#: largest value of any size in a checkpoint's config (a corrupted size must not allocate memory)
MAX_CONFIG_SIZE = 1024


def _config(path: Path, fields) -> NetConfig:
    """The NetConfig a checkpoint records, every field of the right kind and size."""
    defaults = dc.asdict(NetConfig())
    if not isinstance(fields, dict) or set(fields) - set(defaults):
        raise WeightsError(f"{path} does not match the prehensile network: config is malformed")
    values = {}
    for key, value in fields.items():
        default = defaults[key]
        if isinstance(default, tuple):
            ok = isinstance(value, (list, tuple)) and 0 < len(value) <= 8 and all(
                _int_in_range(v) for v in value)
            value = tuple(value) if ok else value
        elif isinstance(default, float):
            ok = isinstance(value, (int, float)) and not isinstance(value, bool) and (
                math.isfinite(value) and 0 < value <= MAX_CONFIG_SIZE)
        else:
            ok = _int_in_range(value)
        if not ok:
            raise WeightsError(f"{path} does not match the prehensile network: config.{key} "
                               f"is malformed ({value!r:.60})")
        values[key] = value
    return NetConfig(**values)


def _int_in_range(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 < value <= MAX_CONFIG_SIZE


def _check_meta(path: Path, meta) -> None:
    """The meta fields the commands read: thresholds are finite numbers, seed ranges [first, last]."""
    if not isinstance(meta, dict):
        raise WeightsError(f"{path}: meta is malformed (not a mapping)")
    for key in ("reach_threshold", "block_threshold", "set_threshold"):
        value = meta.get(key)
        if value is not None and not (isinstance(value, (int, float)) and not isinstance(
                value, bool) and math.isfinite(value)):
            raise WeightsError(f"{path}: meta.{key} must be a finite number")
    calibration = meta.get("calibration", {})
    if not isinstance(calibration, dict):
        raise WeightsError(f"{path}: meta.calibration is malformed (not a mapping)")
    for key, seeds in (("seed_range", meta.get("seed_range")),
                       ("calibration.seeds", calibration.get("seeds"))):
        if seeds is not None and not (
                isinstance(seeds, (list, tuple)) and len(seeds) == 2
                and all(isinstance(v, int) and not isinstance(v, bool) for v in seeds)
                and seeds[0] <= seeds[1]):
            raise WeightsError(f"{path}: meta.{key} must be [first seed, last seed]")
