"""Fused cloud -> per-object segments, by the renderer's labels or by clustering the cloud alone.

Two modes:

- ``label``: points are grouped by their pixel label (the renderer's instance image stands in for
  the paper's SD Mask R-CNN instance segmentation); segments are named after the scenario objects
  and the target is the segment with the target's label.
- ``cluster``: the cloud alone is clustered (DBSCAN in the floor plane, then a height-aware split,
  see `cluster_cloud`); segments are named ``cluster<k>`` ordered by centroid x then y. The paper
  recognises the target by its appearance (colour); geometry cannot, so the target is the cluster
  holding most of the target-labelled points (the pixel labels stand in for appearance only here).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from tsad_drake.perception.pointcloud import BACKGROUND_LABEL, LabelledCloud

SEGMENTATIONS = ("label", "cluster")


@dc.dataclass
class Segment:
    """The points of one object hypothesis."""

    name: str
    indices: np.ndarray  #: (P,) int, indices into the segmented cloud
    points: np.ndarray  #: (P, 3) m, in S
    is_target: bool = False


@dc.dataclass
class ClusterConfig:
    """Clustering of the fused cloud in cluster mode."""

    eps: float = 0.0042  #: m, DBSCAN neighbourhood radius in the floor plane (< the 5 mm min gap)
    min_points: int = 3  #: DBSCAN core-point neighbour count
    min_cluster_points: int = 25  #: clusters smaller than this are dropped as noise
    min_cluster_height: float = 0.02  #: m, clusters shorter than this are dropped
    height_step: float = 0.025  #: m, a jump in top height this large inside a cluster splits it
    split_cell: float = 0.004  #: m, grid cell used to find the top height across a cluster


def segment_by_label(cloud: LabelledCloud, names: list[str], target_label: int | None,
                     min_points: int = 1) -> list[Segment]:
    """One segment per object label present in the cloud, in label (scenario) order."""
    segments = []
    for index in np.unique(cloud.labels):
        if index == BACKGROUND_LABEL:
            continue
        members = np.flatnonzero(cloud.labels == index)
        if len(members) < min_points:
            continue
        segments.append(Segment(names[int(index)], members, cloud.points[members],
                                is_target=target_label is not None and int(index) == target_label))
    return segments


def _dbscan(points: np.ndarray, eps: float, min_points: int) -> np.ndarray:
    import open3d as o3d

    if len(points) == 0:
        return np.zeros(0, dtype=int)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    return np.asarray(pcd.cluster_dbscan(eps=eps, min_points=min_points, print_progress=False))


def _split_by_height(points: np.ndarray, config: ClusterConfig) -> np.ndarray:
    """Sub-cluster ids for one xy cluster: split where two touching objects differ in height.

    The top height is taken per xy grid cell; cells are grouped into height levels (a sorted
    gap of at least `height_step` separates levels) and each point takes the level of its cell.
    A split is kept only when every part is big enough to be an object.
    """
    cells = np.floor(points[:, :2] / config.split_cell).astype(np.int64)
    _, cell_of, = np.unique(cells, axis=0, return_inverse=True)[:2]
    cell_of = cell_of.ravel()
    top = np.full(cell_of.max() + 1, -np.inf)
    np.maximum.at(top, cell_of, points[:, 2])
    levels_sorted = np.sort(np.unique(np.round(top, 4)))
    gaps = np.flatnonzero(np.diff(levels_sorted) >= config.height_step)
    if len(gaps) == 0:
        return np.zeros(len(points), dtype=int)
    thresholds = (levels_sorted[gaps] + levels_sorted[gaps + 1]) / 2
    level = np.searchsorted(thresholds, top[cell_of])
    # only the upper part of a cell column belongs to a taller object: low points stay ambiguous,
    # so each point is assigned by the level of its own cell's top (sides and caps move together)
    sizes = np.bincount(level)
    if (sizes[sizes > 0] < config.min_cluster_points).any():
        return np.zeros(len(points), dtype=int)
    return level


def cluster_cloud(cloud: LabelledCloud, config: ClusterConfig | None = None) -> np.ndarray:
    """Cluster id per point (-1 for noise or dropped clusters) from geometry alone.

    Upright objects on the floor never overlap in the floor plane and stand at least the scene's
    minimum gap apart, so DBSCAN on (x, y) with eps below that gap separates them even where their
    3D surfaces nearly touch; a height-aware step then splits clusters whose cells show two
    distinct top heights (objects in contact but of different heights); clusters that are too
    small or too flat are noise.
    """
    config = config or ClusterConfig()
    points = cloud.points
    flat = np.c_[points[:, :2], np.zeros(len(points))]
    coarse = _dbscan(flat, config.eps, config.min_points)
    ids = np.full(len(points), -1, dtype=int)
    next_id = 0
    for c in range(coarse.max() + 1 if len(coarse) else 0):
        members = np.flatnonzero(coarse == c)
        if len(members) < config.min_cluster_points:
            continue
        sub = _split_by_height(points[members], config)
        for s in np.unique(sub):
            part = members[sub == s]
            z = points[part, 2]
            if len(part) < config.min_cluster_points or z.max() - z.min() < config.min_cluster_height:
                continue
            ids[part] = next_id
            next_id += 1
    return ids


def segment_by_cluster(cloud: LabelledCloud, target_label: int | None,
                       config: ClusterConfig | None = None) -> list[Segment]:
    """Segments from `cluster_cloud`, named cluster<k> by centroid x then y; target marked."""
    ids = cluster_cloud(cloud, config)
    groups = [np.flatnonzero(ids == c) for c in range(ids.max() + 1 if len(ids) else 0)]
    groups = [g for g in groups if len(g)]
    centroids = [cloud.points[g, :2].mean(axis=0) for g in groups]
    order = sorted(range(len(groups)), key=lambda k: (round(centroids[k][0], 4),
                                                      round(centroids[k][1], 4)))
    groups = [groups[k] for k in order]
    target_k = None
    if target_label is not None and groups:
        hits = [int(np.count_nonzero(cloud.labels[g] == target_label)) for g in groups]
        if max(hits) > 0:
            target_k = int(np.argmax(hits))
    return [Segment(f"cluster{k}", g, cloud.points[g], is_target=k == target_k)
            for k, g in enumerate(groups)]


def segment(cloud: LabelledCloud, method: str, names: list[str], target_label: int | None,
            config: ClusterConfig | None = None) -> list[Segment]:
    """Dispatch to `segment_by_label` or `segment_by_cluster` by name."""
    if method == "label":
        return segment_by_label(cloud, names, target_label)
    if method == "cluster":
        return segment_by_cluster(cloud, target_label, config)
    raise ValueError(f"unknown segmentation {method!r}: use one of {SEGMENTATIONS}")


def point_iou_matching(truth: list[np.ndarray], found: list[np.ndarray]
                       ) -> tuple[float, list[tuple[int, int, float]]]:
    """Mean point-level IoU of `truth` segments (index arrays) matched one-to-one to `found`.

    Matching maximises total IoU (scipy's linear_sum_assignment); unmatched truth segments count
    as IoU 0. Returns the mean over truth segments and the (truth, found, IoU) matches.
    """
    from scipy.optimize import linear_sum_assignment

    if not truth:
        return 1.0, []
    iou = np.zeros((len(truth), max(len(found), 1)))
    for i, t in enumerate(truth):
        for j, f in enumerate(found):
            inter = len(np.intersect1d(t, f, assume_unique=True))
            iou[i, j] = inter / (len(t) + len(f) - inter) if inter else 0.0
    rows, cols = linear_sum_assignment(-iou)
    matches = [(int(r), int(c), float(iou[r, c])) for r, c in zip(rows, cols) if c < len(found)]
    return float(sum(m[2] for m in matches)) / len(truth), matches
