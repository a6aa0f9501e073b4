"""Planar geometry of upright objects: footprints, gripper corridors and their contacts.

Everything here is NumPy only, so the scenario generator, the oracle feasibility model and the
world model share one definition of "touching" without importing Drake.
"""

from __future__ import annotations

import numpy as np

#: vertices used to approximate a circular footprint (inscribed error < 0.9% of the radius)
CIRCLE_VERTICES = 24


def rotation2d(angle: float) -> np.ndarray:
    """2x2 rotation matrix for `angle` radians."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def footprint_polygon(shape: str, size: list[float] | tuple[float, ...], x: float, y: float,
                      yaw: float) -> np.ndarray:
    """Counter-clockwise convex polygon (K, 2) of an upright object's footprint in the shelf frame.

    Args:
        shape: "cylinder" (size = [radius, height]) or "box" (size = [size_x, size_y, height]).
        size: dimensions in metres.
        x, y, yaw: planar pose of the object centre in the shelf frame.
    """
    if shape == "cylinder":
        radius = size[0]
        # circumscribed polygon so the approximation never under-reports contact
        angles = np.arange(CIRCLE_VERTICES) * 2 * np.pi / CIRCLE_VERTICES
        r = radius / np.cos(np.pi / CIRCLE_VERTICES)
        local = np.stack([r * np.cos(angles), r * np.sin(angles)], axis=1)
    elif shape == "box":
        hx, hy = size[0] / 2, size[1] / 2
        local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
    else:
        raise ValueError(f"unknown shape {shape!r}")
    return local @ rotation2d(yaw).T + np.array([x, y])


def width_across(shape: str, size: list[float] | tuple[float, ...], yaw: float,
                 theta: float) -> float:
    """Extent of the footprint perpendicular to the approach direction theta (what the fingers span)."""
    if shape == "cylinder":
        return 2.0 * size[0]
    phi = yaw - theta
    return abs(size[0] * np.sin(phi)) + abs(size[1] * np.cos(phi))


def extent_along(shape: str, size: list[float] | tuple[float, ...], yaw: float,
                 theta: float) -> float:
    """Extent of the footprint along the approach direction theta."""
    if shape == "cylinder":
        return 2.0 * size[0]
    phi = yaw - theta
    return abs(size[0] * np.cos(phi)) + abs(size[1] * np.sin(phi))


def _edge_normals(poly: np.ndarray) -> np.ndarray:
    """(K, 2) unit outward normals of a counter-clockwise polygon's edges (edge k runs from vertex
    k to k + 1). Written out instead of `np.roll`, `np.stack` and `np.linalg.norm` (the same
    arithmetic, a third of the time: the scene generator's solvability check makes ~10^5 calls)."""
    edges = np.concatenate([poly[1:], poly[:1]]) - poly
    normals = np.empty_like(edges)
    normals[:, 0] = edges[:, 1]
    normals[:, 1] = -edges[:, 0]
    length = np.sqrt(normals[:, 0] * normals[:, 0] + normals[:, 1] * normals[:, 1])
    return normals / length[:, None]


def convex_polygons_overlap(a: np.ndarray, b: np.ndarray, margin: float = 0.0) -> bool:
    """True when convex polygons a and b overlap or come closer than `margin` (separating axes)."""
    for normals in (_edge_normals(a), _edge_normals(b)):
        pa = a @ normals.T
        pb = b @ normals.T
        separated = (pa.min(axis=0) > pb.max(axis=0) + margin) | (
            pb.min(axis=0) > pa.max(axis=0) + margin)
        if np.any(separated):
            return False
    if margin <= 0.0:
        return True
    # SAT with a margin is conservative at corners: confirm with the true distance
    return convex_polygon_distance(a, b) < margin


def _point_segment_distance(points: np.ndarray, seg_a: np.ndarray, seg_b: np.ndarray) -> np.ndarray:
    """Distances (P, S) from each point to each segment."""
    d = seg_b - seg_a  # (S, 2)
    rel = points[:, None, :] - seg_a[None, :, :]  # (P, S, 2)
    t = np.clip(np.sum(rel * d[None], axis=2) / np.maximum(np.sum(d * d, axis=1), 1e-18), 0, 1)
    closest = seg_a[None] + t[..., None] * d[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=2)


def convex_polygon_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Euclidean distance between convex polygons (0 when they overlap)."""
    if convex_polygons_overlap(a, b):
        return 0.0
    da = _point_segment_distance(a, b, np.roll(b, -1, axis=0)).min()
    db = _point_segment_distance(b, a, np.roll(a, -1, axis=0)).min()
    return float(min(da, db))


def convex_polygon_penetration(a: np.ndarray, b: np.ndarray, signed: bool = False) -> float:
    """Penetration depth of convex polygons a and b (counter-clockwise, maybe padded as by
    `pad_polygons`): the shortest translation that separates them, the least overlap of their
    projections over every edge normal of either (separating-axis theorem). 0 when they touch or
    are apart; with `signed`, minus the widest projected gap when apart."""
    normals = np.concatenate([edge_normals(np.asarray(a)), edge_normals(np.asarray(b))])
    normals = normals[np.any(normals != 0.0, axis=1)]
    if not len(normals):  # degenerate: no edge to separate along
        return np.inf
    pa, pb = a @ normals.T, b @ normals.T
    depth = float(np.min(np.minimum(pa.max(axis=0) - pb.min(axis=0),
                                    pb.max(axis=0) - pa.min(axis=0))))
    return depth if signed else max(depth, 0.0)


def _disc_polygon_penetration(centre: np.ndarray, radius: float, poly: np.ndarray) -> float:
    """Penetration depth of a disc and a convex polygon: the radius less the centre's signed
    distance to the polygon (negative inside)."""
    edges = np.roll(poly, -1, axis=0)
    boundary = float(_point_segment_distance(centre[None], poly, edges).min())
    inside = bool(points_in_polygon(centre[None], poly)[0])
    return max(radius + boundary if inside else radius - boundary, 0.0)


def footprint_penetration(a: tuple, b: tuple) -> float:
    """Penetration depth (m) of two upright objects' true footprints, each given as
    (shape, size, x, y, yaw) as for `footprint_polygon`: exact for circles (not their
    circumscribed polygons, which overlap by up to 0.9% of the radii when the discs touch), the
    separating-axis depth for two boxes; 0 when they touch or are apart."""
    (shape_a, size_a, xa, ya, yaw_a), (shape_b, size_b, xb, yb, yaw_b) = a, b
    if shape_a == "cylinder" and shape_b == "cylinder":
        return max(size_a[0] + size_b[0] - float(np.hypot(xa - xb, ya - yb)), 0.0)
    if shape_a == "cylinder":
        a, b = b, a
        (shape_a, size_a, xa, ya, yaw_a), (shape_b, size_b, xb, yb, yaw_b) = a, b
    poly_a = footprint_polygon(shape_a, size_a, xa, ya, yaw_a)
    if shape_b == "cylinder":
        return _disc_polygon_penetration(np.array([xb, yb], dtype=float), size_b[0], poly_a)
    return convex_polygon_penetration(poly_a, footprint_polygon(shape_b, size_b, xb, yb, yaw_b))


def corridor_polygon(x: float, y: float, theta: float, half_width: float, start_behind: float,
                     length: float) -> np.ndarray:
    """Rectangle swept by the gripper approaching the point (x, y) along (cos theta, sin theta).

    The rectangle spans from `start_behind` beyond the point (fingertips reach past the object's
    centre) back to `length` before it (outside the shelf), with `half_width` on each side.
    """
    u = np.array([np.cos(theta), np.sin(theta)])
    v = np.array([-u[1], u[0]])
    c = np.array([x, y])
    front = c + start_behind * u
    back = c - length * u
    return np.array([front - half_width * v, front + half_width * v,
                     back + half_width * v, back - half_width * v])


def points_in_polygon(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Boolean mask of points (P, 2) inside the counter-clockwise convex polygon."""
    edges = np.roll(poly, -1, axis=0) - poly
    rel = points[:, None, :] - poly[None, :, :]
    cross = edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0]
    return np.all(cross >= 0, axis=1)


