"""Planner registry: each planner's plan function, default config and what it supports.

Every planner is `plan(state, feasibility, workspace, config, rng) -> Plan`. An entry says which
of the closed loop's re-planning features the planner takes part in, so the loop never guesses
from its config's fields; a planner of your own registers a `PlannerSpec` with `register`.

The registry is framework: it imports no planner. The built-in planners (`tsad_drake.planners`)
register themselves when that package is imported, which every import of one of them, of
`run_config` (their configs) or of the composition root (`pipeline`) does.
"""

from __future__ import annotations

import copy
import dataclasses as dc
from collections.abc import Callable
from typing import Any

#: plan(state, feasibility, workspace, config, rng) -> Plan
PlanFunction = Callable[..., Any]


@dc.dataclass(frozen=True)
class PlannerSpec:
    """A planner and what it supports (each flag names the config fields it relies on)."""

    name: str
    plan: PlanFunction
    default_config: Callable[[], Any]
    #: plans in sub-searches: in closed loop it is asked for the first one only
    #: (`config.max_sub_searches = 1`) unless the run's `episode.lookahead` is set
    sub_searches: bool = False
    #: honours excluded relocations (`config.excluded_actions`): a relocation motion planning
    #: refused, or one that brought the scene back to an earlier configuration, is excluded and
    #: the planner asked again
    exclusions: bool = False
    #: the closed loop may keep the rest of its last plan while a new observation still admits
    #: it (the run's `episode.reuse_plans`)
    reuse: bool = False
    #: decides itself whether a problem can be solved (TSAD's `fail_fast`, off in its paper
    #: variant); for the others the closed loop checks before asking (`episode.fail_fast`)
    checks_solvability: bool = False
    #: takes the paper's reward ablations (`ABLATIONS`)
    ablations: bool = False
    #: named variants: name -> config overrides ("full" is the default config)
    variants: dict[str, dict[str, Any]] = dc.field(default_factory=lambda: {"full": {}})
    #: per variant, the run's `episode` section fields it sets (`execution.episode.EpisodeConfig`:
    #: look_again, lookahead, ...); a variant not named keeps the section's defaults
    episode_variants: dict[str, dict[str, Any]] = dc.field(default_factory=dict)


#: TSAD ablations of the paper's Table II: name -> config overrides
ABLATIONS: dict[str, dict[str, Any]] = {"none": {}, "no-ro": {"use_ro": False},
                                        "no-re": {"use_re": False}}

PLANNERS: dict[str, PlannerSpec] = {}


def register(spec: PlannerSpec) -> None:
    """Make `spec` available by its name (`tsad plan --planner NAME` for built-in names)."""
    PLANNERS[spec.name] = spec


def get_planner(name: str) -> PlannerSpec:
    """The planner called `name`; ValueError naming the known ones otherwise."""
    if name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}: use one of {', '.join(sorted(PLANNERS))}")
    return PLANNERS[name]


def make_config(name: str, ablation: str = "none", variant: str = "full", **overrides: Any) -> Any:
    """Default config of planner `name` in `variant`, with an ablation and field overrides
    (applied in that order)."""
    spec = get_planner(name)
    config = spec.default_config()
    if variant not in spec.variants:
        raise ValueError(f"planner {name!r} has no variant {variant!r}: use one of "
                         f"{', '.join(spec.variants)}")
    changes = copy.deepcopy(spec.variants[variant])  # a nested config is never shared
    if ablation != "none":
        if ablation not in ABLATIONS:
            raise ValueError(f"unknown ablation {ablation!r}: use one of {', '.join(ABLATIONS)}")
        if not spec.ablations:
            raise ValueError(f"ablation {ablation!r} applies to tsad only")
        changes.update(ABLATIONS[ablation])
    changes.update(overrides)
    return dc.replace(config, **changes) if changes else config
