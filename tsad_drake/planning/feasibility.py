"""Batched FeasibilityModel implementations: `oracle` (true shapes) and `geometric` (point clouds).

Both reduce every object to a convex footprint polygon with a grasp centre and a width across the
gripper per approach angle, then answer all questions with vectorised corridor tests:

- oracle: the true footprint of the scenario object each PlanObject stands for, at the pose the
  simulation has moved it to (true centre on the placement cell, yaw turned with the gripper);
- geometric: the hull of the object's perceived points completed by point reflection through its
  estimated centre (cylinders and boxes are centrally symmetric), nothing else.

The gripper corridor is `geometry2d.approach_corridor`; the side walls block it too. An object can be
picked at theta when its corridor is clear and its width across fits the stroke minus the margin.
Answers are cached per state (states are immutable; the key is the tuple of object poses).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from tsad_drake.geometry2d import (
    approach_corridor,
    convex_polygons_overlap_pairs,
    footprint_polygon,
    pad_polygons,
    rotation2d,
    side_wall_polygons,
    width_across,
)
from tsad_drake.planning.interface import FeasibilityModel, approach_order
from tsad_drake.planning.pointcloud_sim import (
    DEFAULT_PLACEMENT_GAP,
    PERCEIVED_EDGE_MARGIN,
    PERCEIVED_FIT_MARGIN,
    PERCEIVED_PLACEMENT_GAP,
    inside_workspace,
    perceived_hull,
)
from tsad_drake.planning.types import PlanningState, PlanObject, Workspace
from tsad_drake.scenario import ObjectConfig, Scenario

#: m, how far in front of the shelf's front edge the approach corridor starts
CORRIDOR_OUTSIDE = 0.30
#: states kept in a model's cache before it is cleared
CACHE_LIMIT = 50_000


@dc.dataclass
class ObjectGeometry:
    """One object reduced to what the corridor tests need."""

    polygon: np.ndarray  #: (K, 2) counter-clockwise convex footprint in S, m
    centre: np.ndarray  #: (2,) grasp point in S, m
    widths: np.ndarray  #: (A,) m, width across the gripper per approach angle
    outer: float = 0.0  #: m, largest distance from the centre to the footprint
    inner: float = 0.0  #: m, radius of the largest centred disc inside the footprint

    def __post_init__(self) -> None:
        rel = self.polygon - self.centre
        self.outer = float(np.linalg.norm(rel, axis=1).max())
        edges = np.roll(self.polygon, -1, axis=0) - self.polygon
        lengths = np.linalg.norm(edges, axis=1)
        keep = lengths > 1e-12
        # distance of the centre to the left of each counter-clockwise edge: cross(edge, c - p)
        cross = edges[keep, 1] * rel[keep, 0] - edges[keep, 0] * rel[keep, 1]
        self.inner = float(max(0.0, (cross / lengths[keep]).min())) if keep.any() else 0.0


def corridor_polygons(centres: np.ndarray, thetas: np.ndarray, workspace: Workspace) -> np.ndarray:
    """(Q, 4, 2) approach corridors to `centres` (Q, 2) along `thetas` (Q,)."""
    return np.array([approach_corridor(x, y, th, workspace.swept_half_width,
                                       workspace.finger_reach, CORRIDOR_OUTSIDE)
                     for (x, y), th in zip(centres, thetas, strict=True)]).reshape(-1, 4, 2)


def corridor_hits(centres: np.ndarray, thetas: np.ndarray, corridors: np.ndarray,
                  objects: list[ObjectGeometry], workspace: Workspace) -> np.ndarray:
    """(Q, J) True where corridor q (to centres[q] along thetas[q]) touches object j's footprint.

    Exact (the separating-axis test of `geometry2d`) but only run where the bounding discs of the
    footprints leave the answer open.
    """
    q, j = len(centres), len(objects)
    hits = np.zeros((q, j), dtype=bool)
    if q == 0 or j == 0:
        return hits
    obj_centres = np.array([o.centre for o in objects])
    outer = np.array([o.outer for o in objects])
    inner = np.array([o.inner for o in objects])
    u = np.stack([np.cos(thetas), np.sin(thetas)], axis=1)
    v = np.stack([-u[:, 1], u[:, 0]], axis=1)
    back = (centres[:, 0] + CORRIDOR_OUTSIDE) / np.maximum(np.cos(thetas), 1e-6)
    rel = obj_centres[None, :, :] - centres[:, None, :]
    along = np.einsum("qjd,qd->qj", rel, u)
    across = np.abs(np.einsum("qjd,qd->qj", rel, v))
    d_along = np.maximum(0.0, np.maximum(along - workspace.finger_reach, -back[:, None] - along))
    d_across = np.maximum(0.0, across - workspace.swept_half_width)
    dist = np.hypot(d_along, d_across)
    sure_hit = dist < inner[None, :] - 1e-9
    open_ = (dist <= outer[None, :] + 1e-9) & ~sure_hit
    hits |= sure_hit
    qi, ji = np.nonzero(open_)
    if len(qi):
        polys = pad_polygons([o.polygon for o in objects])
        hits[qi, ji] = convex_polygons_overlap_pairs(corridors[qi], polys[ji])
    return hits





class StateGeometry:
    """Per-state lazily computed corridor answers of a footprint model."""

    def __init__(self, objects: list[ObjectGeometry], num_plan_objects: int,
                 model: FootprintFeasibility) -> None:
        self.objects = objects  #: plan objects first, then static obstacles (oracle: unseen)
        self.num_plan_objects = num_plan_objects
        self.model = model
        self._object_hits: np.ndarray | None = None
        self._cell_hits: np.ndarray | None = None
        self.place_memo: dict[tuple[int, float], np.ndarray] = {}

    @property
    def object_hits(self) -> np.ndarray:
        """(N, A, J) corridor to plan object i at angle a touches object j (j == i excluded)."""
        if self._object_hits is None:
            ws, n = self.model.workspace, self.num_plan_objects
            thetas = ws.approach_angles
            centres = np.repeat(np.array([o.centre for o in self.objects[:n]]), len(thetas), axis=0)
            angles = np.tile(thetas, n)
            corridors = corridor_polygons(centres, angles, ws)
            hits = corridor_hits(centres, angles, corridors, self.objects, ws)
            hits = hits.reshape(n, len(thetas), len(self.objects))
            hits[np.arange(n), :, np.arange(n)] = False
            self._object_hits = hits
        return self._object_hits

    @property
    def cell_hits(self) -> np.ndarray:
        """(C, A, J) corridor to grid cell c at angle a touches object j."""
        if self._cell_hits is None:
            ws, cache = self.model.workspace, self.model.cell_corridors
            hits = corridor_hits(cache.centres, cache.thetas, cache.polygons, self.objects, ws)
            self._cell_hits = hits.reshape(len(ws.cell_centres), len(ws.approach_angles), -1)
        return self._cell_hits


@dc.dataclass
class CellCorridors:
    """Corridors to every grid cell at every approach angle (fixed per workspace)."""

    centres: np.ndarray  #: (C*A, 2)
    thetas: np.ndarray  #: (C*A,)
    polygons: np.ndarray  #: (C*A, 4, 2)
    wall_clear: np.ndarray  #: (C, A) the corridor misses both side walls


class FootprintFeasibility(FeasibilityModel):
    """Shared machinery: subclasses say how a PlanObject becomes an ObjectGeometry."""

    name = "footprint"

    def __init__(self, workspace: Workspace, placement_gap: float = DEFAULT_PLACEMENT_GAP,
                 edge_margin: float = 0.0, fit_margin: float = 0.0) -> None:
        self.workspace = workspace
        self.placement_gap = placement_gap  #: m, a placed object keeps this far from the others
        self.edge_margin = edge_margin  #: m, and this far inside the shelf floor's edges
        self.fit_margin = fit_margin  #: m, graspable widths stay this far under the stroke's limit
        self._walls = side_wall_polygons(workspace.depth, workspace.width,
                                         workspace.wall_thickness)
        self._states: dict[tuple, StateGeometry] = {}
        self._objects: dict[tuple, tuple[ObjectGeometry, np.ndarray]] = {}
        thetas = workspace.approach_angles
        cells = workspace.cell_centres
        centres = np.repeat(cells, len(thetas), axis=0)
        angles = np.tile(thetas, len(cells))
        polys = corridor_polygons(centres, angles, workspace)
        self.cell_corridors = CellCorridors(
            centres, angles, polys, self._walls_clear(polys).reshape(len(cells), len(thetas)))

    # -- subclass hooks ------------------------------------------------------------------------
    def object_geometry(self, obj: PlanObject) -> ObjectGeometry:
        raise NotImplementedError

    def static_obstacles(self, state: PlanningState) -> list[ObjectGeometry]:
        """Obstacles that are not plan objects (none, unless the model knows more than the state)."""
        return []

    # -- caches --------------------------------------------------------------------------------
    def _walls_clear(self, corridors: np.ndarray) -> np.ndarray:
        clear = np.ones(len(corridors), dtype=bool)
        for wall in self._walls:
            clear &= ~convex_polygons_overlap_pairs(
                corridors, np.broadcast_to(wall, (len(corridors),) + wall.shape))
        return clear

    def _object_entry(self, obj: PlanObject) -> tuple[ObjectGeometry, np.ndarray]:
        key = (obj.name, obj.pose, obj.origin, len(obj.points))
        entry = self._objects.get(key)
        if entry is None:
            geom = self.object_geometry(obj)
            thetas = self.workspace.approach_angles
            corridors = corridor_polygons(np.repeat(geom.centre[None], len(thetas), axis=0),
                                          thetas, self.workspace)
            entry = (geom, self._walls_clear(corridors))
            self._objects[key] = entry
        return entry

    def geometry(self, state: PlanningState) -> StateGeometry:
        """The cached StateGeometry of `state`."""
        key = state.key()
        geom = self._states.get(key)
        if geom is None:
            if len(self._states) > CACHE_LIMIT:
                self._states.clear()
                self._objects.clear()
            objects = [self._object_entry(o)[0] for o in state.objects]
            geom = StateGeometry(objects + self.static_obstacles(state), len(objects), self)
            self._states[key] = geom
        return geom

    # -- FeasibilityModel ----------------------------------------------------------------------
    def blockers(self, state: PlanningState, index: int) -> list[frozenset[int]]:
        """Per approach angle, the plan objects the corridor to object `index` touches."""
        g = self.geometry(state)
        hits = g.object_hits[index, :, :g.num_plan_objects]
        return [frozenset(np.nonzero(row)[0].tolist()) for row in hits]

    def reachable(self, state: PlanningState, index: int) -> np.ndarray:
        """(A,) the object fits the stroke and its corridor misses the walls (ignoring objects)."""
        geom, wall_clear = self._object_entry(state.objects[index])
        ws = self.workspace
        return wall_clear & (geom.widths <= ws.stroke - ws.grasp_margin - self.fit_margin + 1e-9)

    def pickable(self, state: PlanningState, index: int) -> np.ndarray:
        """(A,) object `index` can be picked at each angle: reachable with a clear corridor."""
        g = self.geometry(state)
        return self.reachable(state, index) & ~g.object_hits[index].any(axis=1)

    # -- placements ----------------------------------------------------------------------------
    def place_options(self, state: PlanningState, index: int, theta_pick: float) -> np.ndarray:
        """(C,) theta_place per grid cell for moving object `index` picked at theta_pick; nan
        where no angle works.

        A cell works at theta_place when the object, turned by theta_place - theta_pick, lies
        inside the workspace (`edge_margin` inside its edges) at least `placement_gap` from every
        other footprint, and the corridor to the cell at theta_place misses the walls and every
        other object (so the placed object is pickable there in s'). Its width across is
        unchanged because it turns with the gripper.
        The least rotation wins.
        """
        g = self.geometry(state)
        memo_key = (index, round(float(theta_pick), 9))
        if memo_key in g.place_memo:
            return g.place_memo[memo_key]
        ws, gap, edge = self.workspace, self.placement_gap, self.edge_margin
        thetas, cells = ws.approach_angles, ws.cell_centres
        me = g.objects[index]
        others = [j for j in range(len(g.objects)) if j != index]
        clear = self.cell_corridors.wall_clear & ~g.cell_hits[:, :, others].any(axis=2)
        result = np.full(len(cells), np.nan)
        unresolved = np.ones(len(cells), dtype=bool)
        other_centres = np.array([g.objects[j].centre for j in others]).reshape(-1, 2)
        other_outer = np.array([g.objects[j].outer for j in others])
        other_inner = np.array([g.objects[j].inner for j in others])
        other_polys = pad_polygons([g.objects[j].polygon for j in others]) if others else None
        dist = np.linalg.norm(cells[:, None, :] - other_centres[None, :, :], axis=2)  # (C, O)
        occupied = np.any(dist < me.inner + other_inner[None, :] + gap, axis=1)
        unresolved &= ~occupied
        local = me.polygon - me.centre
        for k in approach_order(thetas, theta_pick):
            cand = np.nonzero(unresolved & clear[:, k])[0]
            if len(cand) == 0:
                continue
            rotated = local @ rotation2d(thetas[k] - theta_pick).T
            polys = rotated[None, :, :] + cells[cand][:, None, :]  # (c, K, 2)
            ok = inside_workspace(polys, ws, edge)
            if other_polys is not None:
                near = dist[cand] <= me.outer + other_outer[None, :] + gap + 1e-9
                ci, oi = np.nonzero(near & ok[:, None])
                if len(ci):
                    overlap = convex_polygons_overlap_pairs(polys[ci], other_polys[oi], gap)
                    bad = np.zeros(len(cand), dtype=bool)
                    np.logical_or.at(bad, ci, overlap)
                    ok &= ~bad
            result[cand[ok]] = thetas[k]
            unresolved[cand[ok]] = False
            if not unresolved.any():
                break
        g.place_memo[memo_key] = result
        return result


def polygon_widths(polygon: np.ndarray, thetas: np.ndarray) -> np.ndarray:
    """(A,) extent of `polygon` perpendicular to each approach direction."""
    v = np.stack([-np.sin(thetas), np.cos(thetas)], axis=1)
    proj = polygon @ v.T
    return proj.max(axis=0) - proj.min(axis=0)


class GeometricFeasibility(FootprintFeasibility):
    """Feasibility from the perceived point clouds only (hull of the centrally completed points)."""

    name = "geometric"

    def __init__(self, workspace: Workspace, placement_gap: float = PERCEIVED_PLACEMENT_GAP,
                 edge_margin: float = PERCEIVED_EDGE_MARGIN,
                 fit_margin: float = PERCEIVED_FIT_MARGIN) -> None:
        super().__init__(workspace, placement_gap, edge_margin, fit_margin)

    def object_geometry(self, obj: PlanObject) -> ObjectGeometry:
        polygon = perceived_hull(obj)
        return ObjectGeometry(polygon, np.array([obj.x, obj.y]),
                              polygon_widths(polygon, self.workspace.approach_angles))


class OracleFeasibility(FootprintFeasibility):
    """Feasibility from the true shapes of `scenario` (ground truth for judging and labelling).

    Each PlanObject stands for the scenario object of the same name (or, for "cluster<k>" names,
    the one whose centre is nearest the perceived centre). A moved object's true centre is the
    placement cell and its true yaw turned by the same angle as the plan object's. Scenario
    objects no PlanObject stands for (unseen ones) are static obstacles: they block corridors and
    placements but are never in a rearrangement set.
    """

    name = "oracle"

    def __init__(self, scenario: Scenario, workspace: Workspace | None = None,
                 placement_gap: float = DEFAULT_PLACEMENT_GAP) -> None:
        if workspace is None:
            from tsad_drake.planning.state import make_workspace

            workspace = make_workspace(scenario)
        super().__init__(workspace, placement_gap)
        self.scenario = scenario
        self._by_name = {o.name: o for o in scenario.objects}
        self._centres = np.array([[o.x, o.y] for o in scenario.objects])
        self._hidden: dict[frozenset, list[ObjectGeometry]] = {}

    def true_object(self, obj: PlanObject) -> ObjectConfig:
        """The scenario object `obj` stands for."""
        if obj.name in self._by_name:
            return self._by_name[obj.name]
        x, y, _ = obj.origin if obj.origin is not None else obj.pose
        nearest = int(np.argmin(np.linalg.norm(self._centres - [x, y], axis=1)))
        return self.scenario.objects[nearest]

    def true_pose(self, obj: PlanObject) -> tuple[float, float, float]:
        """True (x, y, yaw) of the object `obj` stands for, after the simulated moves."""
        true = self.true_object(obj)
        if not obj.moved:
            return true.x, true.y, true.yaw
        return obj.x, obj.y, true.yaw + obj.yaw - obj.origin[2]

    def _geometry_at(self, true: ObjectConfig, x: float, y: float, yaw: float) -> ObjectGeometry:
        widths = np.array([width_across(true.shape, true.size, yaw, th)
                           for th in self.workspace.approach_angles])
        return ObjectGeometry(footprint_polygon(true.shape, true.size, x, y, yaw),
                              np.array([x, y]), widths)

    def object_geometry(self, obj: PlanObject) -> ObjectGeometry:
        return self._geometry_at(self.true_object(obj), *self.true_pose(obj))

    def static_obstacles(self, state: PlanningState) -> list[ObjectGeometry]:
        seen = frozenset(self.true_object(o).name for o in state.objects)
        if seen not in self._hidden:
            self._hidden[seen] = [self._geometry_at(o, o.x, o.y, o.yaw)
                                  for o in self.scenario.objects if o.name not in seen]
        return self._hidden[seen]
