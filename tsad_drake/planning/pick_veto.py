"""A feasibility model with some picks ruled out: (object, approach angle) pairs that motion planning
rejected in the current scene.

When a pick fails at the motion level (no IK for the grasp, a finger against a neighbour), the
object may still be pickable from another angle; ruling out only that angle lets the planner's own
theta_pick choice move to the next one. Every other answer is the wrapped model's.
"""

from __future__ import annotations

import numpy as np

from tsad_drake.planning.interface import FeasibilityModel
from tsad_drake.planning.types import PlanningState


class PickVeto(FeasibilityModel):
    """`base` with `pickable(state, i)[k]` False for every vetoed (object name, angle index k)."""

    def __init__(self, base: FeasibilityModel, vetoes: set[tuple[str, int]]) -> None:
        self.base = base
        self.vetoes = frozenset(vetoes)
        self.name = base.name
        self.workspace = base.workspace
        self.answers_one_cell = base.answers_one_cell
        self._rollout: PickVeto | None = None  #: `rollout_model`'s vetoed copy, made once

    def pickable(self, state: PlanningState, index: int) -> np.ndarray:
        ok = self.base.pickable(state, index)
        name = state.objects[index].name
        ruled_out = [k for n, k in self.vetoes if n == name]
        if not ruled_out:
            return ok
        ok = ok.copy()
        ok[ruled_out] = False
        return ok

    def pickable_at(self, state: PlanningState, index: int, k: int) -> bool:
        if (state.objects[index].name, k) in self.vetoes:
            return False
        return self.base.pickable_at(state, index, k)

    # -- the wrapped model's answers -----------------------------------------------------------
    def blockers(self, state: PlanningState, index: int) -> list[frozenset[int]]:
        return self.base.blockers(state, index)

    def blockers_at(self, state: PlanningState, index: int, k: int) -> frozenset[int]:
        return self.base.blockers_at(state, index, k)

    def reachable(self, state: PlanningState, index: int) -> np.ndarray:
        return self.base.reachable(state, index)

    def unreachable_detail(self, state: PlanningState, index: int) -> str:
        return self.base.unreachable_detail(state, index)

    def place_options(self, state: PlanningState, index: int, theta_pick: float) -> np.ndarray:
        return self.base.place_options(state, index, theta_pick)

    def first_place_option(self, state: PlanningState, index: int, theta_pick: float,
                           cells: list[int]) -> tuple[int, float] | None:
        return self.base.first_place_option(state, index, theta_pick, cells)

    def rollout_model(self) -> FeasibilityModel:
        """The wrapped model's rollout model with the same vetoes (itself when that is the
        wrapped model): rollouts and drafts (`TSADExtras.draft_search`) rule out the same picks."""
        cheap = self.base.rollout_model()
        if cheap is self.base:
            return self
        if self._rollout is None or self._rollout.base is not cheap:
            self._rollout = PickVeto(cheap, set(self.vetoes))
        return self._rollout

    def evaluate_all(self, state: PlanningState) -> None:
        self.base.evaluate_all(state)

    @property
    def evaluations(self) -> int:
        return self.base.evaluations

    @property
    def network_seconds(self) -> float:
        return self.base.network_seconds
