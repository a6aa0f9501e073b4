"""Prehensile network data: oracle labels, training states and dataset shards.

Labels come from the `oracle` feasibility model (true shapes): `reach` (object i fits the stroke at
theta and its corridor misses the walls), `pickable` (reach and no object in the corridor) and, per
point, whether the object it belongs to is in the blocker set of (i, theta).

Scenes: for seed s, scenario type SCENARIO_TYPES[s % 4] with generator seed s; per scene the
observed state s0, two states after random feasible relocations in the point-cloud simulation
(s1, s2: the moved points the search sees), and the true scene after those moves observed again
(s3: what closed-loop re-observation sees). Split by scene: (seed // 4) % 10 == 8 validation, 9
test, so every scenario type (seed % 4) is in every split.
"""

from __future__ import annotations

import dataclasses as dc
import hashlib
from pathlib import Path

import numpy as np

from tsad_drake.errors import InputFileError
from tsad_drake.outputs import atomic_write
from tsad_drake.planning.types import Action, PlanningState
from tsad_drake.prehensile.encoding import NUM_FEATURES, WALL_ID, encode_batch, state_cloud
from tsad_drake.runtime import show_progress

SCENARIO_TYPES = ("1", "2", "3", "real")
SPLITS = ("train", "val", "test")


@dc.dataclass(frozen=True)
class Sensing:
    """How training and evaluation scenes are observed: the renderer, the depth sensor model
    (`perception.sensor` preset; its noise is drawn per scene seed and state) and the
    segmentation. The default is the shipped weights' data: ray caster, ideal, labels."""

    observer: str = "raycast"  #: raycast (NumPy ray caster) | drake (the Drake station)
    sensor: str = "ideal"  #: ideal | realistic
    segmentation: str = "label"  #: label | cluster
    #: depth frames fused per view (0: the sensor preset's, filled in on construction; the
    #: shipped realistic weights' data took 1)
    frames: int = 0

    def __post_init__(self) -> None:
        from tsad_drake.perception.sensor import sensor_config

        if not self.frames:
            object.__setattr__(self, "frames", sensor_config(self.sensor).frames)

    def sensor_config(self):
        """The `perception.sensor.SensorConfig` of this sensing (ValueError on a bad name)."""
        from tsad_drake.perception.sensor import sensor_config

        return sensor_config(self.sensor, frames=self.frames)

    @property
    def tag(self) -> str:
        """Name part of shard files: the observer alone for the default sensing; fused frames
        (more than one, of a noisy sensor) add `-xN`."""
        if (self.sensor, self.segmentation) == ("ideal", "label"):
            return self.observer
        fused = f"-x{self.frames}" if self.frames > 1 and self.sensor != "ideal" else ""
        return f"{self.observer}-{self.sensor}-{self.segmentation}{fused}"


#: the shipped weights' data: ray caster, ideal sensor, label segmentation
DEFAULT_SENSING = Sensing()




