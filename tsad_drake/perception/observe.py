"""One observation: depth images at every approach angle -> fused cloud -> PerceivedScene.

`observe(station)` renders with the Drake station (the real path); `observe_raycast(scenario)`
renders the same camera with the NumPy ray caster in `tsad_drake.viewpoints` (a fast path for
the planners' tests and benchmarks). Both return the same `Observation`.
"""

from __future__ import annotations

import dataclasses as dc
import math
from typing import Any

import numpy as np

from tsad_drake.geometry2d import convex_polygon_penetration
from tsad_drake.perception.footprint import FootprintConfig, fit_footprint
from tsad_drake.perception.free_space import FreeSpace
from tsad_drake.perception.pointcloud import CloudConfig, LabelledCloud, views_to_cloud
from tsad_drake.perception.pose import PoseConfig, estimate_planar_pose
from tsad_drake.perception.segmentation import ClusterConfig, Segment, segment
from tsad_drake.perception.sensor import SensorConfig, read_depth
from tsad_drake.perception.types import PerceivedObject, PerceivedScene
from tsad_drake.scenario import Scenario
from tsad_drake.viewpoints import CameraConfig, camera_pose, raycast, scenario_prisms


@dc.dataclass
class View:
    """One rendered viewpoint."""

    theta: float  #: rad, approach angle the camera looks along
    depth: np.ndarray  #: (H, W) float32 m, inf where nothing
    label: np.ndarray  #: (H, W) int32 object index, -1 for shelf/background
    X_SC: np.ndarray  #: 4x4 camera pose in S


@dc.dataclass
class PerceptionConfig:
    """Everything the depth -> scene pipeline can be tuned by."""

    cloud: CloudConfig = dc.field(default_factory=CloudConfig)
    cluster: ClusterConfig = dc.field(default_factory=ClusterConfig)
    pose: PoseConfig = dc.field(default_factory=PoseConfig)
    footprint: FootprintConfig = dc.field(default_factory=FootprintConfig)


#: m, floor and wall bands cut under noisy sensing (the shelf's own noisy points stay out)
ROBUST_FLOOR_TOLERANCE = 0.008
ROBUST_WALL_TOLERANCE = 0.006
#: m, depth step beyond which the far side of an edge (flying pixels) is dropped
ROBUST_SHADOW_JUMP = 0.012
#: m, touching objects whose tops differ this much are split (tops are seen from above, where
#: the depth noise moves points mostly sideways: 8 mm splits where 20 mm is needed without it)
ROBUST_HEIGHT_STEP = 0.008
#: m, longest and widest footprint one object has in the built-in scenes (a longer cluster is
#: several objects the noise joined)
ROBUST_MAX_OBJECT_LENGTH = 0.135
ROBUST_MAX_OBJECT_WIDTH = 0.080
#: neighbours of the statistical outlier removal under noisy sensing
ROBUST_OUTLIER_NEIGHBOURS = 12


def perception_config(sensor: SensorConfig | None = None) -> PerceptionConfig:
    """The perception settings for readings of `sensor`: the defaults for an ideal sensor (the
    headline rows' pipeline, unchanged), the noise-robust pipeline otherwise."""
    if sensor is None or sensor.ideal:
        return PerceptionConfig()
    return PerceptionConfig(
        cloud=CloudConfig(floor_tolerance=ROBUST_FLOOR_TOLERANCE,
                          wall_tolerance=ROBUST_WALL_TOLERANCE,
                          outlier_neighbours=ROBUST_OUTLIER_NEIGHBOURS,
                          shadow_jump=ROBUST_SHADOW_JUMP),
        cluster=ClusterConfig(height_step=ROBUST_HEIGHT_STEP,
                              max_object_length=ROBUST_MAX_OBJECT_LENGTH,
                              max_object_width=ROBUST_MAX_OBJECT_WIDTH),
        footprint=FootprintConfig(fitted=True))


@dc.dataclass
class Observation:
    """Per-view images, the fused shelf-free cloud and the segmented scene."""

    views: list[View]
    cloud: LabelledCloud  #: fused, down-sampled, shelf removed, labels from the pixels
    scene: PerceivedScene
    segments: list[Segment]  #: the segments behind scene.objects (indices into `cloud`)
    segmentation: str  #: "label" or "cluster"


