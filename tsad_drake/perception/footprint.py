"""Noise-robust footprints: a fitted shape outline and a per-object uncertainty from the fit.

Under depth noise the hull of an object's seen points grows with the noise (its extreme points are
the noisiest ones, and the completion by reflection doubles the growth). A footprint fitted by
least squares averages the noise out instead:

- cylinder: the circle fit of `pose.fit_circle`, refitted without points whose residual exceeds
  `trim_sigmas` robust standard deviations (flying pixels, a neighbour's stray points);
- box: at the fitted yaw, each seen face's position is the median of the side points assigned to
  it (its noise averages out); a face seen by too few side points takes the extent of the top
  cap's points and the side points on seen faces, less `edge_trim` extreme points at each end;
  an extent still shorter than the smallest plausible side (or, for a footprint short both ways
  and an end of this extent unseen, than the other extent: a square pillar) is completed at the
  end seen worse (a face, then an edge: a few side points at the bound, then nothing), else away
  from the camera: what was seen stays where its points put it;
  with the views' free space (`free_space.FreeSpace`), an end no face was seen on then grows into
  the shelf, in `grow_step`s, until the next step would cover space a camera saw through or the
  box would outgrow the largest object (`max_length` by `max_width`): a box whose back is hidden
  is as long as the hidden space allows, not as short as its seen part;
- optionally (`box_outline`) the outline is, or also covers, the support polygon of the seen
  points completed through the centre, trimmed of their extremes and drawn in by the noise the
  fit saw (measured worse on scenario 2: kept off).

The uncertainty (m) is how far the true footprint may reach past the outline: a floor plus
`uncertainty_sigmas` times the fit's robust residual (the noise it saw) over the square root of
its points per 100 (a standard error); the planners pad the outline by it
(`planning.state.completed_footprint_points`).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from tsad_drake.geometry2d import convex_hull, footprint_polygon
from tsad_drake.perception.free_space import FreeSpace
from tsad_drake.perception.pointcloud import robust_top
from tsad_drake.perception.pose import (
    PlanarPose,
    PoseConfig,
    complete_interval,
    fit_circle,
    fit_rectangle_yaw,
)


@dc.dataclass
class FootprintConfig:
    """Fitted outlines (off: the planners complete the seen points' hull, the ideal pipeline)."""

    fitted: bool = False  #: give every object a fitted outline and an uncertainty
    trim_sigmas: float = 2.5  #: points off the fit by more than this many robust sigmas are cut
    face_band: float = 0.006  #: m, side points this close to a face (at the robust bounds) are on it
    min_face_points: int = 6  #: a face seen by fewer side points takes the cap's extent
    #: m, a face's points must span this much along it (10th-90th percentile); a corner sliver
    #: or the end of a partly hidden side is no face
    min_face_span: float = 0.012
    #: a face's largest gap across, as a share of its points' span (1: no such test; 0.6 tells
    #: the seen ends of two side faces cut off by an occluder from a face)
    max_face_gap: float = 1.0
    uncertainty_floor: float = 0.0003  #: m, uncertainty of a perfect fit
    #: uncertainty added per robust residual sigma, for a segment of 100 points (the standard
    #: error of a least-squares fit falls with the square root of the points)
    uncertainty_sigmas: float = 1.0
    #: extreme points left out when a face's position comes from the extent of all points
    edge_trim: int = 2
    #: the outline also covers the support polygon of the completed points without this many
    #: extreme points per direction (-1: the fitted shape alone)
    box_outline: str = "fit"  #: fit (the fitted box) | support | union (see the docstring)
    box_centre: str = "fit"  #: centre the support polygon completes through: fit | pose
    hull_trim: int = 3
    hull_shrink: float = 1.5  #: and drawn in by this many robust residual sigmas
    #: a segment is a cylinder when its circle fit's robust residual is below this times the box
    #: fit's (noise inflates both residuals alike, so their ratio, not a difference, decides)
    circle_ratio: float = 1.2
    #: grow unseen box ends into space no camera saw through (needs the views' free space)
    grow_hidden: bool = False
    grow_step: float = 0.003  #: m, step of that growth
    grow_stop_samples: int = 2  #: seen-free points of a step's face that stop the growth
    max_length: float = 0.135  #: m, longest box footprint side in the built-in scenes
    #: m, and the longest of its shorter side (the built-in boxes and pillars are at most 54 mm
    #: wide; a wider guess makes a hidden target too wide for the gripper)
    max_width: float = 0.055
    #: a segment of fewer points than this whose points lie inside a bigger neighbour's fitted
    #: outline (grown by `explained_margin`) is a piece of that neighbour (a corner or far end
    #: cut off by an occluder) and joins it instead of standing as an object (0: off)
    explained_points: int = 0
    explained_margin: float = 0.005  #: m
    explained_share: float = 0.8  #: share of its points the neighbour's outline must hold
    #: m, two segments whose fitted outlines interpenetrate deeper than this are one object cut
    #: apart (rigid objects cannot stand inside each other): their points are joined and fitted
    #: again (0: off). Raycast s1-3 seeds 1000-1009 (realistic, cluster): 7 pairs interpenetrate;
    #: the 4 deeper than 10 mm (58-63 mm) are pieces of one object, the next is two objects at
    #: 5.2 mm, then pieces at 3.8 and 0.1 mm; the demo's split box (Drake observer): 22 mm
    join_depth: float = 0.010


@dc.dataclass
class FittedFootprint:
    """An object's outline in S and how far the true footprint may reach past it."""

    x: float  #: m, centre of the outline
    y: float  #: m
    yaw: float  #: rad
    shape: str  #: "cylinder" or "box"
    size: tuple[float, ...]  #: m, (radius,) or (sx, sy)
    outline: np.ndarray  #: (K, 2) counter-clockwise convex polygon in S, m
    uncertainty: float  #: m
    residual: float  #: m, robust standard deviation of the side points about the fit


def robust_sigma(residuals: np.ndarray) -> float:
    """1.4826 x the median absolute residual (the standard deviation of Gaussian residuals)."""
    if len(residuals) == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(residuals)))


