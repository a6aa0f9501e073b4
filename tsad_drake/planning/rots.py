"""ROTS (the paper's ref [13], prehensile actions only) and ROTS*.

ROTS sees every object as an upright cylinder (centre = the estimated centre, radius = that of the
disc with the area of its perceived footprint, the hull of its completed points) and assumes every
cylinder can be grasped from any side. For a round object that is the object; a long or square one
sticks out of its cylinder, which is how ROTS knocks objects over in scenarios 2 and 3 (the paper's
high fall counts). A bounding disc instead makes a 12 cm rectangle a 13 cm cylinder that fits
nowhere, and ROTS then never plans at all.
A modified VFH+ polar histogram around an object, built from the front opening, marks approach
directions whose gripper corridor meets a cylinder (obstacles enlarged by their radius); free
valleys give the candidate directions among Theta. An A* search over relocations (cost = actions,
h = fewest cylinders on any candidate direction to the target) moves cylinders off the best
directions to cells where they block the fewest of the target's directions.

ROTS* is the same search with every step checked by the feasibility model: a pick must be pickable
there, a placement must be among the model's place options, and the goal is a target the model says
can be picked. The two searches stay separate (cylinders plan, the model checks), as in the paper.
"""

from __future__ import annotations

import dataclasses as dc
import heapq
import itertools
import math

import numpy as np

from tsad_drake.geometry2d import approach_corridor, convex_polygons_overlap, side_wall_polygons
from tsad_drake.planning.actions import choose_theta_pick, place_options
from tsad_drake.planning.baseline_common import Budget, preferred_angle, target_clear
from tsad_drake.planning.feasibility import CORRIDOR_OUTSIDE, angle_index
from tsad_drake.planning.pointcloud_sim import (
    DEFAULT_PLACEMENT_GAP,
    footprint_hull,
    simulate_pick_place,
)
from tsad_drake.planning.types import Action, FeasibilityModel, Plan, PlanningState, Workspace


@dc.dataclass
class ROTSConfig:
    """A* budget, VFH+ histogram and placement pruning of ROTS / ROTS*."""

    max_nodes: int = 3_000  #: A* node expansions
    time_limit_s: float = 10.0  #: s, wall-clock budget
    max_relocations: int = 10  #: deepest plan considered
    cells_per_object: int = 4  #: placement candidates per moved object
    histogram_resolution_deg: float = 1.0  #: deg, VFH+ polar histogram bin width
    placement_gap: float = DEFAULT_PLACEMENT_GAP  #: m, gap kept between placed cylinders
    check_feasibility: bool = False  #: ROTS*: check every step with the feasibility model