def perceive(views: list[View], intrinsics: np.ndarray, scenario: Scenario,
             segmentation: str = "label", config: PerceptionConfig | None = None) -> Observation:
    """Views -> fused cloud -> segments -> planar poses (the renderer-independent pipeline)."""
    config = config or PerceptionConfig()
    cloud = views_to_cloud([(v.depth, v.label, v.X_SC) for v in views], intrinsics,
                           scenario.shelf, config.cloud)
    names = [o.name for o in scenario.objects]
    target_label = names.index(scenario.target) if scenario.target in names else None
    segments = segment(cloud, segmentation, names, target_label, config.cluster)
    free = (FreeSpace([v.depth for v in views], [v.X_SC for v in views], intrinsics)
            if config.footprint.grow_hidden else None)
    objects = [perceived_object(seg.name, seg.points, seg.is_target, config, free)
               for seg in segments]
    if config.footprint.fitted and config.footprint.explained_points > 0:
        objects = join_explained(objects, config.footprint)
    if config.footprint.fitted and config.footprint.join_depth > 0:
        objects = join_interpenetrating(objects, config, free)
    target = next((o.name for o in objects if o.is_target), None)
    return Observation(views, cloud, PerceivedScene(objects, target), segments, segmentation)


def perceived_object(name: str, points: np.ndarray, is_target: bool, config: PerceptionConfig,
                     free: FreeSpace | None) -> PerceivedObject:
    """One segment's object: its planar pose and, with `config.footprint.fitted`, its outline."""
    pose = estimate_planar_pose(points, config.pose)
    if not config.footprint.fitted:
        return PerceivedObject(name, points, pose.x, pose.y, pose.yaw, is_target=is_target,
                               shape=pose.shape, size=tuple(pose.size))
    fit = fit_footprint(points, pose, config.pose, config.footprint, free)
    return PerceivedObject(name, points, fit.x, fit.y, fit.yaw, is_target=is_target,
                           shape=fit.shape, size=tuple(fit.size), outline=fit.outline,
                           uncertainty=fit.uncertainty)


def interpenetration(a: np.ndarray, b: np.ndarray) -> float:
    """m, how deep convex polygons `a` and `b` (counter-clockwise) interpenetrate: the least
    overlap of their projections over every edge normal (<= 0: apart)."""
    return convex_polygon_penetration(a, b, signed=True)


def join_interpenetrating(objects: list[PerceivedObject], config: PerceptionConfig,
                          free: FreeSpace | None) -> list[PerceivedObject]:
    """Join every pair of objects whose fitted outlines interpenetrate deeper than
    `config.footprint.join_depth` into one (points joined, pose and outline fitted again, the
    bigger segment's name, the target if either was), until no such pair is left."""
    objects = list(objects)
    while True:
        pairs = [(interpenetration(a.outline, b.outline), i, j)
                 for i, a in enumerate(objects) for j, b in enumerate(objects[:i])
                 if a.outline is not None and b.outline is not None]
        deep = [p for p in pairs if p[0] > config.footprint.join_depth]
        if not deep:
            return objects
        _, i, j = max(deep)
        a, b = objects[i], objects[j]
        name = a.name if len(a.points) >= len(b.points) else b.name
        joined = perceived_object(name, np.concatenate([a.points, b.points]),
                                  a.is_target or b.is_target, config, free)
        objects = [joined if k == j else o for k, o in enumerate(objects) if k != i]  # j < i


def join_explained(objects: list[PerceivedObject], config: FootprintConfig
                   ) -> list[PerceivedObject]:
    """Join each small object (`explained_points`) whose points a bigger object's fitted outline
    (grown by `explained_margin`) holds to that object: its points are added, its own outline
    goes. The target is never joined away (a neighbour's piece may join it)."""
    from tsad_drake.geometry2d import convex_hull, padded_outline, points_in_polygon

    grown = [None if o.outline is None
             else convex_hull(padded_outline(o.outline, config.explained_margin))
             for o in objects]
    by_size = sorted(range(len(objects)), key=lambda k: len(objects[k].points))
    largest_first = sorted(range(len(objects)), key=lambda k: -len(objects[k].points))
    points = {k: objects[k].points for k in range(len(objects))}
    gone: set[int] = set()
    for k in by_size:
        small = objects[k]
        if len(small.points) >= config.explained_points or small.is_target or grown[k] is None:
            continue
        for j in largest_first:
            big = objects[j]
            if j == k or j in gone or len(big.points) <= len(small.points) or grown[j] is None:
                continue
            inside = points_in_polygon(small.points[:, :2], grown[j])
            if inside.mean() >= config.explained_share:
                points[j] = np.concatenate([points[j], small.points])
                gone.add(k)
                break
    return [dc.replace(o, points=points[k]) for k, o in enumerate(objects) if k not in gone]


