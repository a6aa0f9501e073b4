"""Prehensile network checkpoints: the file format, the shipped weights' path, save and load.

A checkpoint is a torch file {"format": CHECKPOINT_FORMAT, "config": NetConfig fields,
"encoding": the input constants it was trained with, "state_dict": ..., "meta": {...}}; loading
checks all of them, so a file from another version or a corrupted one fails with one clear line.
"""

from __future__ import annotations

import dataclasses as dc
import hashlib
from pathlib import Path

import torch

from tsad_drake.errors import WeightsError
from tsad_drake.prehensile import encoding
from tsad_drake.prehensile.network import NetConfig, PrehensileNet

#: format tag, changed whenever the network or its input encoding changes
CHECKPOINT_FORMAT = "tsad-prehensile-net-v5"
#: the shipped weights, produced by `tsad train` (see docs/model-card.md)
DEFAULT_WEIGHTS = Path(__file__).resolve().parent.parent / "data" / "prehensile_net.pt"


def encoding_signature() -> dict:
    """The input-encoding constants a checkpoint must agree with."""
    return {name: getattr(encoding, name) for name in (
        "NUM_POINTS", "MAX_QUERY_POINTS", "QUERY_EDGE_POINTS", "GRID", "WALL_GRID", "COORD_SCALE",
        "HEIGHT_SCALE", "CROP_BACK", "CROP_FRONT", "CROP_HALF_WIDTH", "NUM_FEATURES")}


def save_checkpoint(net: PrehensileNet, path: Path, meta: dict) -> None:
    """Write the network and `meta` to `path` atomically (a temporary file, then a rename)."""
    tmp = Path(path).with_suffix(".tmp")
    torch.save({"format": CHECKPOINT_FORMAT, "config": dc.asdict(net.config),
                "encoding": encoding_signature(), "state_dict": net.state_dict(), "meta": meta}, tmp)
    tmp.replace(path)


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
    try:
        config = NetConfig(**{k: tuple(v) if isinstance(v, list) else v
                              for k, v in ckpt["config"].items()})
        net = PrehensileNet(config)
        net.load_state_dict(ckpt["state_dict"])
    except (TypeError, KeyError, RuntimeError) as err:
        raise WeightsError(f"{path} does not match the prehensile network: "
                           f"{str(err).splitlines()[0][:120]}") from None
    net.eval()
    return net, dict(ckpt.get("meta", {}))


def weights_digest(path: str | Path | None = None) -> str:
    """Short fingerprint of a weights file (default: the shipped one): `--feasibility net` rows
    record it so a resumed bench never mixes in rows planned with another network."""
    path = Path(path) if path is not None else DEFAULT_WEIGHTS
    return hashlib.sha1(path.read_bytes()).hexdigest()[:12]
