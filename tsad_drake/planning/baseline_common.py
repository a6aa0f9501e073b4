"""Helpers the baseline planners (GP3, ROTS, ROTS*, optimal) share: budgets, angle choice, moves.

Only the FeasibilityModel interface and the point-cloud simulation are used; no true shapes.
"""

from __future__ import annotations

import dataclasses as dc
import time

import numpy as np

from tsad_drake.geometry2d import (
    approach_corridor,
    convex_polygons_overlap_pairs,
    edge_normals,
)
from tsad_drake.planning.interface import FeasibilityModel, approach_order
from tsad_drake.planning.pointcloud_sim import (
    footprint_hull,
    move_object,
    moved_polygon,
    simulate_pick_place,
)
from tsad_drake.planning.state import moved_completed_points, occupied_cells
from tsad_drake.planning.types import Action, Plan, PlanningState, PlanObject, Workspace

#: m, where a removed object is parked: far in front of the shelf, out of every corridor
PARK_X = -10.0
#: m, spacing of parked objects along y
PARK_SPACING = 1.0


@dc.dataclass
class Budget:
    """A count budget (iterations or expanded nodes) that ends a search, and a wall-clock safety
    stop that aborts it.

    Only the count decides what a search returns, so the same scene, seed and config give the
    same plan on any machine at any load. A search the safety stop cut is `timed_out`: its
    planner returns a failure saying so (`timed_out_plan`), never the shorter search's answer.
    """

    max_iterations: int  #: iterations or expanded nodes
    safety_stop_s: float  #: s, wall clock after which the search is aborted as timed out
    iterations: int = 0
    start: float = dc.field(default_factory=time.perf_counter)
    timed_out: bool = False  #: the safety stop was reached
    #: the budget this one is a part of (`part`): its ticks count there too, and it ends with it
    parent: Budget | None = None

    def tick(self) -> None:
        self.iterations += 1
        if self.parent is not None:
            self.parent.tick()

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def exhausted(self) -> bool:
        if self.parent is not None:  # the whole search's clock and count end a part too
            if self.parent.exhausted():
                self.timed_out = self.parent.timed_out
                return True
            return self.iterations >= self.max_iterations
        if not self.timed_out and self.elapsed >= self.safety_stop_s:
            self.timed_out = True
        return self.timed_out or self.iterations >= self.max_iterations

    def part(self, max_iterations: int) -> Budget:
        """A budget of at most `max_iterations` of this one's (a part of a search)."""
        return Budget(max_iterations, self.safety_stop_s, parent=self)


def timed_out_plan(planner: str, budget: Budget, stats: dict) -> Plan:
    """The failure a planner returns when its search reached the safety stop (no actions)."""
    reason = (f"timed out: safety stop of {budget.safety_stop_s:g} s reached after "
              f"{budget.iterations} iterations")
    return Plan(planner, None, [], False, reason, budget.elapsed, {**stats, "timed_out": True},
                timed_out=True)


def preferred_angle(workspace: Workspace, mask: np.ndarray, prefer: float = 0.0) -> float | None:
    """The angle of Theta allowed by `mask` closest to `prefer` (ties: smaller |theta|)."""
    for k in approach_order(workspace.approach_angles, prefer):
        if mask[k]:
            return float(workspace.approach_angles[k])
    return None


def reachable_angles(feasibility: FeasibilityModel, state: PlanningState, index: int,
                     workspace: Workspace) -> np.ndarray:
    """(A,) angles at which object `index` could be picked once its blockers are gone."""
    return np.asarray(feasibility.reachable(state, index), dtype=bool)


def park(state: PlanningState, index: int) -> PlanningState:
    """`state` with object `index` removed from the shelf (parked far outside every corridor)."""
    obj = state.objects[index]
    action = Action(obj.name, 0.0, PARK_X, PARK_SPACING * (index + 1), 0.0)
    return simulate_pick_place(state, action)


def target_clear(feasibility: FeasibilityModel, state: PlanningState) -> np.ndarray:
    """(A,) angles at which the target can be taken out in `state`."""
    return np.asarray(feasibility.pickable(state, state.target_index), dtype=bool)


class CellScorer:
    """Cheap per-cell scores of a placement, cached per object pose (ranking signals only).

    `after_moves` is epsilon after the move (state.py's definition of an empty cell);
    `corridor_blocks` counts the target's approach corridors the moved object's perceived hull
    would touch. The feasibility model has the final word on every move.
    """

    def __init__(self, workspace: Workspace) -> None:
        self.workspace = workspace
        self._masks: dict[tuple, np.ndarray] = {}
        self._hulls: dict[str, tuple[np.ndarray, tuple]] = {}
        #: target (x, y) -> its approach corridors (A, 4, 2) and their edge normals
        self._corridors: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    def mask(self, obj: PlanObject) -> np.ndarray:
        key = (obj.name, obj.pose)
        if key not in self._masks:
            ws = self.workspace
            self._masks[key] = occupied_cells(moved_completed_points(obj), ws.cell_centres,
                                              ws.min_empty_distance)
        return self._masks[key]

    def after_moves(self, state: PlanningState, index: int, theta_pick: float,
                    options: np.ndarray) -> dict[int, int]:
        """epsilon after placing object `index` in each cell allowed by `options` (nan: not)."""
        ws = self.workspace
        rest = np.zeros(len(ws.cell_centres), dtype=bool)
        for j, obj in enumerate(state.objects):
            if j != index:
                rest |= self.mask(obj)
        obj = state.objects[index]
        counts = {}
        for c in np.nonzero(~np.isnan(options))[0]:
            x, y = ws.cell_centres[c]
            moved = move_object(obj, x, y, float(options[c]) - theta_pick)
            counts[int(c)] = int(np.count_nonzero(~(rest | self.mask(moved))))
        return counts

    def corridor_blocks(self, state: PlanningState, index: int, x: float, y: float,
                        rotation: float) -> int:
        """How many target approach corridors object `index` moved to (x, y) would touch."""
        obj = state.objects[index]
        if obj.name not in self._hulls:  # the hull moves rigidly with its object
            self._hulls[obj.name] = (footprint_hull(obj), obj.pose)
        hull, (hx, hy, hyaw) = self._hulls[obj.name]
        hull = moved_polygon(hull, (hx, hy), obj.x, obj.y, obj.yaw - hyaw)
        poly = moved_polygon(hull, (obj.x, obj.y), x, y, rotation)
        target = state.objects[state.target_index]
        tkey = (target.x, target.y)
        if tkey not in self._corridors:
            ws = self.workspace
            corridors = np.array([
                approach_corridor(target.x, target.y, th, ws.swept_half_width, ws.finger_reach)
                for th in ws.approach_angles])
            self._corridors[tkey] = (corridors, edge_normals(corridors))
        corridors, normals = self._corridors[tkey]
        polys = np.broadcast_to(poly, (len(corridors),) + poly.shape)
        poly_normals = np.broadcast_to(edge_normals(poly), polys.shape)
        return int(np.count_nonzero(convex_polygons_overlap_pairs(
            corridors, polys, normals_a=normals, normals_b=poly_normals)))
