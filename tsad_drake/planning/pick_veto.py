"""A feasibility model with some picks ruled out: (object, approach angle) pairs that motion planning
rejected in the current scene.

When a pick fails at the motion level (no IK for the grasp, a finger against a neighbour), the
object may still be pickable from another angle; ruling out only that angle lets the planner's own
theta_pick choice move to the next one. Everything else is the wrapped model's answer.
"""

from __future__ import annotations

import numpy as np

from tsad_drake.planning.types import FeasibilityModel, PlanningState


class PickVeto:
    """`base` with `pickable(state, i)[k]` False for every vetoed (object name, angle index k)."""

    def __init__(self, base: FeasibilityModel, vetoes: set[tuple[str, int]]) -> None:
        self.base = base
        self.vetoes = frozenset(vetoes)
        self.name = base.name

    def pickable(self, state: PlanningState, index: int) -> np.ndarray:
        ok = self.base.pickable(state, index)
        name = state.objects[index].name
        ruled_out = [k for n, k in self.vetoes if n == name]
        if not ruled_out:
            return ok
        ok = ok.copy()
        ok[ruled_out] = False
        return ok

    def __getattr__(self, attribute: str):
        return getattr(self.base, attribute)  # blockers, reachable, place_options, ...
