"""The built-in planners: TSAD (`planners.tsad`), GP3, ROTS / ROTS* and `optimal`.

Importing this package registers them (`planning.registry.register`); the framework in
`planning/` never imports them.
"""

from __future__ import annotations

from tsad_drake.planners.gp3 import GP3Config, plan_gp3
from tsad_drake.planners.optimal import OptimalConfig, plan_optimal
from tsad_drake.planners.rots import ROTSConfig, plan_rots, plan_rots_star
from tsad_drake.planners.tsad.config import EPISODE_VARIANTS, VARIANTS, TSADConfig
from tsad_drake.planners.tsad.plan import plan_tsad
from tsad_drake.planning.registry import PlannerSpec, register

register(PlannerSpec("tsad", plan_tsad, TSADConfig, sub_searches=True, exclusions=True,
                     reuse=True, ablations=True, checks_solvability=True, variants=VARIANTS,
                     episode_variants=EPISODE_VARIANTS))
register(PlannerSpec("gp3", plan_gp3, GP3Config))
register(PlannerSpec("rots", plan_rots, ROTSConfig))
register(PlannerSpec("rots-star", plan_rots_star, lambda: ROTSConfig(check_feasibility=True)))
register(PlannerSpec("rots-star-search", plan_rots_star,
                     lambda: ROTSConfig(check_feasibility=True, check_during_search=True)))
register(PlannerSpec("optimal", plan_optimal, OptimalConfig))
