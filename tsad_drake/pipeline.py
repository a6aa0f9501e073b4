"""The one composition root: scenario -> observer -> world -> feasibility -> planner -> episode.

`tsad plan`, the bench and Python callers assemble episodes here from names (as on the command
line); everything below takes its collaborators as arguments. The observers live here because
they are the only place where the planner's world touches rendering.
"""

from __future__ import annotations

import dataclasses as dc
from typing import Any

from tsad_drake.execution.episode import run_episode
from tsad_drake.execution.record import EpisodeInfo, EpisodeRecord, MotionVerdict
from tsad_drake.execution.world import GeometricWorld, Observer, World
from tsad_drake.perception.observe import PerceptionConfig, perception_config
from tsad_drake.perception.sensor import SensorConfig
from tsad_drake.perception.types import PerceivedScene
from tsad_drake.planning.feasibility import GeometricFeasibility, OracleFeasibility
from tsad_drake.planning.interface import FeasibilityModel
from tsad_drake.planning.registry import get_planner
from tsad_drake.planning.types import Workspace
from tsad_drake.run_config import RunConfig, config_digest, default_run_config, run_config_record
from tsad_drake.scenario import Scenario
from tsad_drake.station import StationConfig

#: the feasibility models by name (`--feasibility`)
FEASIBILITY_NAMES = ("net", "geometric", "oracle")


def make_feasibility(name: str, scenario: Scenario, workspace: Workspace, sensor: str = "ideal"
                     ) -> FeasibilityModel:
    """The feasibility model called `name`: "oracle" (true shapes from `scenario`), "geometric"
    (perceived point clouds) or "net" (the prehensile network shipped for observations of
    `sensor`, `checkpoint.shipped_weights`; WeightsError if bad)."""
    if name == "oracle":
        return OracleFeasibility(scenario, workspace)
    if name == "geometric":
        return GeometricFeasibility(workspace)
    if name == "net":
        from tsad_drake.prehensile.weights import require_torch, shipped_weights

        require_torch()
        from tsad_drake.prehensile.feasibility import NetFeasibility

        return NetFeasibility(workspace, shipped_weights(sensor))
    raise ValueError(f"unknown feasibility model {name!r}: use one of {', '.join(FEASIBILITY_NAMES)}")


@dc.dataclass(frozen=True)
class EpisodeSettings:
    """How to run an episode (names as on the command line)."""

    planner: str = "tsad"
    feasibility: str = "geometric"
    ablation: str = "none"
    variant: str = "full"  #: full (every extra) | paper (the paper's TSAD exactly); TSAD only
    #: planner config fields set after the variant and the ablation: ((field, value), ...)
    planner_overrides: tuple[tuple[str, Any], ...] = ()
    observer: str = "raycast"  #: raycast (NumPy ray caster) | drake (VTK renders in the station)
    closed_loop: bool = True
    max_actions: int = 12  #: pick-and-places allowed in the episode, random ones included
    segmentation: str = "label"
    motion: bool = False  #: verify each action at the motion level before executing it
    #: geometric (the 2-D corridor rule judges) | physics (every action a Drake contact
    #: simulation; implies the motion level and the Drake observer on the simulated state)
    world: str = "geometric"
    sensor: str = "ideal"  #: ideal (exact rendered depth) | realistic (`perception.sensor`)
    #: sensor fields set after the preset: ((field, value), ...), e.g. (("noise_sigma0", 0.002),)
    sensor_overrides: tuple[tuple[str, float], ...] = ()
    #: every component's settings (`tsad --config`/`--set`); None: the defaults of the names above
    #: with the overrides (`run_config.default_run_config`). When given, the overrides stay empty.
    config: RunConfig | None = None

    def run_config(self) -> RunConfig:
        """The episode's effective config (ValueError on an unknown name or field)."""
        if self.config is not None:
            if self.planner_overrides or self.sensor_overrides:
                raise ValueError("set planner and sensor fields in `config`, not as overrides, "
                                 "when a config is given")
            return self.config
        return default_run_config(self.planner, self.ablation, self.variant, self.sensor,
                                  dict(self.planner_overrides), dict(self.sensor_overrides))

    def sensor_config(self) -> SensorConfig:
        """The episode's sensor model (ValueError on an unknown name or field)."""
        return self.run_config().sensor


