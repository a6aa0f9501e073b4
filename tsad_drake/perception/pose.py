"""Planar pose (x, y, yaw) of one segment from its points, allowing for a one-sided view.

The camera sees the fronts (and, from above, the tops) of upright objects, so a plain centroid is
pulled towards the camera. Two models are fitted to the segment's side points (those below the top
cap) and the one with the smaller residual wins:

- a circle (algebraic Kasa fit refined by Gauss-Newton, radius clamped to a prior range): the
  centre of a fitted arc is unbiased however little of the arc is seen;
- a rectangle (L-shape fitting by search over yaw: side points must lie on the edges of the
  bounding rectangle at that yaw). Its extent comes from all points (top cap included); an extent
  shorter than the smallest plausible side is grown away from the camera (+x, into the shelf), and
  a small footprint is completed to a square, since the back faces are never seen.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np


@dc.dataclass
class PoseConfig:
    """Priors and tolerances of the planar pose fit."""

    cap_band: float = 0.006  #: m, points this close below the segment's top are its top cap
    min_radius: float = 0.015  #: m, smallest plausible cylinder radius
    max_radius: float = 0.06  #: m, largest plausible cylinder radius
    min_box_side: float = 0.04  #: m, smallest plausible box side (shorter extents are completed)
    square_below: float = 0.065  #: m, a footprint with both extents below this is taken as square
    yaw_step_deg: float = 1.0  #: deg, coarse yaw search step of the rectangle fit
    circle_preference: float = 0.6  #: circle wins when its rms < this x the rectangle's rms
    min_side_points: int = 8  #: fewer side points than this: fit all points instead


@dc.dataclass
class PlanarPose:
    """A fitted footprint: centre, yaw and the shape it was fitted as."""

    x: float  #: m
    y: float  #: m
    yaw: float  #: rad, in [-pi/4, pi/4) for boxes (a box's yaw is only known modulo 90 deg), 0 for cylinders
    shape: str  #: "cylinder" or "box"
    size: tuple[float, ...]  #: (radius,) or (sx, sy) along yaw and across, m
    rms: float  #: m, fit residual on the side points


def fit_circle(xy: np.ndarray, min_radius: float, max_radius: float, iterations: int = 10
               ) -> tuple[np.ndarray, float, float]:
    """Least-squares circle through 2D points; returns (centre, radius, rms residual).

    The radius is clamped to [min_radius, max_radius] (a nearly straight face would otherwise fit a
    huge circle); with a clamped radius the centre is refitted for that radius.
    """
    mean = xy.mean(axis=0)
    q = xy - mean
    A = np.c_[2 * q, np.ones(len(q))]
    b = (q ** 2).sum(axis=1)
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    centre = sol[:2]
    radius = float(np.sqrt(max(sol[2] + centre @ centre, 1e-12)))
    spread = np.linalg.svd(q, compute_uv=False) if len(q) >= 2 else np.zeros(2)
    if spread[-1] <= 1e-6 * max(spread[0], 1e-12):  # collinear: an infinitely large circle
        radius = np.inf
    fixed = None
    if not min_radius < radius < max_radius:
        fixed = float(np.clip(radius, min_radius, max_radius))
        radius = fixed
        centre = np.array([fixed, 0.0])  # start one radius behind the points (away from camera)
    for _ in range(iterations):  # Gauss-Newton on the geometric distance
        diff = q - centre
        dist = np.maximum(np.linalg.norm(diff, axis=1), 1e-12)
        if fixed is None:
            J = np.c_[-diff / dist[:, None], -np.ones(len(q))]
            r = dist - radius
            step, *_ = np.linalg.lstsq(J, -r, rcond=None)
            centre, radius = centre + step[:2], radius + step[2]
        else:
            J = -diff / dist[:, None]
            step, *_ = np.linalg.lstsq(J, -(dist - fixed), rcond=None)
            centre = centre + step
        if np.abs(step).max() < 1e-7:
            break
    if fixed is None and not min_radius < radius < max_radius:
        clamped = float(np.clip(radius, min_radius, max_radius))
        return fit_circle(xy, clamped, clamped, iterations)
    rms = float(np.sqrt(np.mean((np.linalg.norm(q - centre, axis=1) - radius) ** 2)))
    return centre + mean, float(radius), rms


def _robust_bounds(values: np.ndarray) -> tuple[float, float]:
    """Extent of noisy samples: 0.5th and 99.5th percentiles (min/max without noise outliers)."""
    lo, hi = np.percentile(values, [0.5, 99.5])
    return float(lo), float(hi)


def _rect_costs(xy: np.ndarray, yaws: np.ndarray) -> np.ndarray:
    """Per yaw, the RMS distance of points to the nearest edge of their (robust) bounding
    rectangle at that yaw: every yaw at once, a row of projections per yaw."""
    c, s = np.cos(yaws)[:, None], np.sin(yaws)[:, None]
    u = c * xy[:, 0] + s * xy[:, 1]  # (yaws, points)
    v = c * xy[:, 1] - s * xy[:, 0]
    (u0, u1), (v0, v1) = (np.percentile(w, [0.5, 99.5], axis=1)[:, :, None] for w in (u, v))
    d = np.minimum(np.minimum(np.abs(u - u0), np.abs(u1 - u)),
                   np.minimum(np.abs(v - v0), np.abs(v1 - v)))
    return np.sqrt(np.mean(d ** 2, axis=1))


def fit_rectangle_yaw(xy: np.ndarray, step_deg: float = 1.0) -> tuple[float, float]:
    """Yaw in [-pi/4, pi/4) whose bounding rectangle edges the side points lie on best, and rms."""
    coarse = np.radians(np.arange(-45.0, 45.0, step_deg))
    best = coarse[int(np.argmin(_rect_costs(xy, coarse)))]
    fine = best + np.radians(np.linspace(-step_deg, step_deg, 21))
    fine_costs = _rect_costs(xy, fine)
    yaw = float(fine[int(np.argmin(fine_costs))])
    yaw = (yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4
    return yaw, float(fine_costs.min())


def complete_interval(lo: float, hi: float, want: float, axis_x: float,
                      seen: tuple[int, int] = (0, 0)) -> tuple[float, float]:
    """Grow [lo, hi] to length `want` at the end seen worse (`seen`: how well each end was
    seen, higher is better), else away from the camera (towards +x along this axis)."""
    grow = want - (hi - lo)
    if grow <= 0:
        return lo, hi
    if seen[0] != seen[1]:  # the end seen better stays where its points put it
        return (lo, hi + grow) if seen[0] > seen[1] else (lo - grow, hi)
    if abs(axis_x) < 0.3:  # axis across the view: both ends are seen equally often
        return lo - grow / 2, hi + grow / 2
    return (lo, hi + grow) if axis_x > 0 else (lo - grow, hi)


def box_footprint(points: np.ndarray, yaw: float, config: PoseConfig
                  ) -> tuple[np.ndarray, tuple[float, float]]:
    """Centre and (sx, sy) of the box at `yaw` from all its points, completing hidden extents."""
    c, s = np.cos(yaw), np.sin(yaw)
    axis_u, axis_v = np.array([c, s]), np.array([-s, c])
    u, v = points[:, :2] @ axis_u, points[:, :2] @ axis_v
    (u0, u1), (v0, v1) = _robust_bounds(u), _robust_bounds(v)
    want_u = max(u1 - u0, config.min_box_side)
    want_v = max(v1 - v0, config.min_box_side)
    if max(want_u, want_v) < config.square_below:
        want_u = want_v = max(want_u, want_v)
    u0, u1 = complete_interval(u0, u1, want_u, axis_u[0])
    v0, v1 = complete_interval(v0, v1, want_v, axis_v[0])
    centre = axis_u * (u0 + u1) / 2 + axis_v * (v0 + v1) / 2
    return centre, (float(u1 - u0), float(v1 - v0))


def estimate_planar_pose(points: np.ndarray, config: PoseConfig | None = None) -> PlanarPose:
    """Planar pose of one upright object from its points in S (see the module docstring)."""
    config = config or PoseConfig()
    points = np.asarray(points, dtype=float)
    if len(points) < 3:
        centre = points[:, :2].mean(axis=0) if len(points) else np.zeros(2)
        return PlanarPose(float(centre[0]), float(centre[1]), 0.0, "cylinder", (0.0,), 0.0)
    z = points[:, 2]
    side = points[z < z.max() - config.cap_band]
    if len(side) < config.min_side_points:
        side = points
    xy = side[:, :2]
    centre, radius, circle_rms = fit_circle(xy, config.min_radius, config.max_radius)
    yaw, rect_rms = fit_rectangle_yaw(xy, config.yaw_step_deg)
    if circle_rms < config.circle_preference * rect_rms:
        return PlanarPose(float(centre[0]), float(centre[1]), 0.0, "cylinder", (radius,),
                          circle_rms)
    centre, size = box_footprint(points, yaw, config)
    return PlanarPose(float(centre[0]), float(centre[1]), yaw, "box", size, rect_rms)
