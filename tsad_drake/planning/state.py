"""Symbolic planning state from perception: the workspace grid, objects as point clouds, epsilon_s.

Nothing here reads true shapes: a `Workspace` holds the shelf size, the placement grid and the
gripper numbers; a `PlanningState` holds what perception delivered.
"""

from __future__ import annotations

import numpy as np

from tsad_drake.geometry2d import footprint_polygon, padded_outline, points_in_polygon, rotation2d
from tsad_drake.perception.types import PerceivedScene
from tsad_drake.planning.types import PlanningState, PlanObject, Workspace
from tsad_drake.scenario import Scenario

#: m, d_min: a grid cell is empty when no object point lies this close to its centre (in xy);
#: about a typical object radius, so a cell counts as empty when an object could stand there
DEFAULT_MIN_EMPTY_DISTANCE = 0.030


def grid_cell_centres(depth: float, width: float, cells_x: int, cells_y: int,
                      margin: float) -> np.ndarray:
    """(Gx*Gy, 2) centres of a Gx x Gy grid over [margin, depth-margin] x [-w/2+margin, w/2-margin].

    Ordered x-major (row k*Gy + j is cell (k, j)), so the order is fixed for a seed-stable search.
    """
    xs = margin + (np.arange(cells_x) + 0.5) * (depth - 2 * margin) / cells_x
    ys = -width / 2 + margin + (np.arange(cells_y) + 0.5) * (width - 2 * margin) / cells_y
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def make_workspace(scenario: Scenario,
                   min_empty_distance: float = DEFAULT_MIN_EMPTY_DISTANCE) -> Workspace:
    """The planner's fixed facts of `scenario`'s shelf: grid cell centres, angles, gripper, d_min."""
    shelf, grid, gripper = scenario.shelf, scenario.grid, scenario.gripper
    return Workspace(
        depth=shelf.depth, width=shelf.width, wall_thickness=shelf.wall_thickness,
        approach_angles=np.sort(scenario.approach_angles),
        cell_centres=grid_cell_centres(shelf.depth, shelf.width, grid.cells_x, grid.cells_y,
                                       grid.margin),
        stroke=gripper.stroke, grasp_margin=gripper.grasp_margin,
        swept_half_width=gripper.corridor_half_width, finger_reach=gripper.corridor_reach,
        min_empty_distance=min_empty_distance)


def state_from_perception(scene: PerceivedScene) -> PlanningState:
    """PlanningState of a perceived scene; `target` is "" when the target was not seen."""
    objects = []
    for o in scene.objects:
        points = np.array(o.points, dtype=float, copy=True)
        points.setflags(write=False)
        pose = (float(o.x), float(o.y), float(o.yaw))
        outline = None
        if o.outline is not None:
            outline = np.array(o.outline, dtype=float, copy=True)
            outline.setflags(write=False)
        objects.append(PlanObject(o.name, points, *pose, origin=pose, shape=o.shape,
                                  size=tuple(float(v) for v in o.size), outline=outline,
                                  uncertainty=float(o.uncertainty)))
    return PlanningState(tuple(objects), scene.target or "")


def completed_footprint_points(obj: PlanObject) -> np.ndarray:
    """(2P (+ K), 2) xy points of `obj` plus their reflection through its estimated centre, plus,
    for an object perception fitted as a cylinder, the K vertices of its fitted circle's footprint.

    An object with a fitted `outline` (noisy sensing) is the outline padded by its uncertainty
    instead, filled with those of the points above that lie inside it (the noisiest points, which
    would grow the hull with the noise, are left out).

    Cylinders and boxes are centrally symmetric about their centre, so the reflection of the
    front-side points recovers the unseen back half of the footprint. The seen points of a
    cylinder stop short of its silhouette (grazing rays; 0.3 mm at the median, 26 mm for one seen
    by 4 points: `bench/hull_errors.py`), while the circle fit's centre and radius are within
    0.02 mm however little of the arc is seen. The circle enters as `footprint_polygon`'s
    circumscribed polygon (the true footprints' own), whose vertices lie at the hull's support
    directions (`CIRCLE_VERTICES` = `HULL_DIRECTIONS`), so the reduced hull contains the circle.
    """
    return np.concatenate([_seen_completed(obj), *_fitted_circle(obj)])


