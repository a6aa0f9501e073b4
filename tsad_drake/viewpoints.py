"""Observation viewpoints and a NumPy ray caster for upright primitives.

The wrist camera looks into the shelf along each approach angle theta from a fixed standoff; the
viewpoint is data (a camera pose in the shelf frame S), and the station places the arm there by IK.
The ray caster renders the same pinhole camera over the scenario's cylinders, boxes and shelf
panels in milliseconds; the generator uses it to measure target visibility, and the tests check it
against Drake's VTK renderer pixel by pixel.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from tsad_drake.scenario import Scenario, ShelfConfig

#: label for pixels that see the shelf or nothing
BACKGROUND_LABEL = -1


@dc.dataclass
class CameraConfig:
    """Wrist depth camera (pinhole, Drake convention: +z optical axis, +x right, +y down)."""

    width: int = 128  #: px
    height: int = 128  #: px
    fov_y_deg: float = 70.0  #: deg, vertical field of view
    near: float = 0.03  #: m, closest depth returned
    far: float = 2.0  #: m, farthest depth returned (beyond: inf)
    standoff: float = 0.22  #: m, horizontal distance of the camera beyond half the shelf depth
    elevation: float = 0.25  #: m, camera height above the shelf floor
    look_at_height: float = 0.0  #: m, height of the point in the workspace centre it looks at

    def focal_length(self) -> float:
        """Focal length in pixels (same along x and y)."""
        return (self.height / 2.0) / np.tan(np.radians(self.fov_y_deg) / 2.0)

    def principal_point(self) -> tuple[float, float]:
        """Pixel coordinates of the optical axis (Drake's CameraInfo(width, height, fov_y))."""
        return self.width / 2.0 - 0.5, self.height / 2.0 - 0.5

    def intrinsics(self) -> np.ndarray:
        f = self.focal_length()
        cx, cy = self.principal_point()
        return np.array([[f, 0, cx], [0, f, cy], [0, 0, 1.0]])


def look_at_rotation(position: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Rotation R_SC of a camera at `position` looking at `target` with image rows going down."""
    forward = target - position
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right = right / np.linalg.norm(right)
    down = np.cross(forward, right)
    return np.stack([right, down, forward], axis=1)


def camera_pose(shelf: ShelfConfig, camera: CameraConfig, theta: float) -> np.ndarray:
    """4x4 pose X_SC of the camera for approach angle theta (radians), in the shelf frame."""
    centre = np.array([shelf.depth / 2.0, 0.0, camera.look_at_height])
    radius = shelf.depth / 2.0 + camera.standoff
    position = np.array([centre[0] - radius * np.cos(theta), -radius * np.sin(theta),
                         camera.elevation])
    X = np.eye(4)
    X[:3, :3] = look_at_rotation(position, centre)
    X[:3, 3] = position
    return X


def camera_rays(camera: CameraConfig) -> np.ndarray:
    """Ray directions (H, W, 3) in the camera frame with unit z (so t along a ray is depth)."""
    f = camera.focal_length()
    cx, cy = camera.principal_point()
    u, v = np.meshgrid(np.arange(camera.width), np.arange(camera.height))
    return np.stack([(u - cx) / f, (v - cy) / f, np.ones_like(u, dtype=float)], axis=-1)


@dc.dataclass
class Prism:
    """An upright cylinder or box spanning z0..z1 (what the ray caster draws)."""

    shape: str  #: "cylinder" (size = [radius, ...]) or "box" (size = [sx, sy, ...])
    size: tuple[float, ...]
    x: float
    y: float
    yaw: float
    z0: float
    z1: float
    label: int


def shelf_prisms(shelf: ShelfConfig) -> list[Prism]:
    """The shelf's panels (floor, back, sides, top) as boxes, labelled as background."""
    t, d, w, h = shelf.wall_thickness, shelf.depth, shelf.width, shelf.height
    full_w = w + 2 * t
    return [
        Prism("box", (d + t, full_w), (d + t) / 2, 0.0, 0.0, -t, 0.0, BACKGROUND_LABEL),
        Prism("box", (t, full_w), d + t / 2, 0.0, 0.0, -t, h + t, BACKGROUND_LABEL),
        Prism("box", (d + t, t), (d + t) / 2, w / 2 + t / 2, 0.0, -t, h + t, BACKGROUND_LABEL),
        Prism("box", (d + t, t), (d + t) / 2, -w / 2 - t / 2, 0.0, -t, h + t, BACKGROUND_LABEL),
        Prism("box", (d + t, full_w), (d + t) / 2, 0.0, 0.0, h, h + t, BACKGROUND_LABEL),
    ]


def scenario_prisms(scenario: Scenario, include_shelf: bool = True,
                     only: list[int] | None = None) -> list[Prism]:
    """Prisms of the scenario's objects (label = object index) and optionally the shelf panels."""
    prisms = shelf_prisms(scenario.shelf) if include_shelf else []
    for i, obj in enumerate(scenario.objects):
        if only is not None and i not in only:
            continue
        prisms.append(Prism(obj.shape, tuple(obj.size), obj.x, obj.y, obj.yaw, 0.0, obj.height, i))
    return prisms


def _hit_cylinder(o: np.ndarray, d: np.ndarray, p: Prism) -> np.ndarray:
    r = p.size[0]
    ox, oy = o[0] - p.x, o[1] - p.y
    dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
    t_best = np.full(d.shape[0], np.inf)
    a = dx * dx + dy * dy
    b = 2 * (ox * dx + oy * dy)
    c = ox * ox + oy * oy - r * r
    disc = b * b - 4 * a * c
    ok = (disc >= 0) & (a > 1e-12)
    sq = np.sqrt(np.where(ok, disc, 0.0))
    for sign in (-1.0, 1.0):
        t = np.where(ok, (-b + sign * sq) / np.where(a > 1e-12, 2 * a, 1.0), np.inf)
        z = o[2] + t * dz
        valid = (t > 0) & (z >= p.z0) & (z <= p.z1)
        t_best = np.where(valid & (t < t_best), t, t_best)
    for zc in (p.z0, p.z1):  # caps
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (zc - o[2]) / dz
        hx, hy = ox + t * dx, oy + t * dy
        valid = (t > 0) & (hx * hx + hy * hy <= r * r)
        t_best = np.where(valid & (t < t_best), t, t_best)
    return t_best


def _hit_box(o: np.ndarray, d: np.ndarray, p: Prism) -> np.ndarray:
    c, s = np.cos(p.yaw), np.sin(p.yaw)
    rot = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1.0]])  # S -> box frame
    ol = rot @ (o - np.array([p.x, p.y, 0.0]))
    dl = d @ rot.T
    lo = np.array([-p.size[0] / 2, -p.size[1] / 2, p.z0])
    hi = np.array([p.size[0] / 2, p.size[1] / 2, p.z1])
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (lo - ol) / dl
        t2 = (hi - ol) / dl
    t1 = np.where(np.isnan(t1), -np.inf, t1)
    t2 = np.where(np.isnan(t2), np.inf, t2)
    t_near = np.max(np.minimum(t1, t2), axis=1)
    t_far = np.min(np.maximum(t1, t2), axis=1)
    hit = (t_far >= t_near) & (t_far > 0)
    return np.where(hit, np.where(t_near > 0, t_near, np.inf), np.inf)