def split_of(seed: int) -> str:
    """Scene-level split: (seed // 4) % 10 == 8 validation, == 9 test, else train. The scenario
    type is seed % 4, so each split holds every type (seed % 10 put scenarios 1 and 3 only in
    validation and 2 and real only in test)."""
    return {8: "val", 9: "test"}.get((seed // len(SCENARIO_TYPES)) % 10, "train")


def scenario_type(seed: int) -> str:
    return SCENARIO_TYPES[seed % len(SCENARIO_TYPES)]


def training_generator(name: str):
    """Generator settings of the training scenes of scenario type `name`: the scenario's own,
    with no solvability check (labels need none, and it is costly), and scenario 1 with the
    generator's default 2-4 blockers, as the shipped weights were trained on before scenario 1's
    bench scenes were calibrated to 2-3 (`SCENARIO1_BLOCKERS`; a superset of them)."""
    from tsad_drake.scenario_generator import GeneratorConfig, scenario_defaults

    config = scenario_defaults(name)[1]
    if name == "1":
        config = dc.replace(config, num_blockers=GeneratorConfig.num_blockers)
    return dc.replace(config, solvable_nodes=0)



# -- labels and states ---------------------------------------------------------------------------
@dc.dataclass
class StateLabels:
    """Oracle answers for every (object, angle) of a state."""

    reach: np.ndarray  #: (N, A) bool
    pickable: np.ndarray  #: (N, A) bool
    blockers: list[list[frozenset[int]]]  #: [i][a] plan-object indices in the corridor


def oracle_labels(oracle, state: PlanningState) -> StateLabels:
    n = len(state.objects)
    return StateLabels(np.array([oracle.reachable(state, i) for i in range(n)]),
                       np.array([oracle.pickable(state, i) for i in range(n)]),
                       [oracle.blockers(state, i) for i in range(n)])


def random_relocation(state: PlanningState, oracle, rng: np.random.Generator) -> PlanningState | None:
    """`state` after one random feasible pick-and-place of a non-target object (oracle-checked)."""
    from tsad_drake.planning.pointcloud_sim import simulate_pick_place

    thetas = oracle.workspace.approach_angles
    order = rng.permutation(len(state.objects))
    for i in order:
        obj = state.objects[i]
        if obj.name == state.target:
            continue
        picks = np.nonzero(oracle.pickable(state, int(i)))[0]
        if len(picks) == 0:
            continue
        theta_pick = float(thetas[rng.choice(picks)])
        places = oracle.place_options(state, int(i), theta_pick)
        cells = np.nonzero(~np.isnan(places))[0]
        if len(cells) == 0:
            continue
        c = int(rng.choice(cells))
        x, y = oracle.workspace.cell_centres[c]
        return simulate_pick_place(state, Action(obj.name, theta_pick, float(x), float(y),
                                                 float(places[c])))
    return None


def true_scene_after(scenario, oracle, state: PlanningState):
    """The scenario with every moved object at its true pose after the simulated moves."""
    poses = {oracle.true_object(o).name: oracle.true_pose(o) for o in state.objects if o.moved}
    objects = [dc.replace(o, x=poses[o.name][0], y=poses[o.name][1], yaw=poses[o.name][2])
               if o.name in poses else o for o in scenario.objects]
    return dc.replace(scenario, objects=objects)


def observe_state(scenario, sensing: Sensing, noise_seed: list[int] | int = 0) -> PlanningState:
    """Observe `scenario` as `sensing` says (perception configured for its sensor) -> state."""
    from tsad_drake.perception.observe import observe, observe_raycast, perception_config
    from tsad_drake.planning.state import state_from_perception

    sensor = sensing.sensor_config()
    kwargs = dict(segmentation=sensing.segmentation, config=perception_config(sensor),
                  sensor=sensor, noise_seed=noise_seed)
    if sensing.observer == "drake":
        from tsad_drake.station import MakeStation

        return state_from_perception(observe(MakeStation(scenario), **kwargs).scene)
    return state_from_perception(observe_raycast(scenario, **kwargs).scene)


def scene_states(seed: int, sensing: Sensing = DEFAULT_SENSING, relocations: int = 2,
                 reobserve: bool = True) -> list[tuple[str, PlanningState, object]]:
    """[(kind, state, oracle)] for scene `seed`: observed, relocated, re-observed."""
    from tsad_drake.planning.feasibility import OracleFeasibility
    from tsad_drake.planning.state import make_workspace
    from tsad_drake.scenes import generate_scenario

    name = scenario_type(seed)
    config = training_generator(name)
    scenario = generate_scenario(name, seed, config=config)
    workspace = make_workspace(scenario)
    oracle = OracleFeasibility(scenario, workspace)
    state = observe_state(scenario, sensing, [seed, 0])
    out = [("observed", state, oracle)]
    rng = np.random.default_rng([seed, 77])
    for _ in range(relocations):
        nxt = random_relocation(state, oracle, rng)
        if nxt is None:
            break
        state = nxt
        out.append(("relocated", state, oracle))
    if reobserve and len(out) > 1:
        moved = true_scene_after(scenario, oracle, state)
        again = observe_state(moved, sensing, [seed, 1])
        out.append(("reobserved", again, OracleFeasibility(moved, workspace)))
    return out


@dc.dataclass
class Samples:
    """Arrays of encoded, labelled queries (one row per query)."""

    xy: np.ndarray  #: (Q, P, 2) float16
    feats: np.ndarray  #: (Q, P, NUM_FEATURES) float16
    point_label: np.ndarray  #: (Q, P) int8: 1 blocker point, 0 other point, -1 ignore (query/wall)
    ids: np.ndarray  #: (Q, P) int8 object index per point (WALL_ID: wall)
    reach: np.ndarray  #: (Q,) bool
    pickable: np.ndarray  #: (Q,) bool
    scene: np.ndarray  #: (Q,) int64 seed
    scenario: np.ndarray  #: (Q,) str scenario type
    kind: np.ndarray  #: (Q,) str state kind
    theta: np.ndarray  #: (Q,) float32 rad

    FIELDS = ("xy", "feats", "point_label", "ids", "reach", "pickable", "scene", "scenario", "kind", "theta")

    @staticmethod
    def concat(parts: list[Samples]) -> Samples:
        return Samples(*[np.concatenate([getattr(p, f) for p in parts]) for f in Samples.FIELDS])

    def save(self, path: Path) -> None:
        """Write the arrays to `path` (.npz) atomically."""
        atomic_write(path, lambda tmp: np.savez_compressed(
            tmp, **{f: getattr(self, f) for f in self.FIELDS}))

    @staticmethod
    def load(path: Path) -> Samples:
        """A shard; InputFileError when it is unreadable, truncated or not a dataset shard."""
        try:
            with np.load(path, allow_pickle=False) as data:
                missing = [f for f in Samples.FIELDS if f not in data.files]
                if missing:
                    raise InputFileError(f"dataset shard {path} lacks {', '.join(missing)}")
                samples = Samples(*[data[f] for f in Samples.FIELDS])
        except InputFileError:
            raise
        except Exception as err:  # noqa: BLE001 - numpy and zipfile raise many kinds for a bad file
            raise InputFileError(f"cannot read dataset shard {path}: "
                                 f"{type(err).__name__}") from None
        problem = samples.problem()
        if problem:
            raise InputFileError(f"dataset shard {path} is malformed: {problem}")
        return samples

    def problem(self) -> str:
        """What is inconsistent in the arrays ("" when nothing): shapes, kinds, finite points."""
        n = len(self.reach) if self.reach.ndim == 1 else -1
        if n < 1 or any(getattr(self, f).ndim < 1 or len(getattr(self, f)) != n
                        for f in self.FIELDS):
            return "every field needs one row per query"
        if (self.xy.ndim != 3 or self.xy.shape[2] != 2 or self.feats.shape[:2] != self.xy.shape[:2]
                or self.feats.ndim != 3 or self.feats.shape[2] != NUM_FEATURES
                or self.point_label.shape != self.xy.shape[:2] or self.ids.shape != self.xy.shape[:2]):
            return "point arrays have the wrong shape"
        numeric = ("xy", "feats", "point_label", "ids", "scene", "theta")
        if not all(np.issubdtype(getattr(self, f).dtype, np.number) for f in numeric):
            return "a numeric field holds something else"
        if not all(np.isfinite(getattr(self, f)).all() for f in ("xy", "feats", "theta")):
            return "points or angles are not finite"
        return ""

    def __len__(self) -> int:
        return len(self.reach)


def point_labels(ids: np.ndarray, index: int, blockers: frozenset[int]) -> np.ndarray:
    lab = np.isin(ids, list(blockers)).astype(np.int8)
    lab[(ids == index) | (ids == WALL_ID)] = -1
    return lab


def state_samples(state: PlanningState, oracle, seed: int, kind: str, balanced: bool,
                  rng: np.random.Generator) -> Samples | None:
    """Encoded, oracle-labelled queries of one state (balanced: every positive, as many negatives)."""
    workspace = oracle.workspace
    thetas = workspace.approach_angles
    labels = oracle_labels(oracle, state)
    pairs = [(i, k) for i in range(len(state.objects)) for k in range(len(thetas))]
    if balanced:
        pos = [p for p in pairs if labels.pickable[p]]
        neg = [p for p in pairs if not labels.pickable[p]]
        take = min(len(neg), max(len(pos), 3))
        neg = [neg[j] for j in rng.choice(len(neg), take, replace=False)] if take else []
        pairs = pos + neg
    if not pairs:
        return None
    cloud = state_cloud(state, workspace)
    xy, feats, ids = encode_batch(cloud, pairs, thetas)
    plab = np.stack([point_labels(ids[q], i, labels.blockers[i][k]) for q, (i, k) in enumerate(pairs)])
    idx = tuple(np.array(pairs).T)
    n = len(pairs)
    return Samples(xy.astype(np.float16), feats.astype(np.float16), plab, ids.astype(np.int8),
                   labels.reach[idx],
                   labels.pickable[idx], np.full(n, seed), np.full(n, scenario_type(seed)),
                   np.full(n, kind), thetas[idx[1]].astype(np.float32))


def scene_samples(seed: int, sensing: Sensing = DEFAULT_SENSING, balanced: bool = True
                  ) -> Samples | None:
    rng = np.random.default_rng([seed, 99])
    parts = [state_samples(st, orc, seed, kind, balanced, rng)
             for kind, st, orc in scene_states(seed, sensing)]
    parts = [p for p in parts if p is not None]
    return Samples.concat(parts) if parts else None


def shard_name(first_seed: int, count: int, sensing: Sensing) -> str:
    return f"shard_{sensing.tag}_{first_seed:07d}_{count:04d}.npz"


def generate_dataset(out: Path, scenes: int, seed_start: int, sensing: Sensing = DEFAULT_SENSING,
                     shard_size: int = 20, progress: bool = True) -> dict:
    """Write shards of `shard_size` scenes to `out`; existing shards are kept (resumable).

    Returns a summary (scenes, samples per split, positives, seconds).
    """
    import time

    from tqdm import tqdm

    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    bar = tqdm(total=scenes, desc="dataset scenes", unit="scene",
               disable=not show_progress(progress))
    for first in range(seed_start, seed_start + scenes, shard_size):
        count = min(shard_size, seed_start + scenes - first)
        path = out / shard_name(first, count, sensing)
        if not path.exists():
            parts = [p for p in (scene_samples(s, sensing) for s in range(first, first + count))
                     if p is not None]
            if parts:
                Samples.concat(parts).save(path)
        bar.update(count)
    bar.close()
    summary = dataset_summary(out)
    summary["seconds"] = round(time.perf_counter() - start, 1)
    return summary


def dataset_shards(directory: Path) -> list[Path]:
    """The shard files of a dataset directory (temporary files of an interrupted run left out)."""
    shards = sorted(Path(directory).glob("shard_*.npz"))
    return [s for s in shards if not s.name.endswith(".tmp.npz")]


def load_dataset(directory: Path) -> Samples:
    """Every shard of `directory`, concatenated; InputFileError when there is none or one is bad."""
    shards = dataset_shards(directory)
    if not shards:
        raise InputFileError(f"no dataset shards (shard_*.npz) in {directory} "
                             "(generate them with `tsad dataset`)")
    parts = [Samples.load(s) for s in shards]
    if len({p.xy.shape[1:] for p in parts}) > 1:
        raise InputFileError(f"the shards in {directory} hold different numbers of points")
    return Samples.concat(parts)


def dataset_summary(directory: Path) -> dict:
    data = load_dataset(directory)
    splits = np.array([split_of(int(s)) for s in data.scene])
    summary = {"scenes": int(len(np.unique(data.scene))), "samples": len(data),
               "positive_fraction": round(float(data.pickable.mean()), 3)}
    for name in SPLITS:
        summary[f"{name}_samples"] = int((splits == name).sum())
    return summary


def dataset_fingerprint(directory: Path) -> str:
    """Short hash of the shard names (which scenes a model was trained on)."""
    names = "\n".join(sorted(p.name for p in Path(directory).glob("shard_*.npz")))
    return hashlib.sha1(names.encode()).hexdigest()[:12]