class RaycastObserver:
    """Observation with the NumPy ray caster (same camera, same pipeline, no Drake).

    Each call reads the scene afresh through `sensor`: observation k of an episode draws its
    noise from the seed (noise_seed, k), so an episode is repeatable and no two reads agree.
    `perception` defaults to the pipeline for `sensor` (`perception_config`), `station` (whose
    camera is used) to the default station.
    """

    def __init__(self, segmentation: str = "label", sensor: SensorConfig | None = None,
                 noise_seed: int = 0, perception: PerceptionConfig | None = None,
                 station: StationConfig | None = None) -> None:
        self.segmentation = segmentation
        self.sensor = sensor or SensorConfig()
        self.perception = perception or perception_config(self.sensor)
        self.camera = (station or StationConfig()).camera
        self.noise_seed = noise_seed
        self.calls = 0

    def __call__(self, truth: Scenario) -> PerceivedScene:
        from tsad_drake.perception.observe import observe_raycast

        seed = [self.noise_seed, self.calls]
        self.calls += 1
        return observe_raycast(truth, camera=self.camera, segmentation=self.segmentation,
                               sensor=self.sensor, config=self.perception,
                               noise_seed=seed).scene


class DrakeObserver:
    """Observation through the Drake station: built once, objects moved for each new observation
    (noise seeded, configs defaulted as in `RaycastObserver`)."""

    def __init__(self, scenario: Scenario, segmentation: str = "label",
                 sensor: SensorConfig | None = None, noise_seed: int = 0,
                 perception: PerceptionConfig | None = None,
                 station: StationConfig | None = None) -> None:
        from tsad_drake.station import MakeStation

        self.station = MakeStation(scenario, config=station)
        self.segmentation = segmentation
        self.sensor = sensor or SensorConfig()
        self.perception = perception or perception_config(self.sensor)
        self.noise_seed = noise_seed
        self.calls = 0

    def __call__(self, truth: Scenario) -> PerceivedScene:
        from tsad_drake.perception.observe import observe

        self.station.set_objects(truth.objects)
        seed = [self.noise_seed, self.calls]
        self.calls += 1
        return observe(self.station, segmentation=self.segmentation, sensor=self.sensor,
                       config=self.perception, noise_seed=seed).scene


#: the observers by name (`--observer`)
OBSERVER_NAMES = ("drake", "raycast")


def make_observer(name: str, scenario: Scenario, segmentation: str = "label",
                  sensor: SensorConfig | None = None, noise_seed: int = 0,
                  perception: PerceptionConfig | None = None,
                  station: StationConfig | None = None) -> Observer:
    """The observer called `name` (OBSERVER_NAMES) for scenes like `scenario`."""
    if name == "raycast":
        return RaycastObserver(segmentation, sensor, noise_seed, perception, station)
    if name == "drake":
        return DrakeObserver(scenario, segmentation, sensor, noise_seed, perception, station)
    raise ValueError(f"unknown observer {name!r}: use one of {', '.join(OBSERVER_NAMES)}")


#: the worlds an episode can act on (`--world`)
WORLD_NAMES = ("geometric", "physics")


def physics_settings(settings: EpisodeSettings) -> EpisodeSettings:
    """The settings a physics episode runs with: motion level on, Drake observer (ValueError for
    an unknown world)."""
    if settings.world not in WORLD_NAMES:
        raise ValueError(f"unknown world {settings.world!r}: use one of {', '.join(WORLD_NAMES)}")
    if settings.world != "physics":
        return settings
    return dc.replace(settings, motion=True, observer="drake")


def make_world(settings: EpisodeSettings, scenario: Scenario, seed: int = 0) -> World:
    """The world an episode acts on: geometric (with the settings' observer, its sensor noise
    drawn from `seed`) or physics, each built with the settings' config."""
    config = settings.run_config()
    if settings.world == "physics":
        from tsad_drake.physics.world import PhysicsWorld

        return PhysicsWorld(scenario, config.world, settings.segmentation, config.motion,
                            config.station, config.perception, config.sensor, seed)
    return GeometricWorld(scenario, make_observer(settings.observer, scenario,
                                                  settings.segmentation, config.sensor, seed,
                                                  config.perception, config.station))


def initial_rearrangement_set_size(scenario: Scenario) -> int:
    """|R_theta*| on the true scene at the start, theta* = the angle with the fewest blockers."""
    from tsad_drake.scenario_generator import target_blockers

    return min(len(target_blockers(scenario, th)) for th in scenario.approach_angles)