class CylinderModel:
    """The cylinder abstraction of a state and its VFH+ polar histograms."""

    def __init__(self, workspace: Workspace, config: ROTSConfig) -> None:
        self.workspace, self.config = workspace, config
        self._radius: dict[str, float] = {}
        self._walls = side_wall_polygons(workspace.depth, workspace.width, workspace.wall_thickness)
        self._wall_clear: dict[tuple, bool] = {}
        half = 90.0 - config.histogram_resolution_deg / 2
        self.bins = np.radians(np.arange(-half, half + 1e-9, config.histogram_resolution_deg))

    def radius(self, state: PlanningState, index: int) -> float:
        """Estimated radius of object `index` (cached by name: moving does not change it)."""
        obj = state.objects[index]
        if obj.name not in self._radius:
            hull = footprint_hull(obj)
            x, y = hull[:, 0], hull[:, 1]
            area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
            self._radius[obj.name] = math.sqrt(area / math.pi)
        return self._radius[obj.name]

    def circles(self, state: PlanningState) -> tuple[np.ndarray, np.ndarray]:
        centres = np.array([[o.x, o.y] for o in state.objects])
        radii = np.array([self.radius(state, i) for i in range(len(state.objects))])
        return centres, radii

    def wall_clear(self, x: float, y: float, theta: float) -> bool:
        key = (round(x, 6), round(y, 6), round(theta, 6))
        if key not in self._wall_clear:
            ws = self.workspace
            corridor = approach_corridor(x, y, theta, ws.swept_half_width, ws.finger_reach,
                                         CORRIDOR_OUTSIDE)
            self._wall_clear[key] = not any(convex_polygons_overlap(corridor, w)
                                            for w in self._walls)
        return self._wall_clear[key]

    def histogram(self, point: np.ndarray, centres: np.ndarray, radii: np.ndarray,
                  thetas: np.ndarray) -> np.ndarray:
        """(T, N) cylinder n meets the gripper corridor to `point` along thetas[t] (VFH+ cells,
        obstacles enlarged by their radius plus the gripper's half width)."""
        ws = self.workspace
        u = np.stack([np.cos(thetas), np.sin(thetas)], axis=1)
        v = np.stack([-u[:, 1], u[:, 0]], axis=1)
        back = (point[0] + CORRIDOR_OUTSIDE) / np.maximum(np.cos(thetas), 1e-6)
        rel = centres - point
        along = rel @ u.T  # (N, T)
        across = np.abs(rel @ v.T)
        d_along = np.maximum(0.0, np.maximum(along - ws.finger_reach, -back[None, :] - along))
        d_across = np.maximum(0.0, across - ws.swept_half_width)
        return (np.hypot(d_along, d_across) < radii[:, None]).T

    def blockers(self, state: PlanningState, index: int, thetas: np.ndarray | None = None
                 ) -> list[frozenset[int] | None]:
        """Per angle of `thetas` (default Theta): cylinders on the way to object `index`, or None
        where a side wall is (directions the histogram can never free)."""
        ws = self.workspace
        thetas = ws.approach_angles if thetas is None else thetas
        centres, radii = self.circles(state)
        hist = self.histogram(centres[index], centres, radii, thetas)
        hist[:, index] = False
        x, y = centres[index]
        return [frozenset(np.nonzero(row)[0].tolist()) if self.wall_clear(x, y, th) else None
                for row, th in zip(hist, thetas, strict=True)]

    def free_directions(self, state: PlanningState, index: int) -> np.ndarray:
        """(A,) angles of Theta lying in a free valley of the VFH+ histogram around `index`."""
        ws = self.workspace
        centres, radii = self.circles(state)
        hist = self.histogram(centres[index], centres, radii, self.bins)
        hist[:, index] = False
        free_bins = ~hist.any(axis=1)
        nearest = np.abs(self.bins[None, :] - ws.approach_angles[:, None]).argmin(axis=1)
        x, y = centres[index]
        return np.array([bool(free_bins[b]) and self.wall_clear(x, y, th)
                         for b, th in zip(nearest, ws.approach_angles, strict=True)])

    def place_options(self, state: PlanningState, index: int, theta_pick: float) -> np.ndarray:
        """(C,) theta_place per cell where the cylinder fits and can be reached (nan: not)."""
        ws = self.workspace
        centres, radii = self.circles(state)
        others = np.arange(len(centres)) != index
        r = radii[index]
        cells = ws.cell_centres
        inside = ((cells[:, 0] - r >= 0) & (cells[:, 0] + r <= ws.depth)
                  & (np.abs(cells[:, 1]) + r <= ws.width / 2))
        dist = np.linalg.norm(cells[:, None, :] - centres[None, others, :], axis=2)
        free = inside & np.all(dist >= r + radii[others][None, :] + self.config.placement_gap,
                               axis=1)
        result = np.full(len(cells), np.nan)
        for c in np.nonzero(free)[0]:
            hist = self.histogram(cells[c], centres[others], radii[others], ws.approach_angles)
            ok = np.array([not row.any() and self.wall_clear(*cells[c], th)
                           for row, th in zip(hist, ws.approach_angles, strict=True)])
            theta = preferred_angle(ws, ok, theta_pick)
            if theta is not None:
                result[c] = theta
        return result

    def target_directions_blocked(self, state: PlanningState, index: int, x: float, y: float
                                  ) -> int:
        """How many of the target's directions a cylinder `index` standing at (x, y) blocks."""
        t = state.target_index
        centre = np.array([[x, y]])
        target = np.array([state.objects[t].x, state.objects[t].y])
        hist = self.histogram(target, centre, np.array([self.radius(state, index)]),
                              self.workspace.approach_angles)
        return int(hist.sum())


