"""Batched FeasibilityModel implementations: `oracle` (true shapes) and `geometric` (point clouds).

Both reduce every object to a convex footprint polygon with a grasp centre and a width across the
gripper per approach angle, then answer all questions with vectorised corridor tests:

- oracle: the true footprint of the scenario object each PlanObject stands for, at the pose the
  simulation has moved it to (true centre on the placement cell, yaw turned with the gripper);
- geometric: the hull of the object's perceived points completed by point reflection through its
  estimated centre (cylinders and boxes are centrally symmetric), nothing else.

The gripper corridor is `geometry2d.approach_corridors`; the side walls block it too. An object can be
picked at theta when its corridor is clear and its width across fits the stroke minus the margin.
Answers are cached per state (states are immutable; the key is the tuple of object poses).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from tsad_drake.geometry2d import (
    approach_corridors,
    convex_polygons_overlap_pairs,
    edge_normals,
    footprint_polygon,
    pad_edge_normals,
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
    #: identity of the geometry for the model's pair caches (equal keys, equal geometry): a
    #: small int the model hands out per distinct (name, pose, origin, points), cheap to hash
    key: int = -1
    #: identity of the footprint's shape in its own frame (equal keys: the same polygon about
    #: the centre, wherever the object stands)
    shape_key: int = -1
    corridors: np.ndarray | None = None  #: (A, 4, 2) approach corridors to `centre`
    wall_clear: np.ndarray | None = None  #: (A,) those corridors miss both side walls
    corridor_normals: np.ndarray | None = None  #: (A, 4, 2) the corridors' edge normals
    normals: np.ndarray | None = None  #: (K, 2) `edge_normals` of `polygon` (filled in)

    def __post_init__(self) -> None:
        self.normals = edge_normals(self.polygon)
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
    return approach_corridors(centres, thetas, workspace.swept_half_width,
                              workspace.finger_reach, CORRIDOR_OUTSIDE)


def corridor_pair_hits(centres: np.ndarray, thetas: np.ndarray, corridors: np.ndarray,
                       objects: list[ObjectGeometry], workspace: Workspace,
                       corridor_normals: np.ndarray | None = None) -> np.ndarray:
    """(Q,) True where corridor q (to centres[q] along thetas[q]) touches footprint objects[q].

    Exact (the separating-axis test of `geometry2d`) but only run where the bounding discs of the
    footprints leave the answer open. `corridor_normals`: the corridors' `edge_normals`, when the
    caller keeps them.
    """
    hits = np.zeros(len(centres), dtype=bool)
    if len(centres) == 0:
        return hits
    obj_centres = np.array([o.centre for o in objects])
    outer = np.array([o.outer for o in objects])
    inner = np.array([o.inner for o in objects])
    u = np.stack([np.cos(thetas), np.sin(thetas)], axis=1)
    v = np.stack([-u[:, 1], u[:, 0]], axis=1)
    back = (centres[:, 0] + CORRIDOR_OUTSIDE) / np.maximum(np.cos(thetas), 1e-6)
    rel = obj_centres - centres
    along = np.einsum("qd,qd->q", rel, u)
    across = np.abs(np.einsum("qd,qd->q", rel, v))
    d_along = np.maximum(0.0, np.maximum(along - workspace.finger_reach, -back - along))
    d_across = np.maximum(0.0, across - workspace.swept_half_width)
    dist = np.hypot(d_along, d_across)
    sure_hit = dist < inner - 1e-9
    open_ = np.nonzero((dist <= outer + 1e-9) & ~sure_hit)[0]
    hits |= sure_hit
    if len(open_):
        polys = pad_polygons([objects[q].polygon for q in open_])
        normals = pad_edge_normals([objects[q].normals for q in open_], polys.shape[1])
        hits[open_] = convex_polygons_overlap_pairs(
            corridors[open_], polys, 0.0,
            None if corridor_normals is None else corridor_normals[open_], normals)
    return hits


class StateGeometry:
    """Per-state corridor answers of a footprint model, assembled from its per-object caches."""

    def __init__(self, objects: list[ObjectGeometry], num_plan_objects: int,
                 model: FootprintFeasibility) -> None:
        self.objects = objects  #: plan objects first, then static obstacles (oracle: unseen)
        self.num_plan_objects = num_plan_objects
        self.model = model
        self._object_hits: np.ndarray | None = None
        self._cell_hits: np.ndarray | None = None
        self._cell_hit_counts: np.ndarray | None = None
        self._blockers: dict[int, list[frozenset[int]]] = {}
        self._near: np.ndarray | None = None
        self._surely: dict[int, np.ndarray] = {}
        self._keys: list[int] = [o.key for o in objects]
        self._others_keys: dict[int, frozenset[int]] = {}

    def blockers(self, index: int) -> list[frozenset[int]]:
        """Per approach angle, the plan objects the corridor to plan object `index` touches."""
        found = self._blockers.get(index)
        if found is None:
            hits = self.object_hits[index, :, :self.num_plan_objects]
            found = self._blockers[index] = [frozenset(np.nonzero(row)[0].tolist())
                                             for row in hits]
        return found

    def others_keys(self, index: int) -> frozenset[int]:
        """The geometry keys of every object but `index` (plan objects and obstacles)."""
        keys = self._others_keys.get(index)
        if keys is None:
            keys = self._others_keys[index] = frozenset(self._keys[:index] + self._keys[index + 1:])
        return keys

    def clear_cells(self, index: int) -> np.ndarray:
        """(C, A) the corridor to cell c at angle a misses the walls and every object but `index`."""
        if self._cell_hit_counts is None:
            self._cell_hit_counts = self.cell_hits.sum(axis=2)
        own = self.cell_hits[:, :, index]
        return self.model.cell_corridors.wall_clear & (self._cell_hit_counts == own)

    def surely_blocked_cells(self, index: int, inner: float, gap: float) -> np.ndarray:
        """(C,) a cell whose centre is closer to some other object's centre than `inner` plus
        that object's inner radius plus `gap`: a footprint of inner radius `inner` on it meets
        that object for sure (cached per index: `inner` is that object's, `gap` the model's)."""
        found = self._surely.get(index)
        if found is not None:
            return found
        if self._near is None:  # (C, J) distance of each cell centre to each object's centre
            centres = np.array([o.centre for o in self.objects])
            self._near = np.linalg.norm(self.model.workspace.cell_centres[:, None, :]
                                        - centres[None, :, :], axis=2)
        others = [j for j in range(len(self.objects)) if j != index]
        other_inner = np.array([self.objects[j].inner for j in others])
        found = self._surely[index] = np.any(
            self._near[:, others] < inner + other_inner[None, :] + gap, axis=1)
        return found

    @property
    def object_hits(self) -> np.ndarray:
        """(N, A, J) corridor to plan object i at angle a touches object j (j == i excluded)."""
        if self._object_hits is None:
            self._object_hits = self.model.object_pair_hits(self.objects[:self.num_plan_objects],
                                                            self.objects)
        return self._object_hits

    @property
    def cell_hits(self) -> np.ndarray:
        """(C, A, J) corridor to grid cell c at angle a touches object j."""
        if self._cell_hits is None:
            self._cell_hits = np.stack([self.model.cell_column(o) for o in self.objects], axis=2)
        return self._cell_hits


@dc.dataclass
class CellCorridors:
    """Corridors to every grid cell at every approach angle (fixed per workspace)."""

    centres: np.ndarray  #: (C*A, 2)
    thetas: np.ndarray  #: (C*A,)
    polygons: np.ndarray  #: (C*A, 4, 2)
    wall_clear: np.ndarray  #: (C, A) the corridor misses both side walls
    normals: np.ndarray  #: (C*A, 4, 2) the corridors' edge normals


class FootprintFeasibility(FeasibilityModel):
    """Shared machinery: subclasses say how a PlanObject becomes an ObjectGeometry.

    Every corridor and placement test is between two footprints (or a footprint and the fixed
    cell corridors), so answers are cached per pair of object geometries (by `ObjectGeometry.key`)
    and a state's answers are assembled from them: a search moves one object per action, so a
    new state costs the tests of the moved object only, and every state sharing a pair shares
    its answer (across the tree, the sub-searches and the rounds on one observation).
    """

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
        self._objects: dict[tuple, ObjectGeometry] = {}
        #: (corridor owner key, obstacle key) -> (A,) the corridor to the owner hits the obstacle
        self._pairs: dict[tuple[int, int], np.ndarray] = {}
        self._cell_columns: dict[int, np.ndarray] = {}  #: obstacle key -> (C, A) cell hits
        #: (mover shape key, rotation, obstacle key) -> (C,) the turned mover at each cell meets it
        self._placements: dict[tuple, np.ndarray] = {}
        #: (shape key, rotation) -> (C, K, 2) the turned shape on every cell, (C,) on the floor,
        #: (C, K, 2) its edge normals on every cell
        self._turned_shapes: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        #: (mover shape key, theta_pick, the other geometries' keys) -> `place_options`' answer:
        #: it depends on nothing else (not on where the mover stands), so the states of a tree
        #: that differ only in the mover's place (siblings moving one object, a rollout moving it
        #: twice) share it; 40% of the calls on scenario 1 (ideal sensing, seeds 1000-1005)
        self._place_answers: dict[tuple, np.ndarray] = {}
        #: (mover shape key, rotation, the other geometries' keys) -> `_placement_hits`' answer
        self._placement_unions: dict[tuple, np.ndarray] = {}
        self._orders: dict[float, np.ndarray] = {}  #: theta_pick -> `approach_order`
        #: identity tuple -> the int `ObjectGeometry.key` / `shape_key` it was given (a new
        #: number for every new identity, also after the caches are cleared)
        self._ids: dict[tuple, int] = {}
        self._next_id = 0
        thetas = workspace.approach_angles
        cells = workspace.cell_centres
        centres = np.repeat(cells, len(thetas), axis=0)
        angles = np.tile(thetas, len(cells))
        polys = corridor_polygons(centres, angles, workspace)
        self.cell_corridors = CellCorridors(
            centres, angles, polys, self._walls_clear(polys).reshape(len(cells), len(thetas)),
            edge_normals(polys))

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

    def _approach_order(self, prefer: float) -> np.ndarray:
        """`approach_order` of the workspace's angles, memoised per preferred angle."""
        order = self._orders.get(prefer)
        if order is None:
            order = self._orders[prefer] = approach_order(self.workspace.approach_angles, prefer)
        return order

    def _id(self, identity: tuple) -> int:
        number = self._ids.get(identity)
        if number is None:
            number = self._ids[identity] = self._next_id
            self._next_id += 1
        return number

    def prepared(self, geom: ObjectGeometry, key: tuple, shape_key: tuple) -> ObjectGeometry:
        """`geom` with its cache keys, its approach corridors and their wall test filled in."""
        thetas = self.workspace.approach_angles
        geom.key, geom.shape_key = self._id(key), self._id(("shape",) + shape_key)
        geom.corridors = corridor_polygons(np.repeat(geom.centre[None], len(thetas), axis=0),
                                           thetas, self.workspace)
        geom.wall_clear = self._walls_clear(geom.corridors)
        geom.corridor_normals = edge_normals(geom.corridors)
        return geom

    def _object_entry(self, obj: PlanObject) -> ObjectGeometry:
        key = (obj.name, obj.pose, obj.origin, len(obj.points))
        geom = self._objects.get(key)
        if geom is None:
            # the perceived points move rigidly with the object: its origin and how far it has
            # turned since fix the shape about its centre
            origin = obj.origin if obj.origin is not None else obj.pose
            shape = (obj.name, origin, len(obj.points), round(obj.yaw - origin[2], 12))
            geom = self._objects[key] = self.prepared(self.object_geometry(obj), key, shape)
        return geom

    def _clear_caches(self) -> None:
        for cache in (self._states, self._objects, self._pairs, self._cell_columns,
                      self._placements, self._turned_shapes, self._place_answers, self._ids,
                      self._placement_unions):
            cache.clear()

    def geometry(self, state: PlanningState) -> StateGeometry:
        """The cached StateGeometry of `state`."""
        key = state.key()
        geom = self._states.get(key)
        if geom is None:
            if max(len(self._states), len(self._placements), len(self._place_answers),
                   len(self._placement_unions)) > CACHE_LIMIT:
                self._clear_caches()
            objects = [self._object_entry(o) for o in state.objects]
            geom = StateGeometry(objects + self.static_obstacles(state), len(objects), self)
            self._states[key] = geom
        return geom

    def object_pair_hits(self, owners: list[ObjectGeometry],
                         obstacles: list[ObjectGeometry]) -> np.ndarray:
        """(N, A, J) the corridor to owners[i] at angle a touches obstacles[j] (False for i == j),
        from the pair cache; the missing pairs are tested in one batch."""
        num_angles = len(self.workspace.approach_angles)
        none = np.zeros(num_angles, dtype=bool)
        keys = [o.key for o in obstacles]
        get = self._pairs.get
        rows, missing = [], []  # rows in (i, j) order, stacked once (not set one by one)
        for i, owner in enumerate(owners):
            own = owner.key
            for j, key in enumerate(keys):
                row = none if i == j else get((own, key))
                if row is None:
                    missing.append((i, j))
                    row = none
                rows.append(row)
        hits = np.ascontiguousarray(np.array(rows, dtype=bool).reshape(
            len(owners), len(obstacles), num_angles).transpose(0, 2, 1))
        if missing:
            thetas = self.workspace.approach_angles
            pair_owners = [owners[i] for i, _ in missing]
            centres = np.repeat(np.array([o.centre for o in pair_owners]), num_angles, axis=0)
            corridors = np.concatenate([o.corridors for o in pair_owners])
            normals = np.concatenate([o.corridor_normals for o in pair_owners])
            found = corridor_pair_hits(centres, np.tile(thetas, len(missing)), corridors,
                                       [obstacles[j] for _, j in missing for _ in thetas],
                                       self.workspace, normals).reshape(len(missing), num_angles)
            for (i, j), row in zip(missing, found, strict=True):
                self._pairs[(owners[i].key, obstacles[j].key)] = row
                hits[i, :, j] = row
        return hits

    def cell_column(self, obstacle: ObjectGeometry) -> np.ndarray:
        """(C, A) the corridor to grid cell c at angle a touches `obstacle` (cached)."""
        column = self._cell_columns.get(obstacle.key)
        if column is None:
            ws, cache = self.workspace, self.cell_corridors
            column = corridor_pair_hits(cache.centres, cache.thetas, cache.polygons,
                                        [obstacle] * len(cache.centres), ws, cache.normals)
            column = self._cell_columns[obstacle.key] = column.reshape(
                len(ws.cell_centres), len(ws.approach_angles))
        return column

    # -- FeasibilityModel ----------------------------------------------------------------------
    def blockers(self, state: PlanningState, index: int) -> list[frozenset[int]]:
        """Per approach angle, the plan objects the corridor to object `index` touches."""
        return self.geometry(state).blockers(index)

    def blockers_at(self, state: PlanningState, index: int, k: int) -> frozenset[int]:
        return self.geometry(state).blockers(index)[k]

    def reachable(self, state: PlanningState, index: int) -> np.ndarray:
        """(A,) the object fits the stroke and its corridor misses the walls (ignoring objects)."""
        geom = self._object_entry(state.objects[index])
        ws = self.workspace
        return geom.wall_clear & (geom.widths <= ws.stroke - ws.grasp_margin - self.fit_margin
                                  + 1e-9)

    def unreachable_detail(self, state: PlanningState, index: int) -> str:
        """The footprint's narrowest width across the approach against the stroke's limit, or the
        side walls when it fits at some angle but every such corridor meets a wall."""
        geom = self._object_entry(state.objects[index])
        ws = self.workspace
        limit = ws.stroke - ws.grasp_margin - self.fit_margin
        fits = geom.widths <= limit + 1e-9
        if not fits.any():
            k = int(np.argmin(geom.widths))
            return (f"narrowest across the gripper {geom.widths[k] * 1000:.0f} mm, at "
                    f"{np.degrees(ws.approach_angles[k]):+.0f} deg; the stroke takes "
                    f"{limit * 1000:.0f} mm")
        if not (fits & geom.wall_clear).any():
            return "every approach it fits the gripper at meets a shelf side wall"
        return ""

    def pickable(self, state: PlanningState, index: int) -> np.ndarray:
        """(A,) object `index` can be picked at each angle: reachable with a clear corridor."""
        g = self.geometry(state)
        return self.reachable(state, index) & ~g.object_hits[index].any(axis=1)

    # -- placements ----------------------------------------------------------------------------
    def _turned(self, me: ObjectGeometry,
                rotation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(C, K, 2) `me` turned by `rotation` about its centre and put on every grid cell, (C,)
        whether each lies inside the workspace (`edge_margin` inside its edges) and (C, K, 2) the
        polygons' edge normals; cached per shape (`ObjectGeometry.shape_key`: where the object
        stands does not matter)."""
        key = (me.shape_key, rotation)
        entry = self._turned_shapes.get(key)
        if entry is None:
            rotated = (me.polygon - me.centre) @ rotation2d(rotation).T
            polys = rotated[None, :, :] + self.workspace.cell_centres[:, None, :]
            entry = (polys, inside_workspace(polys, self.workspace, self.edge_margin),
                     edge_normals(polys))
            self._turned_shapes[key] = entry
        return entry

    def _placement_hits(self, me: ObjectGeometry, rotation: float, others: list[ObjectGeometry],
                        others_key: frozenset[int]) -> np.ndarray:
        """(C,) `me` turned by `rotation` on a cell (inside the workspace) comes within
        `placement_gap` of one of `others` (whose keys are `others_key`); cached per (shape,
        rotation, others) and per (shape, rotation, other), the missing pairs tested in one
        batch."""
        union_key = (me.shape_key, rotation, others_key)
        hits = self._placement_unions.get(union_key)
        if hits is None:
            hits = self._placement_unions[union_key] = self._placement_union(me, rotation, others)
        return hits

    def _placement_union(self, me: ObjectGeometry, rotation: float,
                         others: list[ObjectGeometry]) -> np.ndarray:
        polys, inside, poly_normals = self._turned(me, rotation)
        cells, gap = self.workspace.cell_centres, self.placement_gap
        hits = np.zeros(len(cells), dtype=bool)
        missing = []
        for other in others:
            known = self._placements.get((me.shape_key, rotation, other.key))
            if known is None:
                missing.append(other)
            else:
                hits |= known
        if missing:
            centres = np.array([o.centre for o in missing])
            outer = np.array([o.outer for o in missing])
            dist = np.linalg.norm(cells[None, :, :] - centres[:, None, :], axis=2)  # (M, C)
            near = (dist <= me.outer + outer[:, None] + gap + 1e-9) & inside[None, :]
            found = np.zeros(near.shape, dtype=bool)
            mi, ci = np.nonzero(near)
            if len(mi):
                padded = pad_polygons([o.polygon for o in missing])
                normals = pad_edge_normals([o.normals for o in missing], padded.shape[1])
                found[mi, ci] = convex_polygons_overlap_pairs(
                    polys[ci], padded[mi], gap, poly_normals[ci], normals[mi])
            for other, row in zip(missing, found, strict=True):
                self._placements[(me.shape_key, rotation, other.key)] = row
            hits |= found.any(axis=0)
        return hits

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
        me = g.objects[index]
        others_key = g.others_keys(index)
        memo_key = (me.shape_key, round(float(theta_pick), 9), others_key)
        known = self._place_answers.get(memo_key)
        if known is not None:
            return known
        others = [o for j, o in enumerate(g.objects) if j != index]
        ws, gap = self.workspace, self.placement_gap
        thetas, cells = ws.approach_angles, ws.cell_centres
        clear = g.clear_cells(index)
        result = np.full(len(cells), np.nan)
        unresolved = np.ones(len(cells), dtype=bool)
        if others:
            unresolved &= ~g.surely_blocked_cells(index, me.inner, gap)
        for k in self._approach_order(theta_pick):
            cand = unresolved & clear[:, k]
            if not cand.any():
                continue
            rotation = round(float(thetas[k] - theta_pick), 9)
            ok = cand & self._turned(me, rotation)[1]
            if ok.any() and others:
                ok &= ~self._placement_hits(me, rotation, others, others_key)
            result[ok] = thetas[k]
            unresolved[ok] = False
            if not unresolved.any():
                break
        self._place_answers[memo_key] = result
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
            self._hidden[seen] = [self.prepared(self._geometry_at(o, o.x, o.y, o.yaw),
                                                ("unseen", o.name), ("unseen", o.name))
                                  for o in self.scenario.objects if o.name not in seen]
        return self._hidden[seen]
