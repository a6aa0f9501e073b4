"""Depth images -> labelled point clouds in the shelf frame: back-projection, shelf removal, fusion.

Every point carries the label of the pixel it came from (object index, or -1 for shelf/background),
so segmentation by the renderer's label image and evaluation of the clustering both work on the
same fused cloud. Labels survive voxel down-sampling by a majority vote inside each voxel.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from tsad_drake.scenario import ShelfConfig

#: label of points that belong to no object
BACKGROUND_LABEL = -1


@dc.dataclass
class LabelledCloud:
    """Points in the shelf frame S with one integer label per point."""

    points: np.ndarray  #: (N, 3) float, metres, in S
    labels: np.ndarray  #: (N,) int32, object index per point, BACKGROUND_LABEL for none

    def __len__(self) -> int:
        return int(self.points.shape[0])

    def select(self, mask: np.ndarray) -> LabelledCloud:
        """The points where `mask` (boolean or index array) selects."""
        return LabelledCloud(self.points[mask], self.labels[mask])

    @staticmethod
    def empty() -> LabelledCloud:
        return LabelledCloud(np.zeros((0, 3)), np.zeros(0, dtype=np.int32))


@dc.dataclass
class CloudConfig:
    """How depth images become the fused, shelf-free cloud."""

    max_depth: float = 1.5  #: m, depth readings beyond this are dropped
    floor_tolerance: float = 0.004  #: m, points at most this high above the shelf floor are floor
    wall_tolerance: float = 0.003  #: m, points this close to a side/back wall or the top are shelf
    voxel_size: float = 0.003  #: m, edge of the voxels the fused cloud is down-sampled into
    #: m, a pixel reading this much farther than its nearest 4-neighbour is dropped before
    #: back-projection: flying pixels between surfaces and the far side of each depth edge
    #: (0: off)
    shadow_jump: float = 0.0
    #: a reading beyond the jump that continues its neighbour's slope (a top seen at a grazing
    #: angle) stays when the two steps differ by at most this fraction (0: every such reading
    #: goes; see `drop_far_side_of_edges`)
    shadow_slope_tolerance: float = 0.0
    #: statistical outlier removal per view (flying pixels): neighbours compared (0: off)
    outlier_neighbours: int = 0
    #: a point whose mean neighbour distance exceeds the view's mean by this many standard
    #: deviations is an outlier
    outlier_std_ratio: float = 2.0


def robust_top(points: np.ndarray) -> float:
    """Top height of a set of points, robust to a few stray points above it (the 5th highest)."""
    z = np.sort(np.asarray(points)[:, 2])
    return float(z[-min(len(z), 5)])


def drop_far_side_of_edges(depth: np.ndarray, jump: float, slope_tolerance: float = 0.0
                           ) -> np.ndarray:
    """`depth` with inf where a reading lies more than `jump` (m) beyond a 4-neighbour and does
    not continue that neighbour's surface: flying pixels (readings between a silhouette and what
    lies behind it) and the occluded side of each depth edge go; an object's own silhouette, the
    near side, stays.

    A surface seen at a grazing angle (an object's top from a camera a little above it) steps by
    more than `jump` from pixel to pixel too. With `slope_tolerance` > 0 such a reading stays
    when it continues a slope: the neighbour's own step towards the camera, one pixel further on,
    is within `slope_tolerance` (a fraction of the step) of its own. A flying pixel's near
    neighbour sits on a face turned to the camera (no such step), so it goes either way.
    """
    depth = np.asarray(depth, dtype=float)
    if jump <= 0:
        return depth
    finite = np.where(np.isfinite(depth) & (depth > 0), depth, np.inf)
    padded = np.pad(finite, 2, mode="constant", constant_values=np.inf)
    h, w = finite.shape
    far_side = np.zeros(finite.shape, dtype=bool)
    with np.errstate(invalid="ignore"):
        for dv, du in ((-1, 0), (1, 0), (0, -1), (0, 1)):
            q = padded[2 + dv:2 + dv + h, 2 + du:2 + du + w]
            q2 = padded[2 + 2 * dv:2 + 2 * dv + h, 2 + 2 * du:2 + 2 * du + w]
            step = finite - q
            slope = (np.abs((q - q2) - step) <= slope_tolerance * step if slope_tolerance > 0
                     else np.zeros(finite.shape, dtype=bool))
            far_side |= np.isfinite(finite) & np.isfinite(q) & (step > jump) & ~slope
    out = depth.copy()
    out[far_side] = np.inf
    return out


def depth_to_cloud(depth: np.ndarray, intrinsics: np.ndarray, X_SC: np.ndarray,
                   label: np.ndarray | None = None, max_depth: float = np.inf) -> LabelledCloud:
    """Back-project a depth image (metres along the optical axis) into the shelf frame.

    Args:
        depth: (H, W) depth, inf (or nan, <= 0, > max_depth) where nothing was seen; dropped.
        intrinsics: 3x3 pinhole matrix [[f, 0, cx], [0, f, cy], [0, 0, 1]].
        X_SC: 4x4 camera pose in S (Drake camera frame: +z optical axis, +x right, +y down).
        label: optional (H, W) per-pixel labels carried along; BACKGROUND_LABEL when omitted.
        max_depth: m, readings beyond this are dropped.

    Returns:
        The valid pixels as points in S with their labels.
    """
    depth = np.asarray(depth, dtype=float)
    valid = np.isfinite(depth) & (depth > 0) & (depth <= max_depth)
    v, u = np.nonzero(valid)
    z = depth[v, u]
    fx, fy = intrinsics[0, 0], intrinsics[1, 1]
    cx, cy = intrinsics[0, 2], intrinsics[1, 2]
    p_C = np.stack([(u - cx) / fx * z, (v - cy) / fy * z, z], axis=1)
    p_S = p_C @ X_SC[:3, :3].T + X_SC[:3, 3]
    if label is None:
        labels = np.full(len(z), BACKGROUND_LABEL, dtype=np.int32)
    else:
        labels = np.asarray(label, dtype=np.int32)[v, u]
    return LabelledCloud(p_S, labels)


def workspace_mask(points: np.ndarray, shelf: ShelfConfig, floor_tolerance: float = 0.004,
                   wall_tolerance: float = 0.003) -> np.ndarray:
    """True for points strictly inside the shelf's free workspace (not floor, walls, top, outside).

    The box is x in [0, depth - wall_tolerance], |y| <= width/2 - wall_tolerance,
    z in (floor_tolerance, height - wall_tolerance).
    """
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    return ((x >= 0.0) & (x <= shelf.depth - wall_tolerance)
            & (np.abs(y) <= shelf.width / 2 - wall_tolerance)
            & (z > floor_tolerance) & (z < shelf.height - wall_tolerance))


def remove_shelf(cloud: LabelledCloud, shelf: ShelfConfig,
                 config: CloudConfig | None = None) -> LabelledCloud:
    """Drop floor, wall, top and out-of-workspace points (geometry only; labels are not used)."""
    config = config or CloudConfig()
    return cloud.select(workspace_mask(cloud.points, shelf, config.floor_tolerance,
                                       config.wall_tolerance))


def voxel_down_sample(cloud: LabelledCloud, voxel_size: float) -> LabelledCloud:
    """Open3D voxel down-sampling; each voxel's label is the most common label of its points."""
    import open3d as o3d

    if len(cloud) == 0 or voxel_size <= 0:
        return cloud
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cloud.points))
    lo = cloud.points.min(axis=0) - voxel_size
    hi = cloud.points.max(axis=0) + voxel_size
    down, _, traces = pcd.voxel_down_sample_and_trace(voxel_size, lo, hi, False)
    members = [np.asarray(t) for t in traces]
    voxel_of = np.repeat(np.arange(len(members)), [len(m) for m in members])
    labels = cloud.labels[np.concatenate(members)]
    return LabelledCloud(np.asarray(down.points), majority_label(voxel_of, labels, len(members)))