def observe_raycast(scenario: Scenario, camera: CameraConfig | None = None,
                    segmentation: str = "label", config: PerceptionConfig | None = None,
                    depth_noise: float = 0.0, noise_seed: int = 0,
                    sensor: SensorConfig | None = None) -> Observation:
    """Observe `scenario` from every approach angle with the NumPy ray caster (no Drake).

    Args:
        depth_noise: m, standard deviation of Gaussian noise added to every finite depth reading
            (a shorthand for `SensorConfig(noise_sigma0=depth_noise)`; ignored with `sensor`).
        noise_seed: seed of the sensor's random effects.
        sensor: the depth sensor model applied to each rendered image (None: `depth_noise` only).
    """
    camera = camera or CameraConfig()
    sensor = sensor if sensor is not None else SensorConfig(noise_sigma0=float(depth_noise))
    prisms = scenario_prisms(scenario)
    rng = np.random.default_rng(noise_seed)
    views = []
    for theta in scenario.approach_angles:
        X_SC = camera_pose(scenario.shelf, camera, float(theta))
        depth, label = raycast(prisms, camera, X_SC)
        views.append(sensed_view(float(theta), depth, label, X_SC, sensor, rng))
    return perceive(views, camera.intrinsics(), scenario, segmentation, config)


def sensed_view(theta: float, depth: np.ndarray, label: np.ndarray, X_SC: np.ndarray,
                sensor: SensorConfig, rng: np.random.Generator) -> View:
    """A View of one rendering as `sensor` reads it (labels cleared where the reading dropped)."""
    read = read_depth(depth, sensor, rng)
    label = np.where(np.isfinite(read), np.asarray(label, dtype=np.int32), -1).astype(np.int32)
    return View(theta, read, label, np.asarray(X_SC, dtype=float))


def station_intrinsics(station: Any, depth_shape: tuple[int, int]) -> np.ndarray:
    """The station camera's 3x3 intrinsics (its `camera` config, else the default camera)."""
    camera = getattr(station, "camera", None)
    if not isinstance(camera, CameraConfig):
        camera = CameraConfig()
    if (camera.height, camera.width) != tuple(depth_shape):
        raise ValueError(f"station depth images are {depth_shape}, camera config says "
                         f"{(camera.height, camera.width)}")
    return camera.intrinsics()


def observe(station: Any, segmentation: str = "label",
            config: PerceptionConfig | None = None, sensor: SensorConfig | None = None,
            noise_seed: int = 0) -> Observation:
    """Observe the station's scene from every approach angle with its Drake renderer.

    Args:
        station: a `MakeStation(scenario)` result: `.scenario`, `.render(theta) -> (depth, label,
            X_SC)`, and optionally `.camera` (a CameraConfig; the default camera otherwise).
        segmentation: "label" (renderer's label image) or "cluster" (point cloud only).
        config: pipeline settings.
        sensor: the depth sensor model applied to each rendering (None: ideal).
        noise_seed: seed of the sensor's random effects.
    """
    scenario = station.scenario
    sensor = sensor or SensorConfig()
    rng = np.random.default_rng(noise_seed)
    views = []
    for theta in scenario.approach_angles:
        depth, label, X_SC = station.render(float(theta))
        views.append(sensed_view(float(theta), depth, label, X_SC, sensor, rng))
    intrinsics = station_intrinsics(station, views[0].depth.shape)
    return perceive(views, intrinsics, scenario, segmentation, config)


def summary_table(scene: PerceivedScene) -> str:
    """A fixed-width table of the perceived objects (name, points, x, y, yaw deg, target)."""
    header = (f"{'name':<12} {'points':>6} {'x [m]':>7} {'y [m]':>7} {'yaw [deg]':>9} "
              f"{'shape':<8} target")
    lines = [header]
    for o in scene.objects:
        lines.append(f"{o.name:<12} {len(o.points):>6d} {o.x:>7.3f} {o.y:>7.3f} "
                     f"{math.degrees(o.yaw):>9.1f} {getattr(o, 'shape', ''):<8} "
                     f"{'*' if o.is_target else ''}")
    if scene.target is None:
        lines.append("(target not seen)")
    return "\n".join(lines)