def approach_corridor(x: float, y: float, theta: float, half_width: float, finger_reach: float,
                      outside: float = 0.30) -> np.ndarray:
    """Corridor swept by the open gripper reaching the grasp point (x, y) from outside the shelf.

    It runs from `finger_reach` past the point back along the approach line until it is `outside`
    metres in front of the shelf's front edge (x = 0).
    """
    length = (x + outside) / max(np.cos(theta), 1e-6)
    return corridor_polygon(x, y, theta, half_width, finger_reach, length)


def approach_corridors(points: np.ndarray, thetas: np.ndarray, half_width: float,
                       finger_reach: float, outside: float = 0.30) -> np.ndarray:
    """(P, 4, 2) `approach_corridor` to each of `points` (P, 2) along `thetas` (P,), batched."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    thetas = np.asarray(thetas, dtype=float).reshape(-1)
    u = np.stack([np.cos(thetas), np.sin(thetas)], axis=1)
    v = np.stack([-u[:, 1], u[:, 0]], axis=1)
    length = (points[:, 0] + outside) / np.maximum(np.cos(thetas), 1e-6)
    front = points + finger_reach * u
    back = points - length[:, None] * u
    hv = half_width * v
    return np.stack([front - hv, front + hv, back + hv, back - hv], axis=1)


def side_wall_polygons(depth: float, width: float, thickness: float) -> list[np.ndarray]:
    """Footprints of the two side walls (an approach that crosses one is blocked by the shelf)."""
    walls = []
    for side in (1.0, -1.0):
        yc = side * (width / 2 + thickness / 2)
        walls.append(footprint_polygon("box", (depth + thickness, thickness), depth / 2, yc, 0.0))
    return walls


def padded_outline(outline: np.ndarray, pad: float) -> np.ndarray:
    """The vertices of `outline` grown by `pad` (m) in `CIRCLE_VERTICES` directions each: a
    polygon containing the outline's Minkowski sum with a disc of radius `pad`."""
    if pad <= 0:
        return np.asarray(outline)
    angles = np.arange(CIRCLE_VERTICES) * 2 * np.pi / CIRCLE_VERTICES
    ring = pad / np.cos(np.pi / CIRCLE_VERTICES) * np.stack([np.cos(angles), np.sin(angles)], 1)
    return (np.asarray(outline)[:, None, :] + ring[None, :, :]).reshape(-1, 2)


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull (K, 2) of planar points (Qhull; degenerate sets as they are)."""
    from scipy.spatial import ConvexHull, QhullError

    pts = np.unique(np.asarray(points, dtype=float)[:, :2], axis=0)
    if len(pts) < 3:
        return pts
    try:
        return pts[ConvexHull(pts).vertices]  # counter-clockwise in 2-D
    except QhullError:  # collinear: the two extreme points
        d = pts - pts.mean(axis=0)
        axis = np.linalg.svd(d, full_matrices=False)[2][0]
        proj = d @ axis
        return pts[[int(np.argmin(proj)), int(np.argmax(proj))]]


def pad_polygons(polygons: list[np.ndarray]) -> np.ndarray:
    """Stack polygons into (N, K, 2), repeating each one's last vertex (a zero-length edge)."""
    k = max(len(p) for p in polygons)
    out = np.empty((len(polygons), k, 2))
    for i, p in enumerate(polygons):
        out[i, :len(p)] = p
        out[i, len(p):] = p[-1]
    return out