def _seen_completed(obj: PlanObject) -> np.ndarray:
    """`completed_footprint_points` without a cylinder's fitted circle."""
    xy = obj.points[:, :2]
    centre = np.array([obj.x, obj.y])
    parts = [xy, 2.0 * centre - xy]
    if obj.outline is not None:  # the seen points and their reflections fill it, for d_min
        inside = np.concatenate(parts)
        inside = inside[points_in_polygon(inside, obj.outline)]
        return np.concatenate([padded_outline(obj.outline, obj.uncertainty), inside])
    return np.concatenate(parts)


def _fitted_circle(obj: PlanObject) -> list[np.ndarray]:
    """[the fitted circle's footprint polygon] for a cylinder without an outline, else []."""
    if obj.outline is None and obj.shape == "cylinder" and obj.size:
        return [footprint_polygon("cylinder", obj.size, obj.x, obj.y, 0.0)]
    return []


#: (name, origin, number of points, shape, size, uncertainty, has an outline) -> `_seen_completed`
#: in the frame of the object as perceived (one perception of one object: its name, perceived
#: pose and point count agree, as the keys of the search's caches do)
_LOCAL_COMPLETED: dict[tuple, np.ndarray] = {}
#: perceived objects kept before the memo is cleared
LOCAL_COMPLETED_LIMIT = 20_000


def moved_completed_points(obj: PlanObject) -> np.ndarray:
    """`completed_footprint_points` of `obj`; for a moved object, its seen part worked out once
    per perceived object and moved rigidly with it (the simulation moves the points, outline and
    centre rigidly, so the reflections and the outline's inside move with them: equal up to
    rounding), the fitted circle added at the current centre (its polygon does not turn)."""
    if not obj.moved:
        return completed_footprint_points(obj)
    key = (obj.name, obj.origin, len(obj.points), obj.shape, obj.size, obj.uncertainty,
           obj.outline is None)
    turned = rotation2d(obj.yaw - obj.origin[2])
    centre = np.array([obj.x, obj.y])
    local = _LOCAL_COMPLETED.get(key)
    if local is None:
        if len(_LOCAL_COMPLETED) > LOCAL_COMPLETED_LIMIT:
            _LOCAL_COMPLETED.clear()
        local = _LOCAL_COMPLETED[key] = (_seen_completed(obj) - centre) @ turned
    return np.concatenate([local @ turned.T + centre, *_fitted_circle(obj)])


def occupied_cells(points_xy: np.ndarray, cell_centres: np.ndarray,
                   min_empty_distance: float) -> np.ndarray:
    """(C,) True for the cells with at least one of `points_xy` within d_min of their centre."""
    occupied = np.zeros(len(cell_centres), dtype=bool)
    if len(points_xy) == 0:
        return occupied
    # only cells within d_min of the points' bounding box can hold a point within d_min (the
    # test below decides those exactly; the slack keeps rounding from dropping a cell)
    gap = np.maximum(np.maximum(points_xy.min(axis=0) - cell_centres,
                                cell_centres - points_xy.max(axis=0)), 0.0)
    near = np.nonzero(np.sum(gap ** 2, axis=1) < min_empty_distance ** 2 + 1e-12)[0]
    if len(near):
        d2 = np.sum((cell_centres[near, None, :] - points_xy[None, :, :]) ** 2, axis=2)
        occupied[near] = np.any(d2 < min_empty_distance ** 2, axis=1)
    return occupied


def empty_cell_count(state: PlanningState, workspace: Workspace) -> int:
    """epsilon_s: the number of grid cells with no (completed) object point within d_min."""
    occupied = np.zeros(len(workspace.cell_centres), dtype=bool)
    for obj in state.objects:
        occupied |= occupied_cells(moved_completed_points(obj), workspace.cell_centres,
                                   workspace.min_empty_distance)
    return int(len(occupied) - occupied.sum())

def true_state(scenario: Scenario, spacing: float = 0.01) -> PlanningState:
    """The planning state of `scenario` as the true shapes give it: each object's footprint filled
    with points `spacing` apart (plus its corners) at its top height, named as in the scenario."""
    objects = []
    for o in scenario.objects:
        poly = o.footprint()
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        gx, gy = np.meshgrid(np.arange(lo[0], hi[0] + 1e-9, spacing),
                             np.arange(lo[1], hi[1] + 1e-9, spacing), indexing="ij")
        grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
        xy = np.concatenate([poly, grid[points_in_polygon(grid, poly)]])
        points = np.column_stack([xy, np.full(len(xy), o.size[-1])])
        points.setflags(write=False)
        pose = (float(o.x), float(o.y), float(o.yaw))
        objects.append(PlanObject(o.name, points, *pose, origin=pose))
    return PlanningState(tuple(objects), scenario.target)
