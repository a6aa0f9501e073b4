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
import itertools

import numpy as np

from tsad_drake.perception.pointcloud import BACKGROUND_LABEL, LabelledCloud, robust_top

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
    height_step: float = 0.02  #: m, touching objects whose tops differ this much are split
    split_cell: float = 0.004  #: m, grid cell used to find the top height across a cluster
    cap_band: float = 0.006  #: m, points this close below a part's top form its top cap
    min_cap_cells: int = 20  #: a part needs a top cap over this many grid cells to stand alone
    fragment_points: int = 150  #: capless parts smaller than this are fragments of a neighbour
    merge_distance: float = 0.010  #: m, a fragment this close (in xy) to a part joins it
    #: m, a cluster longer (along its principal axis) than this holds several objects and is split
    #: by k-means in the floor plane until no part is (0: never; noisy depth bridges gaps)
    max_object_length: float = 0.0
    max_object_width: float = 0.0  #: m, and likewise a cluster wider than this across its axis
    max_split: int = 4  #: most parts one cluster is split into
    #: m, a flat part (a top seen without its sides: the camera samples a top it sees at a grazing
    #: angle in rows centimetres apart, so the far rows of a long top come apart from the rest)
    #: joins the part whose top is at its height and whose cap comes this close to its own in the
    #: floor plane, when together they are no longer or wider than one object (0: off; needs
    #: `max_object_length` and `max_object_width`)
    top_join_gap: float = 0.0
    top_join_height: float = 0.004  #: m, tops this close in height are one top


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


def _height_levels(points: np.ndarray, config: ClusterConfig) -> np.ndarray:
    """Height level per point of one xy cluster: split where touching objects differ in height.

    Each point takes the top height of its xy grid cell (sides and cap of an object share the
    object's top). Cell tops are chained into groups (sorted tops closer than half a height step);
    groups with too few points are stragglers, and the remaining groups become levels when their
    tops lie at least `height_step` apart. Points get the level their cell top falls into.
    """
    cells = np.floor(points[:, :2] / config.split_cell).astype(np.int64)
    cell_of = np.unique(cells, axis=0, return_inverse=True)[1].ravel()
    top = np.full(cell_of.max() + 1, -np.inf)
    np.maximum.at(top, cell_of, points[:, 2])
    point_top = top[cell_of]
    order = np.sort(point_top)
    breaks = np.flatnonzero(np.diff(order) >= config.height_step / 2)
    groups = np.split(order, breaks + 1)
    kept = [g for g in groups if len(g) >= config.min_cluster_points]
    thresholds = [(low.max() + high.min()) / 2 for low, high in itertools.pairwise(kept)
                  if high.min() - low.max() >= config.height_step / 2
                  and np.median(high) - np.median(low) >= config.height_step]
    return np.searchsorted(np.asarray(thresholds), point_top)


def _has_cap(points: np.ndarray, config: ClusterConfig) -> bool:
    """Whether the points include a top cap: an area of points near their top height."""
    cap = points[points[:, 2] >= points[:, 2].max() - config.cap_band]
    cells = np.unique(np.floor(cap[:, :2] / config.split_cell).astype(np.int64), axis=0)
    return len(cells) >= config.min_cap_cells


def _split_touching(points: np.ndarray, members: np.ndarray, config: ClusterConfig
                    ) -> list[np.ndarray]:
    """Split one xy cluster into objects of distinct heights (indices into `points`).

    Each height level is re-clustered in xy (its objects may only touch through another object);
    the split is kept only when at least two parts show a top cap, and capless parts (occluded
    fragments of a side) join the capped part nearest to them in the floor plane.
    """
    from scipy.spatial import cKDTree

    level = _height_levels(points[members], config)
    if level.max() == 0:
        return [members]
    parts = []
    for lv in np.unique(level):
        sub = members[level == lv]
        sub_ids = _dbscan(np.c_[points[sub, :2], np.zeros(len(sub))], config.eps,
                          config.min_points)
        parts += [sub[sub_ids == k] for k in range(sub_ids.max() + 1)]
    capped = [p for p in parts if len(p) >= config.min_cluster_points
              and _has_cap(points[p], config)]
    if len(capped) < 2:
        return [members]
    owner = np.concatenate([np.full(len(p), k) for k, p in enumerate(capped)])
    tree = cKDTree(points[np.concatenate(capped), :2])
    rest = np.setdiff1d(members, np.concatenate(capped))
    nearest = owner[tree.query(points[rest, :2])[1]] if len(rest) else np.zeros(0, dtype=int)
    return [np.sort(np.concatenate([p, rest[nearest == k]])) for k, p in enumerate(capped)]


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
    coarse = _dbscan(np.c_[points[:, :2], np.zeros(len(points))], config.eps, config.min_points)
    parts = []
    for c in range(coarse.max() + 1 if len(coarse) else 0):
        parts += _split_touching(points, np.flatnonzero(coarse == c), config)
    parts = _absorb_fragments(points, parts, config)
    if config.top_join_gap > 0 and config.max_object_length > 0:
        parts = join_tops(points, parts, config)
    if config.max_object_length > 0:
        parts = [q for p in parts for q in split_oversized(points, p, config)]
    ids = np.full(len(points), -1, dtype=int)
    next_id = 0
    for part in parts:
        z = points[part, 2]
        if len(part) < config.min_cluster_points or z.max() - z.min() < config.min_cluster_height:
            continue
        ids[part] = next_id
        next_id += 1
    return ids