def edge_normals(polys: np.ndarray) -> np.ndarray:
    """(..., K, 2) unit outward normals of the edges of counter-clockwise polygons (..., K, 2);
    zero for the zero-length edges that `pad_polygons` adds."""
    edges = np.roll(polys, -1, axis=-2) - polys
    normals = np.stack([edges[..., 1], -edges[..., 0]], axis=-1)
    length = np.linalg.norm(normals, axis=-1, keepdims=True)
    return np.where(length > 1e-12, normals / np.maximum(length, 1e-12), 0.0)


def pad_edge_normals(normals: list[np.ndarray], k: int) -> np.ndarray:
    """(N, k, 2) what `edge_normals(pad_polygons(polygons))` gives, from each polygon's own
    `edge_normals` (bit for bit: the same edges; the padding's zero-length edges get zero normals
    and the closing edge comes last), for callers that keep each polygon's normals."""
    out = np.zeros((len(normals), k, 2))
    for i, n in enumerate(normals):
        out[i, :len(n) - 1] = n[:-1]
        out[i, k - 1] = n[-1]
    return out


def convex_polygons_overlap_pairs(a: np.ndarray, b: np.ndarray, margin: float = 0.0,
                                  normals_a: np.ndarray | None = None,
                                  normals_b: np.ndarray | None = None) -> np.ndarray:
    """Batched separating-axis test: (P,) True where polygon a[p] meets b[p] (or is within margin).

    a: (P, Ka, 2), b: (P, Kb, 2), both counter-clockwise convex and padded as by `pad_polygons`.
    With margin 0 this is exactly `convex_polygons_overlap`; with a margin it is conservative at
    corners (it may report contact for polygons slightly farther apart than `margin`).
    `normals_a` / `normals_b`: their `edge_normals` when the caller keeps them (the same answer).
    """
    separated = np.zeros(a.shape[0], dtype=bool)
    for normals in (edge_normals(a) if normals_a is None else normals_a,
                    edge_normals(b) if normals_b is None else normals_b):  # (P, K, 2)
        axes = normals.transpose(0, 2, 1)
        pa = a @ axes  # (P, Va, K)
        pb = b @ axes
        gap = np.maximum(pa.min(axis=1) - pb.max(axis=1), pb.min(axis=1) - pa.max(axis=1))
        useful = np.any(normals != 0.0, axis=-1)
        separated |= np.any((gap > margin) & useful, axis=1)
    return ~separated