def _window(p: Prism, camera: CameraConfig, X_SC: np.ndarray) -> np.ndarray | slice:
    """Indices of the rays (row-major pixels) that can hit prism `p`: those inside the image
    rectangle around its bounding box's projected corners (a convex prism projects inside the
    hull of its bounding box's corners); every ray when a corner is not in front of the camera."""
    half = ((p.size[0], p.size[0]) if p.shape == "cylinder"
            else (np.hypot(p.size[0], p.size[1]) / 2,) * 2)
    corners = np.array([[p.x + sx * half[0], p.y + sy * half[1], z]
                        for sx in (-1, 1) for sy in (-1, 1) for z in (p.z0, p.z1)])
    local = (corners - X_SC[:3, 3]) @ X_SC[:3, :3]  # in the camera frame
    if (local[:, 2] <= 1e-6).any():
        return slice(None)
    f = camera.focal_length()
    cx, cy = camera.principal_point()
    u = f * local[:, 0] / local[:, 2] + cx
    v = f * local[:, 1] / local[:, 2] + cy
    c0, c1 = max(int(np.floor(u.min())) - 1, 0), min(int(np.ceil(u.max())) + 2, camera.width)
    r0, r1 = max(int(np.floor(v.min())) - 1, 0), min(int(np.ceil(v.max())) + 2, camera.height)
    if c0 >= c1 or r0 >= r1:
        return np.zeros(0, dtype=int)
    return (np.arange(r0, r1)[:, None] * camera.width + np.arange(c0, c1)[None, :]).ravel()


def raycast(prisms: list[Prism], camera: CameraConfig, X_SC: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Render depth (H, W, metres along the optical axis, inf where nothing) and labels (H, W).

    Labels are the prisms' `label` fields; BACKGROUND_LABEL where nothing or the shelf is hit.
    """
    rays_C = camera_rays(camera).reshape(-1, 3)
    d = rays_C @ X_SC[:3, :3].T  # unit depth per ray: t along d equals depth
    o = X_SC[:3, 3]
    depth = np.full(d.shape[0], np.inf)
    label = np.full(d.shape[0], BACKGROUND_LABEL, dtype=np.int32)
    for p in prisms:
        rays = _window(p, camera, X_SC)
        t = _hit_cylinder(o, d[rays], p) if p.shape == "cylinder" else _hit_box(o, d[rays], p)
        closer = t < depth[rays]
        depth[rays] = np.where(closer, t, depth[rays])
        label[rays] = np.where(closer, p.label, label[rays])
    out_of_range = (depth < camera.near) | (depth > camera.far)
    depth[out_of_range] = np.inf
    label[out_of_range] = BACKGROUND_LABEL
    shape = (camera.height, camera.width)
    return depth.reshape(shape), label.reshape(shape)


def target_visibility(scenario: Scenario, camera: CameraConfig, theta: float) -> float:
    """Fraction of the target's pixels (as if alone on the shelf) that are visible in the scene."""
    X_SC = camera_pose(scenario.shelf, camera, theta)
    index = scenario.target_index()
    _, alone = raycast(scenario_prisms(scenario, only=[index]), camera, X_SC)
    total = int(np.count_nonzero(alone == index))
    if total == 0:
        return 0.0
    _, full = raycast(scenario_prisms(scenario), camera, X_SC)
    return float(np.count_nonzero(full == index)) / total