def episode_settings(scenario: Scenario, settings: EpisodeSettings) -> EpisodeSettings:
    """The settings an episode on `scenario` runs with: `physics_settings`, and where the arm is
    in play (motion level, Drake observer), the config's station placed for the shelf
    (`placement.placed_config`; raises PlacementError when no base pose reaches it all)."""
    settings = physics_settings(settings)
    if not (settings.motion or settings.observer == "drake"):
        return settings
    from tsad_drake.placement import placed_config

    return dc.replace(settings, config=placed_config(scenario, settings.run_config()),
                      planner_overrides=(), sensor_overrides=())


def episode_record(scenario: Scenario, seed: int, settings: EpisodeSettings,
                   physics_replay=None) -> EpisodeRecord:
    """Run one episode and return its record; on the physics world, `physics_replay` (a path)
    gets a Meshcat recording of the simulation."""
    settings = episode_settings(scenario, settings)
    config = settings.run_config()
    world = make_world(settings, scenario, seed)
    action_check = None
    if settings.motion:
        from tsad_drake.motion.verify import motion_check

        def action_check(truth: Scenario, action) -> MotionVerdict:
            return MotionVerdict(*motion_check(truth, action, config.motion,
                                               config.station.X_WS(truth.shelf.floor_height)))

    def model(truth: Scenario, workspace: Workspace) -> FeasibilityModel:
        return make_feasibility(settings.feasibility, truth, workspace, settings.sensor)

    planner = get_planner(settings.planner)
    info = EpisodeInfo(settings.ablation, settings.variant, settings.observer, settings.world,
                       settings.sensor, config_digest(config),
                       initial_rearrangement_set_size(scenario))
    record = run_episode(world, planner, model, config.planner, seed,
                         closed_loop=settings.closed_loop,
                         episode=config.episode, max_actions=settings.max_actions,
                         action_check=action_check, feasibility_name=settings.feasibility,
                         info=info)
    if physics_replay is not None and settings.world == "physics":
        world.write_replay(physics_replay)  # a PhysicsWorld (`make_world`)
    return record


def run_settings(scenario: Scenario, seed: int, settings: EpisodeSettings) -> dict:
    """Run one episode and return its JSON row (`EpisodeRecord.to_json`: the plan.json fields
    and the settings it ran with)."""
    return episode_record(scenario, seed, settings).to_json()


def plan_episode(scenario: Scenario, seed: int, settings: EpisodeSettings,
                 out_dir=None, meshcat=None) -> EpisodeRecord:
    """`tsad plan`: one episode on a given scene, as the plan.json record (`to_json` writes it).

    With `settings.motion`, the executed actions are verified again as one continuous motion from
    the ready pose; `motion` holds the segments, and `out_dir` gets `replay.html` (an offline
    Meshcat recording) and `scene.dmd.yaml` (Drake model directives of the scene); a `meshcat`
    given (`tsad plan --meshcat`) records the replay there, live. On the physics world
    `replay.html` is the contact simulation as it ran (what happened), and the verified plan's
    motion is `planned_replay.html` (what was planned).
    """
    physics = out_dir is not None and settings.world == "physics"
    record = episode_record(scenario, seed, settings,
                            physics_replay=out_dir / "replay.html" if physics else None)
    settings = episode_settings(scenario, settings)
    config = settings.run_config()
    if settings.motion:
        from tsad_drake.motion.export import SceneLayout, motion_section, write_scene_directives
        from tsad_drake.motion.replay import write_replay_html
        from tsad_drake.motion.verify import verify_plan

        actions = [a.true_action() for a in record.actions]
        X_WS = config.station.X_WS(scenario.shelf.floor_height)
        motions = verify_plan(scenario, actions, config.motion, X_WS)
        record.motion = motion_section(scenario, motions, SceneLayout(scenario, X_WS))
        if out_dir is not None:
            planned = out_dir / ("planned_replay.html" if physics else "replay.html")
            write_replay_html(scenario, actions, motions, planned, meshcat, X_WS=X_WS)
            write_scene_directives(scenario, out_dir, X_WS)
    record.settings = dc.asdict(dc.replace(settings, config=None))
    del record.settings["config"]  # written whole as `config`
    record.config = run_config_record(config)  #: every setting (`tsad config --dump` prints it)
    return record
