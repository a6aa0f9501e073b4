"""Planner registry: name -> plan function with the shared signature, and each one's config.

Every planner is `plan(state, feasibility, workspace, config, rng) -> Plan`. The baselines
("gp3", "rots", "rots-star", "rots-star-search", "optimal") register here next to "tsad".
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Callable
from typing import Any

from tsad_drake.planning.gp3 import GP3Config, plan_gp3
from tsad_drake.planning.optimal import OptimalConfig, plan_optimal
from tsad_drake.planning.rots import ROTSConfig, plan_rots, plan_rots_star
from tsad_drake.planning.tsad import TSADConfig, plan_tsad

PLANNERS: dict[str, Callable] = {"tsad": plan_tsad}
#: planner name -> factory of its default config
CONFIGS: dict[str, Callable[[], Any]] = {"tsad": TSADConfig}
# the baselines (gp3.py, rots.py, optimal.py)
PLANNERS.update({"gp3": plan_gp3, "rots": plan_rots, "rots-star": plan_rots_star,
                 "rots-star-search": plan_rots_star, "optimal": plan_optimal})
CONFIGS.update({"gp3": GP3Config, "rots": ROTSConfig,
                "rots-star": lambda: ROTSConfig(check_feasibility=True),
                "rots-star-search": lambda: ROTSConfig(check_feasibility=True,
                                                       check_during_search=True),
                "optimal": OptimalConfig})
#: TSAD ablations of the paper's Table II: name -> TSADConfig overrides
ABLATIONS: dict[str, dict[str, Any]] = {"none": {}, "no-ro": {"use_ro": False},
                                        "no-re": {"use_re": False}}


def get_planner(name: str) -> Callable:
    """The plan function called `name`; ValueError naming the known ones otherwise."""
    if name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}: use one of {', '.join(sorted(PLANNERS))}")
    return PLANNERS[name]


def make_config(name: str, ablation: str = "none", **overrides: Any) -> Any:
    """Default config of planner `name`, with an ablation (TSAD only) and field overrides."""
    get_planner(name)
    config = CONFIGS[name]() if name in CONFIGS else None
    if ablation != "none":
        if ablation not in ABLATIONS:
            raise ValueError(f"unknown ablation {ablation!r}: use one of {', '.join(ABLATIONS)}")
        if not isinstance(config, TSADConfig):
            raise ValueError(f"ablation {ablation!r} applies to tsad only")
        overrides = {**ABLATIONS[ablation], **overrides}
    return dc.replace(config, **overrides) if overrides else config