def _side_points(points: np.ndarray, pose_config: PoseConfig) -> np.ndarray:
    """The points below the top cap (the top taken robustly: a few noisy points stand higher)."""
    side = points[points[:, 2] < robust_top(points) - pose_config.cap_band]
    return side if len(side) >= pose_config.min_side_points else points


def _cap_points(points: np.ndarray, pose_config: PoseConfig) -> np.ndarray:
    """The top cap's points (within the cap band of the robust top), else all points."""
    cap = points[np.abs(points[:, 2] - robust_top(points)) <= pose_config.cap_band]
    return cap if len(cap) >= pose_config.min_side_points else points


def fit_cylinder(points: np.ndarray, pose_config: PoseConfig, config: FootprintConfig
                 ) -> tuple[np.ndarray, float, float]:
    """Trimmed least-squares circle of the side points: (centre, radius, robust residual)."""
    xy = _side_points(points, pose_config)[:, :2]
    centre, radius, _ = fit_circle(xy, pose_config.min_radius, pose_config.max_radius)
    for _ in range(2):
        residual = np.linalg.norm(xy - centre, axis=1) - radius
        sigma = robust_sigma(residual)
        keep = np.abs(residual) <= config.trim_sigmas * max(sigma, 1e-4)
        if keep.sum() < pose_config.min_side_points or keep.all():
            break
        xy = xy[keep]
        centre, radius, _ = fit_circle(xy, pose_config.min_radius, pose_config.max_radius)
    residual = np.linalg.norm(xy - centre, axis=1) - radius
    return centre, radius, robust_sigma(residual)


