"""The shipped network weights: where they are and their fingerprint, without PyTorch.

The geometric path (the default) needs no torch: the bench records the weights' digest and the
command line checks the `net` choice with this module alone; PyTorch is the `net` extra
(`pip install 'tsad_drake[net]'`), and `require_torch` says so in one line where it is missing.
"""

from __future__ import annotations

import hashlib
import importlib.util
from pathlib import Path

from tsad_drake.errors import UsageError

#: the shipped weights, produced by `tsad train` (see docs/model-card.md)
DEFAULT_WEIGHTS = Path(__file__).resolve().parent.parent / "data" / "prehensile_net.pt"
#: the shipped weights fine-tuned on realistic depth with cluster segmentation (model card)
REALISTIC_WEIGHTS = DEFAULT_WEIGHTS.with_name("prehensile_net_realistic.pt")


def shipped_weights(sensor: str = "ideal") -> Path:
    """The shipped weights for observations of the sensor called `sensor`: the fine-tune on
    realistic depth for every sensor but the ideal one."""
    return DEFAULT_WEIGHTS if sensor == "ideal" else REALISTIC_WEIGHTS


def weights_digest(path: str | Path | None = None) -> str:
    """Short fingerprint of a weights file (default: the shipped one): `--feasibility net` rows
    record it so a resumed bench never mixes in rows planned with another network."""
    path = Path(path) if path is not None else DEFAULT_WEIGHTS
    return hashlib.sha1(path.read_bytes()).hexdigest()[:12]


def require_torch(what: str = "the prehensile network (--feasibility net)") -> None:
    """UsageError (one line, exit status 2) when PyTorch or numba (the `net` extra) is missing."""
    if importlib.util.find_spec("torch") is None:
        raise UsageError(f"{what} needs PyTorch: pip install 'tsad_drake[net]'")
    if importlib.util.find_spec("numba") is None:
        raise UsageError(f"{what} needs numba: pip install 'tsad_drake[net]'")
