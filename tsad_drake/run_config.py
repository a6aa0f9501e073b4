"""Every setting of a run in one typed dataclass that loads and dumps as YAML (Drake's typed YAML).

`RunConfig` has one section per component: the planner's config, the closed loop (`episode`), the
depth sensor, perception,
the station (with its camera), the motion planner and the physics world. The selectors of the
command line (`--planner`, `--ablation`, `--variant`, `--sensor`) pick the defaults
(`default_run_config`); a YAML file (`merge_file`, `--config`) then replaces the fields it names,
and `--set section.field=value` (`apply_sets`) replaces single fields after it. Bad input of any
kind is a `UsageError` (one line, exit status 2) raised before any work.

Drake's typed YAML reads each dataclass field's `type`; the config modules use postponed
annotations (strings), so `resolve_field_types` replaces those strings with the types they name,
once, at import. A run-time field such as `TSADConfig.excluded_actions` (filled by the closed
loop) dumps as an empty list.
"""

import dataclasses as dc
import hashlib
import typing

import yaml
from pydrake.common.yaml import yaml_dump, yaml_dump_typed, yaml_load_typed

from tsad_drake.errors import UsageError
from tsad_drake.execution.episode import EpisodeConfig
from tsad_drake.motion.scene import MotionConfig
from tsad_drake.perception.observe import PerceptionConfig, perception_config
from tsad_drake.perception.sensor import SensorConfig, sensor_config
from tsad_drake.physics.config import PhysicsConfig
from tsad_drake.planners.gp3 import GP3Config
from tsad_drake.planners.optimal import OptimalConfig
from tsad_drake.planners.rots import ROTSConfig
from tsad_drake.planners.tsad.config import TSADConfig
from tsad_drake.planning.registry import get_planner, make_config
from tsad_drake.station import StationConfig

#: the planners' config classes (which one `--planner` picks: `planning.registry`)
PlannerConfig = TSADConfig | GP3Config | ROTSConfig | OptimalConfig


@dc.dataclass
class RunConfig:
    """Every setting of one run, by component (the sections of a config file)."""

    planner: PlannerConfig = dc.field(default_factory=TSADConfig)  #: the chosen planner's config
    #: the closed loop: limits, looks again, plan reuse (defaults: the planner's variant's)
    episode: EpisodeConfig = dc.field(default_factory=EpisodeConfig)
    sensor: SensorConfig = dc.field(default_factory=SensorConfig)  #: depth error model
    #: depth -> point cloud -> segments -> poses (defaults follow the sensor: `perception_config`)
    perception: PerceptionConfig = dc.field(default_factory=PerceptionConfig)
    #: the Drake station: robot and shelf placement, the wrist camera (`station.camera`), IK
    station: StationConfig = dc.field(default_factory=StationConfig)
    motion: MotionConfig = dc.field(default_factory=MotionConfig)  #: motion planning, verification
    world: PhysicsConfig = dc.field(default_factory=PhysicsConfig)  #: physics world (--world physics)


#: the sections of a config file, in order
SECTIONS: tuple[str, ...] = tuple(f.name for f in dc.fields(RunConfig))


def resolve_field_types(cls: type) -> None:
    """Give every field of dataclass `cls` (and of the dataclasses it nests) its real type in place
    of a postponed annotation string, as Drake's typed YAML needs."""
    hints = typing.get_type_hints(cls)
    for field in dc.fields(cls):
        field.type = hints[field.name]
        for member in typing.get_args(field.type) or (field.type,):
            if dc.is_dataclass(member) and isinstance(member, type):
                resolve_field_types(member)


resolve_field_types(RunConfig)


def default_run_config(planner: str = "tsad", ablation: str = "none", variant: str = "full",
                       sensor: str = "ideal", planner_overrides: dict | None = None,
                       sensor_overrides: dict | None = None) -> RunConfig:
    """The config the named choices give (ValueError on an unknown name or field): the planner's
    default config in `variant` with `ablation` and `planner_overrides`, the closed loop's
    settings of that variant (`PlannerSpec.episode_variants`), the `sensor` preset with
    `sensor_overrides` and the perception pipeline for that sensor, the other sections' defaults."""
    sensor_settings = sensor_config(sensor, **(sensor_overrides or {}))
    planner_config = make_config(planner, ablation, variant, **(planner_overrides or {}))
    episode = EpisodeConfig(**get_planner(planner).episode_variants.get(variant, {}))
    return RunConfig(planner=planner_config, episode=episode, sensor=sensor_settings,
                     perception=perception_config(sensor_settings))


def _with_nulls(value, plain: dict) -> dict:
    """`plain` (Drake's dump of dataclass `value`) in field order with a null for each field that
    is None (Drake leaves those out, and a file without them would keep non-None defaults)."""
    return {f.name: (_with_nulls(getattr(value, f.name), plain[f.name])
                     if dc.is_dataclass(getattr(value, f.name)) else plain.get(f.name))
            for f in dc.fields(value)}