class _ROTSSearch:
    def __init__(self, feasibility: FeasibilityModel, workspace: Workspace,
                 config: ROTSConfig) -> None:
        self.feasibility, self.workspace, self.config = feasibility, workspace, config
        self.model = CylinderModel(workspace, config)
        self.budget = Budget(config.max_nodes, config.time_limit_s)
        self.star = config.check_feasibility

    def target_sets(self, state: PlanningState) -> list[tuple[float, frozenset[int]]]:
        """(theta, cylinders in the way) for the target's wall-clear directions."""
        sets = self.model.blockers(state, state.target_index)
        return [(float(th), b) for th, b in zip(self.workspace.approach_angles, sets, strict=True)
                if b is not None]

    def h(self, state: PlanningState) -> float:
        return float(min((len(b) for _, b in self.target_sets(state)), default=math.inf))

    def goal(self, state: PlanningState) -> float | None:
        """The retrieval angle when `state` is a goal, else None."""
        free = self.model.free_directions(state, state.target_index)
        if self.star:
            clear = target_clear(self.feasibility, state)
            both = clear & free
            return preferred_angle(self.workspace, both if both.any() else clear)
        return preferred_angle(self.workspace, free)

    def expansions(self, state: PlanningState) -> list[Action]:
        """Relocations of the objects on the target's best directions (fewest cylinders first),
        then of the ones in their way; the next-best directions only when those give no step
        (in ROTS* the model rejects steps, and the search replans around them)."""
        sets = self.target_sets(state)
        t = state.target_index
        for count in sorted({len(b) for _, b in sets}):
            first: set[int] = set()
            for theta, b in sets:
                if len(b) != count:
                    continue
                first |= b
                if not b and self.star:  # the cylinders say free, the model does not
                    k = angle_index(self.workspace.approach_angles, theta)
                    first |= self.feasibility.blockers(state, t)[k]
            order = sorted(first - {t})
            for i in list(order):
                for b in self.model.blockers(state, i):
                    order.extend(j for j in sorted(b or ()) if j not in order and j != t)
            actions = [a for i in order for a in self.moves(state, i)]
            if actions:
                return actions
        return []

    def moves(self, state: PlanningState, index: int) -> list[Action]:
        ws, name = self.workspace, state.objects[index].name
        if self.star:
            theta_pick = choose_theta_pick(self.feasibility, state, index, ws)
        else:
            theta_pick = preferred_angle(ws, self.model.free_directions(state, index))
        if theta_pick is None:
            return []
        if self.star:
            options = place_options(self.feasibility, state, index, theta_pick, ws)
            cylinder_ok = self.model.place_options(state, index, theta_pick)
            options = np.where(np.isnan(cylinder_ok), np.nan, options)
        else:
            options = self.model.place_options(state, index, theta_pick)
        target = state.objects[state.target_index]
        ranked = []
        for c in np.nonzero(~np.isnan(options))[0]:
            x, y = ws.cell_centres[c]
            blocked = self.model.target_directions_blocked(state, index, x, y)
            ranked.append((blocked, -math.hypot(x - target.x, y - target.y), int(c)))
        ranked.sort()
        return [Action(name, theta_pick, float(ws.cell_centres[c][0]), float(ws.cell_centres[c][1]),
                       float(options[c])) for _, _, c in ranked[:self.config.cells_per_object]]

    def run(self, state: PlanningState) -> tuple[list[Action] | None, float | None]:
        counter = itertools.count()
        frontier = [(self.h(state), next(counter), 0, state, [])]
        best_g = {state.key(): 0}
        while frontier and not self.budget.exhausted():
            _, _, g, node, path = heapq.heappop(frontier)
            theta = self.goal(node)
            if theta is not None:
                return path, theta
            if g >= self.config.max_relocations:
                continue
            self.budget.tick()
            for action in self.expansions(node):
                child = simulate_pick_place(node, action)
                key = child.key()
                if best_g.get(key, math.inf) <= g + 1:
                    continue
                best_g[key] = g + 1
                heapq.heappush(frontier, (g + 1 + self.h(child), next(counter), g + 1,
                                          child, path + [action]))
        return None, None


def plan_rots(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
              config: ROTSConfig | None = None, rng: np.random.Generator | None = None) -> Plan:
    """ROTS: A* over relocations on the cylinder abstraction (deterministic; `rng` unused)."""
    config = config or ROTSConfig()
    name = "rots-star" if config.check_feasibility else "rots"
    search = _ROTSSearch(feasibility, workspace, config)
    actions, theta = search.run(state)
    stats = {"nodes": search.budget.iterations}
    if actions is None:
        reason = ("search budget exhausted" if search.budget.exhausted()
                  else "no relocation sequence frees the target")
        return Plan(name, None, [], False, reason, search.budget.elapsed, stats)
    return Plan(name, theta, actions, True, "", search.budget.elapsed, stats)


def plan_rots_star(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
                   config: ROTSConfig | None = None, rng: np.random.Generator | None = None
                   ) -> Plan:
    """ROTS*: ROTS with every step checked by the feasibility model."""
    config = dc.replace(config or ROTSConfig(), check_feasibility=True)
    return plan_rots(state, feasibility, workspace, config, rng)
