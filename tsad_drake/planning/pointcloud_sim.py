"""Point-cloud simulation of a pick-and-place (the paper's Fig. 3) and placement validity.

A pick-and-place {n, theta_pick, x, y, theta_place} moves object n's points rigidly: its estimated
centre goes to the cell centre (x, y) and the points turn by theta_place - theta_pick about it (the
object turns with the gripper). Exactly n's points move; every other object is left untouched.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from tsad_drake.geometry2d import (
    CIRCLE_VERTICES,
    convex_hull,
    convex_polygons_overlap_pairs,
    pad_polygons,
    rotation2d,
)
from tsad_drake.planning.state import completed_footprint_points
from tsad_drake.planning.types import Action, PlanningState, PlanObject, Workspace

#: m, default gap a placed object must keep from every other object's footprint
DEFAULT_PLACEMENT_GAP = 0.005
#: m, the gap the perceived models keep instead: true footprints reach at most 1.9 mm past the
#: perceived hulls on 9 objects in 10 (`bench/hull_errors.py`), so 5 mm wastes the scarce free
#: space the scenes turn on (TSAD on scenario 2: 0.83 success with 5 mm, 0.97 with 3 mm and
#: `PERCEIVED_EDGE_MARGIN`)
PERCEIVED_PLACEMENT_GAP = 0.003
#: m, how far inside the shelf floor's edges a perceived footprint must be placed: a long
#: rectangle's perceived hull can be a millimetre shorter than the box (its back is never seen)
PERCEIVED_EDGE_MARGIN = 0.001
#: m, how much narrower than the stroke minus the grasp margin a perceived footprint must be to
#: count as graspable: the perceived width across the gripper falls short of the true one by up
#: to 2.1 mm where it matters (5 of 6,258 object-angle pairs, s1-3 seeds 0-29, said to fit and did
#: not: the world model tips such an object over); 1 mm leaves none of them and refuses 16 of
#: 5,676 true fits
PERCEIVED_FIT_MARGIN = 0.001
#: support directions a perceived footprint hull is reduced to (a dense circle has a vertex per
#: point); the circle polygon's vertex count, so a fitted cylinder's polygon keeps every vertex
HULL_DIRECTIONS = CIRCLE_VERTICES


def move_object(obj: PlanObject, x: float, y: float, rotation: float) -> PlanObject:
    """`obj` with its points moved so its centre lands on (x, y), turned by `rotation` rad."""
    centre = np.array([obj.x, obj.y])
    points = np.array(obj.points, dtype=float, copy=True)
    points[:, :2] = (points[:, :2] - centre) @ rotation2d(rotation).T + np.array([x, y])
    points.setflags(write=False)
    outline = obj.outline
    if outline is not None:
        outline = (outline - centre) @ rotation2d(rotation).T + np.array([x, y])
        outline.setflags(write=False)
    origin = obj.origin if obj.origin is not None else obj.pose
    return dc.replace(obj, points=points, x=float(x), y=float(y),
                      yaw=float(obj.yaw + rotation), origin=origin, outline=outline)


#: (object key, x, y, rotation) -> the moved object: a search moves the same object to the same
#: cell from many states, and objects are immutable
_MOVED: dict[tuple, PlanObject] = {}
#: moved objects kept before the memo is cleared
MOVED_LIMIT = 100_000


def simulate_pick_place(state: PlanningState, action: Action) -> PlanningState:
    """The next state s' after `action` in the point-cloud simulation (a new, immutable state)."""
    index = state.index(action.object)
    obj = state.objects[index]
    rotation = action.theta_place - action.theta_pick
    key = (obj.name, obj.pose, obj.origin, len(obj.points), action.x, action.y, rotation)
    moved = _MOVED.get(key)
    if moved is None:
        if len(_MOVED) > MOVED_LIMIT:
            _MOVED.clear()
        moved = _MOVED[key] = move_object(obj, action.x, action.y, rotation)
    objects = state.objects[:index] + (moved,) + state.objects[index + 1:]
    return PlanningState(objects, state.target)


def footprint_hull(obj: PlanObject, directions: int = HULL_DIRECTIONS) -> np.ndarray:
    """Counter-clockwise convex footprint of `obj`: the hull of its completed points.

    The hull is reduced to its support points in `directions` evenly spread directions (at most
    that many vertices, still counter-clockwise; a 35 mm circle loses < 0.3 mm).
    """
    hull = convex_hull(completed_footprint_points(obj))
    if len(hull) <= directions:
        return hull
    angles = np.arange(directions) * 2 * np.pi / directions
    support = np.argmax(hull @ np.stack([np.cos(angles), np.sin(angles)]), axis=0)
    keep = np.unique(support)  # hull order is counter-clockwise, so sorted indices keep it
    return hull[keep]


_LOCAL_HULLS: dict[tuple, np.ndarray] = {}


def perceived_hull(obj: PlanObject) -> np.ndarray:
    """`footprint_hull` of `obj` at its current pose, computed once per perceived object and
    moved rigidly with it afterwards (a moved object keeps the points it was perceived with)."""
    origin = obj.origin if obj.origin is not None else obj.pose
    key = (obj.name, origin, len(obj.points))
    turned = obj.yaw - origin[2]
    local = _LOCAL_HULLS.get(key)
    if local is None:  # in the frame of the perceived object
        if len(_LOCAL_HULLS) > 20_000:
            _LOCAL_HULLS.clear()
        local = (footprint_hull(obj) - np.array([obj.x, obj.y])) @ rotation2d(turned)
        _LOCAL_HULLS[key] = local
    return local @ rotation2d(turned).T + np.array([obj.x, obj.y])


def moved_polygon(polygon: np.ndarray, centre: tuple[float, float], x: float, y: float,
                  rotation: float) -> np.ndarray:
    """`polygon` moved rigidly as the simulation moves its object (centre -> (x, y), turned)."""
    return (polygon - np.asarray(centre)) @ rotation2d(rotation).T + np.array([x, y])


def inside_workspace(polygon: np.ndarray, workspace: Workspace,
                     gap: float = 0.0) -> bool | np.ndarray:
    """True when the footprint (K, 2) lies inside the shelf floor, `gap` inside its edges; for
    footprints (..., K, 2) an array of answers."""
    x, y = polygon[..., 0], polygon[..., 1]
    inside = ((x.min(axis=-1) >= gap) & (x.max(axis=-1) <= workspace.depth - gap)
              & (np.abs(y).max(axis=-1) <= workspace.width / 2 - gap))
    return inside if inside.ndim else bool(inside)


def placement_valid(state: PlanningState, index: int, x: float, y: float, rotation: float,
                    workspace: Workspace, gap: float = DEFAULT_PLACEMENT_GAP) -> bool:
    """Whether object `index` moved to (x, y) and turned by `rotation` fits in the perceived state.

    Valid when its footprint (hull of its completed points) is inside the workspace and keeps at
    least `gap` (conservatively) from every other object's footprint.
    """
    obj = state.objects[index]
    poly = moved_polygon(footprint_hull(obj), (obj.x, obj.y), x, y, rotation)
    if not inside_workspace(poly, workspace):
        return False
    others = [footprint_hull(o) for j, o in enumerate(state.objects) if j != index]
    if not others:
        return True
    hits = convex_polygons_overlap_pairs(pad_polygons([poly] * len(others)),
                                         pad_polygons(others), gap)
    return not bool(hits.any())