def _absorb_fragments(points: np.ndarray, parts: list[np.ndarray], config: ClusterConfig
                      ) -> list[np.ndarray]:
    """Merge small capless parts (side slivers cut off by sparse sampling) into the nearest part.

    A fragment joins the nearest capped part when it lies within `merge_distance` of it in the
    floor plane; otherwise it stays as it is (and is dropped later if too small).
    """
    from scipy.spatial import cKDTree

    is_fragment = [len(p) < config.fragment_points and not _has_cap(points[p], config)
                   for p in parts]
    whole = [p for p, frag in zip(parts, is_fragment, strict=True) if not frag]
    if not whole or all(not f for f in is_fragment):
        return parts
    owner = np.concatenate([np.full(len(p), k) for k, p in enumerate(whole)])
    tree = cKDTree(points[np.concatenate(whole), :2])
    merged = [list(p) for p in whole]
    kept = []
    for p, frag in zip(parts, is_fragment, strict=True):
        if not frag:
            continue
        dist, nearest = tree.query(points[p, :2])
        if dist.min() <= config.merge_distance:
            merged[owner[nearest[int(np.argmin(dist))]]] += list(p)
        else:
            kept.append(p)
    return [np.sort(np.asarray(m, dtype=int)) for m in merged] + kept


def _extent(xy: np.ndarray) -> tuple[float, float]:
    """Length along the principal axis and width across it of 2-D points (2nd-98th percentile)."""
    centred = xy - xy.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    proj = centred @ axes.T
    lo, hi = np.percentile(proj, [2, 98], axis=0)
    return float(hi[0] - lo[0]), float(hi[1] - lo[1])


def _kmeans(xy: np.ndarray, k: int, iterations: int = 30) -> np.ndarray:
    """Cluster index per point of a deterministic k-means (farthest-point initialisation)."""
    centres = [xy[int(np.argmin(xy[:, 0] + xy[:, 1]))]]
    for _ in range(k - 1):
        d = np.min([np.sum((xy - c) ** 2, axis=1) for c in centres], axis=0)
        centres.append(xy[int(np.argmax(d))])
    centres = np.array(centres)
    assign = np.zeros(len(xy), dtype=int)
    for _ in range(iterations):
        assign = np.argmin(((xy[:, None, :] - centres[None]) ** 2).sum(axis=2), axis=1)
        new = np.array([xy[assign == j].mean(axis=0) if np.any(assign == j) else centres[j]
                        for j in range(k)])
        if np.allclose(new, centres):
            break
        centres = new
    return assign


def _fits_one_object(points: np.ndarray, part: np.ndarray, config: ClusterConfig) -> bool:
    length, width = _extent(points[part, :2])
    return length <= config.max_object_length and width <= config.max_object_width


def join_tops(points: np.ndarray, parts: list[np.ndarray], config: ClusterConfig
              ) -> list[np.ndarray]:
    """Join parts that are one top seen in pieces: a flat part (z range under
    `min_cluster_height`: a top without its sides) or a capless fragment joins the whole part
    (neither) whose top matches its own within `top_join_height` and whose top cap comes within
    `top_join_gap` of it in the floor plane, nearest first, when the two together fit one
    object; repeated until nothing joins (a far row of a top joins once the rows between have).
    What nothing matches stays as it is."""
    from scipy.spatial import cKDTree

    parts = [p for p in parts if len(p)]

    def loose(part: np.ndarray) -> bool:
        return bool(np.ptp(points[part, 2]) < config.min_cluster_height
                    or (len(part) < config.fragment_points and not _has_cap(points[part], config)))

    joined = True
    while joined:
        joined = False
        tops = [robust_top(points[p]) for p in parts]
        caps = [p[points[p, 2] >= t - config.cap_band] for p, t in zip(parts, tops, strict=True)]
        is_loose = [loose(p) for p in parts]
        for k in sorted((k for k in range(len(parts)) if is_loose[k]), key=lambda k: -len(parts[k])):
            tree = cKDTree(points[parts[k], :2])
            best, best_gap = None, config.top_join_gap
            for j, part in enumerate(parts):
                if is_loose[j] or abs(tops[j] - tops[k]) > config.top_join_height:
                    continue
                gap = float(tree.query(points[caps[j], :2])[0].min())
                if gap <= best_gap and _fits_one_object(
                        points, np.concatenate([part, parts[k]]), config):
                    best, best_gap = j, gap
            if best is not None:
                parts[best] = np.sort(np.concatenate([parts[best], parts[k]]))
                del parts[k]
                joined = True
                break
    return parts


def split_oversized(points: np.ndarray, members: np.ndarray, config: ClusterConfig
                    ) -> list[np.ndarray]:
    """`members` as one part, or split into the fewest k-means parts (floor plane) none of which
    is longer or wider than one object can be (objects whose gap the noise bridged)."""
    if len(members) < 2 * config.min_cluster_points or _fits_one_object(points, members, config):
        return [members]
    for k in range(2, config.max_split + 1):
        assign = _kmeans(points[members, :2], k)
        parts = [members[assign == j] for j in range(k)]
        if all(_fits_one_object(points, p, config) for p in parts if len(p)):
            return [p for p in parts if len(p)]
    return [members]


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