def _sparse_edges(values: np.ndarray, trim: int) -> tuple[float, float]:
    """Ends of a sample whose ends may be seen by a handful of points: the `trim`+1-th smallest
    and largest values (a percentile would cut a sparsely seen end off)."""
    ordered = np.sort(values)
    k = min(trim, (len(ordered) - 1) // 2)
    return float(ordered[k]), float(ordered[-1 - k])


def fit_box(points: np.ndarray, yaw: float, pose_config: PoseConfig, config: FootprintConfig,
            free: FreeSpace | None = None) -> tuple[np.ndarray, tuple[float, float], float]:
    """Centre, (sx, sy) and robust residual of the box at `yaw` (see the module docstring)."""
    c, s = np.cos(yaw), np.sin(yaw)
    axes = (np.array([c, s]), np.array([-s, c]))
    side = _side_points(points, pose_config)[:, :2]
    side_coords = [side @ a for a in axes]
    cap = _cap_points(points, pose_config)
    cap_coords = [cap[:, :2] @ a for a in axes]
    # the side points' distance to their nearest face at the robust bounds: the noise they carry
    bounds = [np.percentile(sc, [0.5, 99.5]) for sc in side_coords]
    dist = np.stack([np.abs(side_coords[0] - bounds[0][0]), np.abs(side_coords[0] - bounds[0][1]),
                     np.abs(side_coords[1] - bounds[1][0]), np.abs(side_coords[1] - bounds[1][1])])
    nearest = np.argmin(dist, axis=0)
    on_faces = dist.min(axis=0) <= config.face_band
    # what bounds a hidden face: the top cap and the side points that lie on a seen face
    inliers = [np.concatenate([cap_coords[axis], side_coords[axis][on_faces]]) for axis in range(2)]
    faces = []
    residuals = []
    evidence = []  # per face: 2 seen as a face, 1 an edge (side points at its bound), 0 none
    for face in range(4):
        axis, end = divmod(face, 2)
        on = (nearest == face) & (dist[face] <= config.face_band)
        evidence.append(1 if on.sum() >= config.min_face_points else 0)
        across = side_coords[1 - axis][on]
        spread = np.ptp(np.percentile(across, [10, 90])) if len(across) else 0.0
        # the seen ends of the two faces beside it, cut off at one depth by an occluder, are
        # no face: a face's points cover it across without a gap of most of its width
        gap = float(np.diff(np.sort(across)).max()) if len(across) > 1 else 0.0
        if (on.sum() >= config.min_face_points and spread >= config.min_face_span
                and gap <= config.max_face_gap * np.ptp(across)):
            coord = side_coords[axis][on]
            position = float(np.median(coord))
            faces.append(position)
            residuals.append(coord - position)
            evidence[face] = 2
        else:
            faces.append(None)
    sigma = robust_sigma(np.concatenate(residuals)) if residuals else 0.0
    extents = []
    for axis in range(2):
        cap_lo, cap_hi = _sparse_edges(inliers[axis], config.edge_trim)
        lo = faces[2 * axis] if faces[2 * axis] is not None else cap_lo
        hi = faces[2 * axis + 1] if faces[2 * axis + 1] is not None else cap_hi
        extents.append([lo, hi])
    if free is not None and config.grow_hidden:  # before the completion to plausible sides
        extents = _grow_hidden_ends(extents, axes, [f is not None for f in faces],
                                    robust_top(points), free, config)
    want = [max(hi - lo, pose_config.min_box_side) for lo, hi in extents]
    if max(want) < pose_config.square_below:  # a square pillar, unless both ends were seen
        want = [max(want) if min(evidence[2 * axis:2 * axis + 2]) == 0 else want[axis]
                for axis in range(2)]
    extents = [list(complete_interval(lo, hi, want[axis], axes[axis][0],
                                      (evidence[2 * axis], evidence[2 * axis + 1])))
               for axis, (lo, hi) in enumerate(extents)]
    centre = sum(a * (lo + hi) / 2 for a, (lo, hi) in zip(axes, extents, strict=True))
    return centre, (float(extents[0][1] - extents[0][0]), float(extents[1][1] - extents[1][0])), sigma


def _end_samples(extents: list[list[float]], axes: tuple[np.ndarray, np.ndarray], axis: int,
                 end: int, at: float, top: float) -> np.ndarray:
    """Points of the box's side face at coordinate `at` of `axis` (end 0: low, 1: high): across
    the face (kept `inset` inside its edges: a ray grazing past the box's side is no evidence)
    and up it, from near the floor to just under the top (a point just behind a box, below its top, is
    hidden by the box itself: the higher the sample, the shorter that shadow)."""
    lo, hi = extents[1 - axis]
    inset = min(0.004, (hi - lo) / 4)
    across = np.linspace(lo + inset, hi - inset, 5)
    heights = np.linspace(0.02, max(top - 0.003, 0.021), 4)
    xy = axes[axis] * at + np.outer(across, axes[1 - axis])
    return np.array([[p[0], p[1], z] for p in xy for z in heights])


def _grow_hidden_ends(extents: list[list[float]], axes: tuple[np.ndarray, np.ndarray],
                      seen: list[bool], top: float, free: FreeSpace, config: FootprintConfig
                      ) -> list[list[float]]:
    """Grow each end no face was seen on (see the module docstring): the longer axis up to
    `max_length`, the shorter up to `max_width`, far ends (into the shelf) first."""
    extents = [list(e) for e in extents]
    long_axis = int(np.argmax([hi - lo for lo, hi in extents]))
    for axis in (long_axis, 1 - long_axis):
        limit = config.max_length if axis == long_axis else config.max_width
        ends = sorted((0, 1), key=lambda end: -axes[axis][0] * (1 if end else -1))
        for end in ends:
            if seen[2 * axis + end]:
                continue
            sign = 1.0 if end else -1.0
            while extents[axis][1] - extents[axis][0] + config.grow_step <= limit:
                at = extents[axis][end] + sign * config.grow_step
                samples = _end_samples(extents, axes, axis, end, at, top)
                if free.seen_free(samples).sum() >= config.grow_stop_samples:
                    break
                extents[axis][end] = at
    return extents


def support_polygon(xy: np.ndarray, trim: int, shrink: float, directions: int = 32
                    ) -> np.ndarray:
    """Convex polygon bounded, in each of `directions`, by the (`trim`+1)-th farthest point less
    `shrink` (m): the hull of noisy points without the overshoot of their noisiest extremes."""
    angles = np.arange(directions) * 2 * np.pi / directions
    normals = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    proj = np.sort(xy @ normals.T, axis=0)
    k = min(trim, len(xy) - 1)
    h = proj[-1 - k] - shrink
    nxt = np.roll(np.arange(directions), -1)
    a = np.stack([normals, normals[nxt]], axis=1)  # (D, 2, 2): consecutive support lines
    b = np.stack([h, h[nxt]], axis=1)
    vertices = np.linalg.solve(a, b[..., None])[..., 0]
    return convex_hull(vertices)


def fit_footprint(points: np.ndarray, pose: PlanarPose, pose_config: PoseConfig,
                  config: FootprintConfig, free: FreeSpace | None = None) -> FittedFootprint:
    """The fitted outline of one segment whose planar pose (and shape) `pose` estimated
    (`free`: the views' free space, for hidden box ends)."""
    points = np.asarray(points, dtype=float)
    if len(points) < pose_config.min_side_points:
        outline = footprint_polygon(pose.shape, pose.size if pose.size[0] > 0 else (0.01,),
                                    pose.x, pose.y, pose.yaw)
        return FittedFootprint(pose.x, pose.y, pose.yaw, pose.shape, pose.size, outline,
                               config.uncertainty_floor + 0.005, 0.0)
    centre, radius, circle_sigma = fit_cylinder(points, pose_config, config)
    yaw, _ = fit_rectangle_yaw(_side_points(points, pose_config)[:, :2],
                               pose_config.yaw_step_deg)
    box_centre, box_size, box_sigma = fit_box(points, yaw, pose_config, config, free)
    # a circle held at the largest plausible radius is a flat face (a box seen from one side
    # fits such a wide arc as well as a rectangle), never a cylinder
    flat = radius >= pose_config.max_radius - 1e-6
    if circle_sigma < config.circle_ratio * box_sigma and not flat:
        shape, size, sigma, yaw = "cylinder", (radius,), circle_sigma, 0.0
    else:
        shape, size, sigma, centre = "box", box_size, box_sigma, box_centre
    outline = footprint_polygon(shape, size, float(centre[0]), float(centre[1]), yaw)
    if shape == "box" and config.box_outline != "fit":  # completed points cover hidden ends
        if config.box_centre == "pose":
            centre = np.array([pose.x, pose.y])
        xy = points[:, :2]
        completed = np.concatenate([xy, 2 * centre - xy])
        support = support_polygon(completed, config.hull_trim, config.hull_shrink * sigma)
        outline = support if config.box_outline == "support" else convex_hull(
            np.concatenate([outline, support]))
    uncertainty = (config.uncertainty_floor
                   + config.uncertainty_sigmas * sigma / np.sqrt(len(points) / 100.0))
    return FittedFootprint(float(centre[0]), float(centre[1]), yaw, shape, size, outline,
                           float(uncertainty), float(sigma))
