"""The FeasibilityModel interface: every prehensile question a planner asks, and angle helpers.

Planners see a state, a workspace and one of these; nothing here imports Drake or reads true
shapes. Implementations: `planning.feasibility` (geometric, oracle), `prehensile.feasibility`
(the network), `planning.pick_veto` (a model with some picks ruled out).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from tsad_drake.planning.pointcloud_sim import placement_valid, simulate_pick_place
from tsad_drake.planning.types import Action, PlanningState, Workspace


def angle_index(thetas: np.ndarray, theta: float) -> int:
    """Index of the approach angle in `thetas` nearest `theta`."""
    return int(np.argmin(np.abs(thetas - theta)))


def approach_order(thetas: np.ndarray, prefer: float) -> np.ndarray:
    """Indices of `thetas` sorted by distance to `prefer`, ties to the smaller |theta|."""
    return np.lexsort((np.abs(thetas), np.round(np.abs(thetas - prefer), 9)))


class FeasibilityModel(ABC):
    """Answers prehensile questions about a state; batched over approach angles.

    This is everything a planner asks. A model of your own implements `blockers` and `pickable`;
    every other method has an honest default built on those two and the point-cloud simulation,
    which a model overrides only when it can answer faster (the footprint models answer every
    placement cell at once, the network one angle or one cell at a time). Set `workspace` in
    `__init__`: the defaults read its angles and cells.
    """

    name: str = "model"  #: recorded in results ("geometric", "oracle", "net", ...)
    workspace: Workspace
    #: the model answers a single placement cell more cheaply than all of them at once, so
    #: planners ask `first_place_option` over the cells they care about instead of
    #: `place_options` (the network: one query per cell)
    answers_one_cell: bool = False
    evaluations: int = 0  #: network queries run (cache misses); 0 for models without a network
    network_seconds: float = 0.0  #: s spent encoding and running them

    @abstractmethod
    def blockers(self, state: PlanningState, index: int) -> list[frozenset[int]]:
        """Per angle of workspace.approach_angles, the indices of the objects whose presence makes
        approaching object `index` at that angle collide (R_{theta,s} when it is the target)."""

    @abstractmethod
    def pickable(self, state: PlanningState, index: int) -> np.ndarray:
        """(A,) bool: object `index` can be picked at each angle (a clear approach, and its width
        across the gripper fits the stroke)."""

    def blockers_at(self, state: PlanningState, index: int, k: int) -> frozenset[int]:
        """R_{theta_k,s} for object `index`: one angle's answer of `blockers`."""
        return self.blockers(state, index)[k]

    def pickable_at(self, state: PlanningState, index: int, k: int) -> bool:
        """Object `index` can be picked at angle k: one angle's answer of `pickable`."""
        return bool(self.pickable(state, index)[k])

    def reachable(self, state: PlanningState, index: int) -> np.ndarray:
        """(A,) bool: object `index` could be picked at each angle once its blockers are gone.
        Default: every angle (a model that does not know says nothing is ruled out)."""
        return np.ones(len(self.workspace.approach_angles), dtype=bool)

    def unreachable_detail(self, state: PlanningState, index: int) -> str:
        """Why object `index` is `reachable` at no angle, in words (e.g. its width against the
        stroke), for the reason an unsolvable problem reports; "" when the model cannot say."""
        return ""

    def place_options(self, state: PlanningState, index: int, theta_pick: float) -> np.ndarray:
        """(C,) theta_place per grid cell for object `index` picked at theta_pick (nan: the cell
        admits no placement). Default: per cell, the least rotation whose placement is valid in
        the point-cloud simulation and leaves the object pickable there at theta_place."""
        name, thetas = state.objects[index].name, self.workspace.approach_angles
        result = np.full(len(self.workspace.cell_centres), np.nan)
        for c, (x, y) in enumerate(self.workspace.cell_centres):
            for k in approach_order(thetas, theta_pick):
                if not placement_valid(state, index, x, y, thetas[k] - theta_pick, self.workspace):
                    continue
                nxt = simulate_pick_place(state, Action(name, theta_pick, x, y, float(thetas[k])))
                if self.pickable(nxt, index)[k]:
                    result[c] = thetas[k]
                    break
        return result

    def first_place_option(self, state: PlanningState, index: int, theta_pick: float,
                           cells: list[int]) -> tuple[int, float] | None:
        """(cell, theta_place) of the first of `cells` that admits a placement of object `index`
        picked at theta_pick, or None. Default: read off `place_options`."""
        options = self.place_options(state, index, theta_pick)
        for cell in cells:
            if not np.isnan(options[cell]):
                return cell, float(options[cell])
        return None

    def rollout_model(self) -> FeasibilityModel:
        """The model a search's random rollouts draw their actions with (default: this one; the
        network offers a cheaper geometric one, see `TSADExtras.fast_rollouts`)."""
        return self

    def evaluate_all(self, state: PlanningState) -> None:  # noqa: B027 - a hint, no-op by default
        """Answer every (object, angle) query of `state` now, in one batch (a hint; default: none)."""