def majority_label(group: np.ndarray, labels: np.ndarray, num_groups: int) -> np.ndarray:
    """Most common label per group (ties go to the larger label, deterministic)."""
    pairs, counts = np.unique(np.stack([group, labels], axis=1), axis=0, return_counts=True)
    order = np.lexsort((pairs[:, 1], counts, pairs[:, 0]))  # by group, then count, then label
    pairs = pairs[order]
    last = np.r_[pairs[1:, 0] != pairs[:-1, 0], True]  # the last row of each group wins
    out = np.full(num_groups, BACKGROUND_LABEL, dtype=np.int32)
    out[pairs[last, 0]] = pairs[last, 1]
    return out


def remove_outliers(cloud: LabelledCloud, neighbours: int, std_ratio: float) -> LabelledCloud:
    """Open3D statistical outlier removal (isolated points: flying pixels, stray noise)."""
    import open3d as o3d

    if neighbours <= 0 or len(cloud) <= neighbours:
        return cloud
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cloud.points))
    _, kept = pcd.remove_statistical_outlier(nb_neighbors=neighbours, std_ratio=std_ratio)
    return cloud.select(np.sort(np.asarray(kept, dtype=int)))


def fuse_clouds(clouds: list[LabelledCloud], voxel_size: float = 0.003) -> LabelledCloud:
    """Concatenate per-view clouds and voxel down-sample them into one cloud."""
    clouds = [c for c in clouds if len(c)]
    if not clouds:
        return LabelledCloud.empty()
    merged = LabelledCloud(np.concatenate([c.points for c in clouds]),
                           np.concatenate([c.labels for c in clouds]).astype(np.int32))
    return voxel_down_sample(merged, voxel_size)


def views_to_cloud(views: list[tuple[np.ndarray, np.ndarray | None, np.ndarray]],
                   intrinsics: np.ndarray, shelf: ShelfConfig,
                   config: CloudConfig | None = None) -> LabelledCloud:
    """(depth, label, X_SC) per view -> one fused, shelf-free, down-sampled cloud in S."""
    config = config or CloudConfig()
    clouds = [remove_outliers(
        remove_shelf(depth_to_cloud(drop_far_side_of_edges(depth, config.shadow_jump,
                                                           config.shadow_slope_tolerance),
                                    intrinsics, X_SC, label, config.max_depth), shelf, config),
        config.outlier_neighbours, config.outlier_std_ratio)
        for depth, label, X_SC in views]
    return fuse_clouds(clouds, config.voxel_size)