def run_config_record(config: RunConfig) -> dict:
    """`config` as plain data (dicts, lists, scalars): the sections of its YAML file, also written
    whole into plan.json and bench files."""
    return {name: _with_nulls(getattr(config, name),
                              yaml.safe_load(yaml_dump_typed(getattr(config, name))))
            for name in SECTIONS}


def dump_run_config(config: RunConfig) -> str:
    """`config` as YAML, every field of every section (what `merge_file` reads back to `config`)."""
    return yaml.safe_dump(run_config_record(config), sort_keys=False, default_flow_style=False)


def config_digest(config: RunConfig) -> str:
    """A short fingerprint of `config` (12 hex digits): equal configs, equal digests."""
    return hashlib.sha256(dump_run_config(config).encode()).hexdigest()[:12]


def _validated(value):
    """`value` rebuilt through its dataclass constructors, so their checks (`__post_init__`) run
    on values set by YAML (which assigns fields directly)."""
    if not dc.is_dataclass(value):
        return value
    return type(value)(**{f.name: _validated(getattr(value, f.name))
                          for f in dc.fields(value) if f.init})


def merge(config: RunConfig, data, where: str) -> RunConfig:
    """`config` with the fields named in `data` ({section: {field: value, ...}, ...}) replaced;
    UsageError starting with `where` for an unknown section or field or a value of a wrong type."""
    if not isinstance(data, dict):
        raise UsageError(f"{where}: expected a mapping of sections ({', '.join(SECTIONS)}), "
                         f"got {type(data).__name__}")
    unknown = [str(name) for name in data if name not in SECTIONS]
    if unknown:
        raise UsageError(f"{where}: unknown section(s) {', '.join(unknown)}: sections are "
                         f"{', '.join(SECTIONS)}")
    changes = {}
    for name, section in data.items():
        old = getattr(config, name)
        if not isinstance(section, dict):
            raise UsageError(f"{where}: section {name} must be a mapping of "
                             f"{type(old).__name__} fields")
        try:
            new = yaml_load_typed(schema=type(old), data=yaml_dump({name: section}),
                                  child_name=name, defaults=old)
            changes[name] = _validated(new)
        except AssertionError:  # Drake asserts that a nested dataclass is given a mapping
            raise UsageError(f"{where}: section {name}: a nested config needs a mapping of its "
                             "fields, not a value") from None
        except (RuntimeError, ValueError, TypeError, NotImplementedError) as err:
            message = " ".join(str(err).split())
            if name == "planner" and "unknown to the schema" in message:
                message += " (is it the planner section of another --planner?)"
            raise UsageError(f"{where}: section {name} ({type(old).__name__}): {message}") from None
    return dc.replace(config, **changes)


def merge_file(config: RunConfig, path: str) -> RunConfig:
    """`config` with the fields set in the YAML file `path` replaced (UsageError when the file is
    missing, unreadable, malformed or names an unknown section or field)."""
    try:
        with open(path, encoding="utf-8") as f:
            data = yaml.safe_load(f)
    except OSError as err:
        raise UsageError(f"--config {path}: cannot read it: {err.strerror}") from None
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        raise UsageError(f"--config {path}: not valid YAML: {' '.join(str(err).split())}") from None
    return merge(config, {} if data is None else data, f"--config {path}")


def _field_type(cls: type, path: list[str], text: str) -> None:
    """Check that `path` names a field of dataclass `cls` (nested with dots); UsageError if not."""
    for depth, name in enumerate(path):
        fields = {f.name: f.type for f in dc.fields(cls)} if dc.is_dataclass(cls) else {}
        if name not in fields:
            where = ".".join(path[:depth]) or cls.__name__
            known = ", ".join(fields) if fields else "none (it is a value)"
            raise UsageError(f"--set {text}: unknown field {name!r} in {where}: fields are {known}")
        cls = fields[name]


def apply_sets(config: RunConfig, items: list[str]) -> RunConfig:
    """`config` with each `section.field=value` of `items` applied in turn (nested fields with more
    dots: `station.camera.width=64`); the value is a YAML scalar or flow sequence."""
    for text in items:
        key, sep, value = text.partition("=")
        path = key.strip().split(".")
        if not sep or len(path) < 2 or not all(path):
            raise UsageError(f"--set {text}: expected section.field=value (sections: "
                             f"{', '.join(SECTIONS)})")
        if path[0] not in SECTIONS:
            raise UsageError(f"--set {text}: unknown section {path[0]!r}: sections are "
                             f"{', '.join(SECTIONS)}")
        _field_type(type(getattr(config, path[0])), path[1:], text)
        try:
            parsed = yaml.safe_load(value)
        except yaml.YAMLError as err:
            raise UsageError(f"--set {text}: value is not YAML: {' '.join(str(err).split())}"
                             ) from None
        for name in reversed(path[1:]):
            parsed = {name: parsed}
        config = merge(config, {path[0]: parsed}, f"--set {text}")
    return config
