"""Seeded generator for the paper's scenarios (1, 2, 3, real) and their occluded variants.

Object kinds and size ranges (metres; the gripper stroke is 0.085 with a 0.005 grasp margin, so an
object fits the fingers when its width across the approach is at most 0.080):

- cylinder: radius 0.025-0.035 (50-70 mm across, fits from every angle with >= 10 mm to spare);
- square_pillar: side 0.040-0.055 (diagonal <= 0.078, so it fits at any yaw, if only just);
- rectangular: 0.040-0.050 x 0.105-0.130; only fits when the approach runs within ~15-20 degrees of
  its long axis, so it can be picked from a few of the seven angles (scenario 2's point);
- large: 0.100-0.125 on both sides; wider than the stroke from every angle (scenario 3's point).
Heights are 0.12-0.20 (large 0.15-0.22), below the 0.36 m shelf and above the 0.10 m the camera
needs to see over the front row.

Scenes follow the paper: the target sits in the back half and is only partly visible from the
front (a fraction of its pixels in [min_visible, max_visible], measured on a label image rendered by
`viewpoints.raycast` from the theta = 0 viewpoint); blockers are dropped between it and the front
so that every approach angle is blocked by at least `min_blockers` objects; the remaining objects
fill the shelf at random with at least `min_gap` between footprints.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from tsad_drake.geometry2d import (
    approach_corridor,
    convex_polygon_distance,
    convex_polygons_overlap,
)
from tsad_drake.scenario import ObjectConfig, Scenario, ScenarioError, ShelfConfig, validate
from tsad_drake.viewpoints import CameraConfig, target_visibility

BUILTIN_SCENARIOS = ("1", "2", "3", "real")


@dc.dataclass
class GeneratorConfig:
    """How dense and how hard generated scenes are."""

    num_objects: int = 10  #: objects on the shelf, target included
    num_blockers: tuple[int, int] = (2, 4)  #: range of objects dropped in front of the target
    min_blockers: int = 1  #: every approach angle to the target is blocked by at least this many
    min_visible: float = 0.10  #: smallest visible fraction of the target from the front view
    max_visible: float = 0.75  #: largest visible fraction of the target from the front view
    target_depth_fraction: float = 0.55  #: target centre lies deeper than this fraction of depth
    wall_margin: float = 0.005  #: m, smallest gap between an object and a wall
    max_attempts: int = 400  #: whole-scene attempts before giving up


def scenario_defaults(name: str) -> tuple[ShelfConfig, GeneratorConfig]:
    """Shelf and generator settings of a built-in scenario."""
    if name == "real":
        return (ShelfConfig(depth=0.40, width=0.28, height=0.36),
                GeneratorConfig(num_objects=5, num_blockers=(1, 2)))
    if name in ("1", "2", "3"):
        return ShelfConfig(), GeneratorConfig()
    raise ScenarioError(f"unknown scenario {name!r}: use one of {', '.join(BUILTIN_SCENARIOS)} "
                        "or a scenario YAML file")


def _sample_kind(name: str, index: int, rng: np.random.Generator) -> str:
    """Kind of the index-th non-target object for scenario `name`."""
    if name == "2" and index < 3:
        return "rectangular"
    if name == "3" and index == 0:
        return "large"
    if name == "real" and index == 0:
        return "rectangular"
    return "cylinder" if rng.random() < 0.5 else "square_pillar"


def _sample_object(kind: str, name: str, rng: np.random.Generator) -> ObjectConfig:
    height = rng.uniform(0.12, 0.20)
    if kind == "cylinder":
        return ObjectConfig(name=name, kind=kind, shape="cylinder",
                            size=[rng.uniform(0.025, 0.035), height])
    if kind == "square_pillar":
        side = rng.uniform(0.040, 0.055)
        return ObjectConfig(name=name, kind=kind, shape="box", size=[side, side, height],
                            yaw=rng.uniform(-np.pi / 4, np.pi / 4))
    if kind == "rectangular":
        # long axis roughly along the approach directions so a few angles fit the gripper
        return ObjectConfig(name=name, kind=kind, shape="box",
                            size=[rng.uniform(0.105, 0.130), rng.uniform(0.040, 0.050), height],
                            yaw=rng.uniform(-np.radians(40), np.radians(40)))
    if kind == "large":
        return ObjectConfig(name=name, kind=kind, shape="box",
                            size=[rng.uniform(0.100, 0.125), rng.uniform(0.100, 0.125),
                                  rng.uniform(0.15, 0.22)],
                            yaw=rng.uniform(-np.pi / 4, np.pi / 4))
    raise ScenarioError(f"unknown object kind {kind!r}")


def _fits(obj: ObjectConfig, placed: list[ObjectConfig], shelf: ShelfConfig,
          cfg: GeneratorConfig, min_gap: float) -> bool:
    poly = obj.footprint()
    m = cfg.wall_margin
    if (poly[:, 0].min() < m or poly[:, 0].max() > shelf.depth - m
            or np.abs(poly[:, 1]).max() > shelf.width / 2 - m):
        return False
    for other in placed:
        if convex_polygon_distance(poly, other.footprint()) < min_gap:
            return False
    return True


def _place(obj: ObjectConfig, placed: list[ObjectConfig], shelf: ShelfConfig,
           cfg: GeneratorConfig, min_gap: float, rng: np.random.Generator,
           x_range: tuple[float, float], y_range: tuple[float, float], tries: int = 60) -> bool:
    for _ in range(tries):
        obj.x = float(rng.uniform(*x_range))
        obj.y = float(rng.uniform(*y_range))
        if _fits(obj, placed, shelf, cfg, min_gap):
            placed.append(obj)
            return True
    return False


def target_blockers(scenario: Scenario, theta: float) -> list[int]:
    """Indices of objects whose footprint meets the gripper corridor to the target at theta."""
    target = scenario.object(scenario.target)
    g = scenario.gripper
    corridor = approach_corridor(target.x, target.y, theta, g.swept_half_width, g.finger_reach)
    return [i for i, o in enumerate(scenario.objects)
            if o.name != target.name and convex_polygons_overlap(corridor, o.footprint())]


def generate_scenario(name: str, seed: int, occluded: bool = False,
                      config: GeneratorConfig | None = None,
                      camera: CameraConfig | None = None) -> Scenario:
    """A random scene of built-in scenario `name` ("1", "2", "3" or "real"), reproducible by seed."""
    shelf, default_cfg = scenario_defaults(name)
    cfg = config or default_cfg
    camera = camera or CameraConfig()
    rng = np.random.default_rng([seed, BUILTIN_SCENARIOS.index(name), int(occluded)])
    base = Scenario(name=name, seed=seed, shelf=shelf, occluded=occluded)
    for _ in range(cfg.max_attempts):
        scenario = _attempt(base, cfg, camera, rng, occluded)
        if scenario is not None:
            validate(scenario)
            return scenario
    raise ScenarioError(f"could not generate scenario {name} seed {seed} "
                        f"in {cfg.max_attempts} attempts")


def _attempt(base: Scenario, cfg: GeneratorConfig, camera: CameraConfig,
             rng: np.random.Generator, occluded: bool) -> Scenario | None:
    shelf = base.shelf
    half_w = shelf.width / 2
    target = _sample_object("cylinder" if rng.random() < 0.5 else "square_pillar", "target", rng)
    placed: list[ObjectConfig] = []
    if not _place(target, placed, shelf, cfg, base.min_gap, rng,
                  (cfg.target_depth_fraction * shelf.depth, shelf.depth),
                  (-half_w + 0.06, half_w - 0.06)):
        return None
    others = [_sample_object(_sample_kind(base.name, i, rng), f"obj{i}", rng)
              for i in range(cfg.num_objects - 1)]
    rng.shuffle(others)
    num_blockers = int(rng.integers(cfg.num_blockers[0], cfg.num_blockers[1] + 1))
    for k, obj in enumerate(others):
        if k < num_blockers:  # in front of the target, within an approach corridor
            x_range = (0.0, max(target.x - 0.05, 0.02))
            y_range = (target.y - 0.09, target.y + 0.09)
        else:
            x_range, y_range = (0.0, shelf.depth), (-half_w, half_w)
        if not _place(obj, placed, shelf, cfg, base.min_gap, rng, x_range, y_range):
            return None
    # target last in the object list is confusing in tables: keep generation order, target first
    scenario = dc.replace(base, objects=placed, target="target")
    blockers = [len(target_blockers(scenario, th)) for th in scenario.approach_angles]
    if min(blockers) < cfg.min_blockers:
        return None
    if occluded:
        visible = max(target_visibility(scenario, camera, th) for th in scenario.approach_angles)
        return scenario if visible == 0.0 else None
    visible = target_visibility(scenario, camera, 0.0)
    if not cfg.min_visible <= visible <= cfg.max_visible:
        return None
    return scenario
