"""Prehensile network data: query encoding (cloud -> fixed-size input) and dataset generation.

One query is (state, object i, approach angle theta). Its input is the state's fused cloud plus the
known side walls, flattened onto an xy grid (2 mm for objects, 5 mm for the walls; max height
kept), moved so object i's estimated centre is the origin and rotated by -theta so the approach
runs along +x, cropped to the window the approach can touch and sampled to `NUM_POINTS` points
(the queried object's, its outermost points across the approach first; then every point in the
corridor; then the rest at random). Per point: xy (m / COORD_SCALE) and features
(height, is-queried-object, is-wall, in-corridor, hull-in-corridor, hull-fits; see NUM_FEATURES).
In-corridor marks the points inside the open
gripper's swept corridor (|y| <= swept half width, x <= finger reach in the approach frame): a
known fact of the gripper, like the walls, so the network need not learn the corridor's edge to
the millimetre from examples and can spend itself on what the points do not show (the hidden
backs of objects, whether the queried object fits the stroke).

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

from tsad_drake.geometry2d import edge_normals, rotation2d, side_wall_polygons
from tsad_drake.planning.feasibility import CORRIDOR_OUTSIDE, polygon_widths
from tsad_drake.planning.pointcloud_sim import HULL_DIRECTIONS, perceived_hull
from tsad_drake.planning.types import Action, PlanningState, PlanObject, Workspace

NUM_POINTS = 256  #: points per query
MAX_QUERY_POINTS = 64  #: at most this many of them from the queried object
QUERY_EDGE_POINTS = 4  #: of those, the queried object's outermost points on each side (across)
#: m, xy cell of the flattening grid for object points. The in-corridor flag is read off the
#: flattened points, so the grid is the flag's error at the corridor's edge: 5 mm (v3) made the
#: flag disagree with the oracle on 0.74% of (query, object) pairs, 2 mm on 0.32% (12 fresh scenes)
GRID = 0.002
WALL_GRID = 0.005  #: m, spacing of the wall samples (areas: a finer grid only adds points)
COORD_SCALE = 0.2  #: m, coordinates are divided by this
HEIGHT_SCALE = 0.2  #: m, heights are divided by this
#: m, crop window in the rotated frame: x in [CROP_BACK, CROP_FRONT], |y| <= CROP_HALF_WIDTH
CROP_BACK, CROP_FRONT, CROP_HALF_WIDTH = -0.60, 0.20, 0.22
WALL_ID = -2  #: object index of wall points
SCENARIO_TYPES = ("1", "2", "3", "real")
#: height, is-query, is-wall, in-corridor (the point), hull-in-corridor (its object's footprint hull:
#: the perceived points completed by reflection through the object's centre, as the geometric
#: model sees it; the hidden back of an object can reach into the corridor), hull-fits (on the
#: queried object's points: its hull's width across the approach fits the stroke)
NUM_FEATURES = 6
SAMPLE_SEED = 1234  #: base seed of the per-query point sampling (deterministic inputs)
SPLITS = ("train", "val", "test")


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


def _flatten(xy: np.ndarray, z: np.ndarray, ids: np.ndarray) -> tuple[np.ndarray, ...]:
    """Keep one point per (object, GRID xy cell): the cell centre and the largest height."""
    if len(xy) == 0:
        return np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64)
    cells = np.floor(xy / GRID).astype(np.int64)
    key = np.stack([ids.astype(np.int64), cells[:, 0], cells[:, 1]], axis=1)
    uniq, inverse = np.unique(key, axis=0, return_inverse=True)
    zmax = np.full(len(uniq), -np.inf)
    np.maximum.at(zmax, inverse.ravel(), z)
    return (uniq[:, 1:] + 0.5) * GRID, zmax, uniq[:, 0]


@dc.dataclass
class StateCloud:
    """A state's points reduced once: (M, 2) xy, (M,) height, (M,) object index (WALL_ID: wall)."""

    xy: np.ndarray
    z: np.ndarray
    ids: np.ndarray
    centres: np.ndarray  #: (N, 2) estimated object centres
    hulls: np.ndarray  #: (N, K, 2) footprint hulls, K = HULL_DIRECTIONS (`padded_hull`)
    hull_normals: np.ndarray  #: (N, K, 2) their edge normals
    hull_low: np.ndarray  #: (N, K) each hull's lowest projection on each of its normals
    hull_high: np.ndarray  #: (N, K) and its highest
    hull_edges: np.ndarray  #: (N, K) False for the padding's zero-length edges
    half_width: float  #: m, the open gripper's swept half width (the corridor)
    max_width: float  #: m, widest object the fingers take (stroke minus grasp margin)
    finger_reach: float  #: m, fingertip sweep past the grasp centre (the corridor's far end)


def wall_points(workspace: Workspace) -> np.ndarray:
    """(W, 2) xy samples of the side walls' footprints on the flattening grid."""
    pts = []
    for poly in side_wall_polygons(workspace.depth, workspace.width, workspace.wall_thickness):
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        xs = np.arange(lo[0], hi[0] + 1e-9, WALL_GRID)
        ys = np.arange(lo[1], hi[1] + 1e-9, WALL_GRID)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        pts.append(np.stack([gx.ravel(), gy.ravel()], axis=1))
    return np.concatenate(pts)


_OBJECT_CLOUDS: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}


def object_cloud(obj: PlanObject) -> tuple[np.ndarray, np.ndarray]:
    """(xy (K, 2), height (K,)) of `obj` flattened on the grid at its perceived pose, then moved
    rigidly with the object: a moved object keeps exactly the points it was perceived with."""
    origin = obj.origin if obj.origin is not None else obj.pose
    key = (obj.name, origin, len(obj.points))
    flat = _OBJECT_CLOUDS.get(key)
    if flat is None:
        if len(_OBJECT_CLOUDS) > 20_000:
            _OBJECT_CLOUDS.clear()
        xy = obj.points[:, :2]
        if obj.moved:  # back to the perceived pose
            xy = (xy - [obj.x, obj.y]) @ rotation2d(origin[2] - obj.yaw).T + origin[:2]
        fxy, fz, _ = _flatten(xy, obj.points[:, 2], np.zeros(len(xy), dtype=np.int64))
        flat = (fxy - origin[:2], fz)  # relative to the perceived centre
        _OBJECT_CLOUDS[key] = flat
    rel, z = flat
    return rel @ rotation2d(obj.yaw - origin[2]).T + [obj.x, obj.y], z


_PADDED_HULLS: dict[tuple, tuple[np.ndarray, ...]] = {}


def padded_hull(obj: PlanObject) -> tuple[np.ndarray, ...]:
    """`perceived_hull` of `obj` at its current pose padded to HULL_DIRECTIONS vertices (the last
    one repeated: a zero-length edge) with its separating-axis data: (vertices (K, 2), edge
    normals (K, 2), the hull's lowest and highest projection on each (K,), which edges are real
    (K,)). Memoised per pose: most objects of a simulated next state have not moved."""
    key = (obj.name, obj.pose, obj.origin, len(obj.points))
    entry = _PADDED_HULLS.get(key)
    if entry is None:
        if len(_PADDED_HULLS) > 50_000:
            _PADDED_HULLS.clear()
        polygon = perceived_hull(obj)
        hull = np.concatenate([polygon, np.repeat(polygon[-1:], HULL_DIRECTIONS - len(polygon), 0)])
        normals = edge_normals(hull)
        proj = normals @ hull.T  # (normal, vertex)
        entry = (hull, normals, proj.min(axis=1), proj.max(axis=1), np.any(normals != 0, axis=1))
        _PADDED_HULLS[key] = entry
    return entry


def hull_arrays(state: PlanningState) -> list[np.ndarray]:
    """`padded_hull` of every object of `state`, stacked field by field ((N, ...) each)."""
    entries = [padded_hull(o) for o in state.objects]
    if not entries:
        return [np.zeros((0, HULL_DIRECTIONS, 2)), np.zeros((0, HULL_DIRECTIONS, 2)),
                np.zeros((0, HULL_DIRECTIONS)), np.zeros((0, HULL_DIRECTIONS)),
                np.zeros((0, HULL_DIRECTIONS), dtype=bool)]
    return [np.stack(field) for field in zip(*entries, strict=True)]


def state_cloud(state: PlanningState, workspace: Workspace) -> StateCloud:
    """The flattened cloud of `state` (objects' current points) plus the side walls."""
    parts = [object_cloud(obj) for obj in state.objects]
    walls = wall_points(workspace)
    xy = [p[0] for p in parts] + [walls]
    z = [p[1] for p in parts] + [np.full(len(walls), 0.25)]
    ids = [np.full(len(p[1]), k) for k, p in enumerate(parts)] + [np.full(len(walls), WALL_ID)]
    return StateCloud(np.concatenate(xy), np.concatenate(z), np.concatenate(ids),
                      np.array([[o.x, o.y] for o in state.objects]).reshape(-1, 2),
                      *hull_arrays(state),
                      workspace.swept_half_width, workspace.stroke - workspace.grasp_margin,
                      workspace.finger_reach)


def hull_hits(cloud: StateCloud, index: int, theta: float) -> np.ndarray:
    """(N,) whether each object's footprint hull meets the approach corridor to object `index`
    at `theta` (False for `index` itself).

    The separating-axis test of `geometry2d.convex_polygons_overlap_pairs` against the corridor
    of `geometry2d.approach_corridor` (touching counts as meeting), with each hull's side of the
    test (its edge normals and its extent along them) precomputed per object pose
    (`padded_hull`): one query is a few products of (N, K) arrays (the generic test: 0.1 ms).
    """
    u = np.array([np.cos(theta), np.sin(theta)])
    v = np.array([-u[1], u[0]])
    back = (cloud.centres[index, 0] + CORRIDOR_OUTSIDE) / max(u[0], 1e-6)
    front, half = cloud.finger_reach, cloud.half_width
    mid = cloud.centres[index] + (front - back) / 2 * u  # the corridor box's centre
    # the corridor's own axes
    along = (cloud.hulls - mid) @ u
    across = (cloud.hulls - mid) @ v
    length = (front + back) / 2
    hits = ((along.min(axis=1) <= length) & (along.max(axis=1) >= -length)
            & (across.min(axis=1) <= half) & (across.max(axis=1) >= -half))
    # the hulls' edge normals: the box's projection against the hull's extent along each
    n = cloud.hull_normals
    centre = n @ mid
    extent = length * np.abs(n @ u) + half * np.abs(n @ v)
    apart = (centre - extent > cloud.hull_high) | (centre + extent < cloud.hull_low)
    hits &= ~np.any(apart & cloud.hull_edges, axis=1)
    hits[index] = False
    return hits


def encode_query(cloud: StateCloud, index: int, theta: float,
                 angle_index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Input of query (object `index`, approach `theta`).

    Returns:
        xy (NUM_POINTS, 2) float32 scaled coordinates, feats (NUM_POINTS, 4) float32,
        ids (NUM_POINTS,) int64 object index per point (WALL_ID for walls).
    """
    c, s = np.cos(theta), np.sin(theta)
    rel = cloud.xy - cloud.centres[index]
    rot = np.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], axis=1)
    keep = ((rot[:, 0] >= CROP_BACK) & (rot[:, 0] <= CROP_FRONT)
            & (np.abs(rot[:, 1]) <= CROP_HALF_WIDTH))
    is_query = cloud.ids == index
    in_corridor = (np.abs(rot[:, 1]) <= cloud.half_width) & (rot[:, 0] <= cloud.finger_reach)
    rng = np.random.default_rng([SAMPLE_SEED, index, angle_index])
    query = np.nonzero(is_query)[0]  # always kept, even outside the window
    if len(query) > MAX_QUERY_POINTS:
        # its outermost points across the approach first (they decide whether it fits the
        # stroke: a random subset can miss a box's corner by millimetres), then the rest at random
        order = np.argsort(rot[query, 1])
        edges = np.concatenate([order[:QUERY_EDGE_POINTS], order[-QUERY_EDGE_POINTS:]])
        rest = rng.choice(np.delete(np.arange(len(query)), edges),
                          MAX_QUERY_POINTS - len(edges), replace=False)
        query = query[np.concatenate([edges, rest])]
    room = NUM_POINTS - len(query)
    # corridor points first (one per object before the rest, should they not all fit): an
    # object that reaches into the corridor by a few points must not lose them to sampling
    corridor = rng.permutation(np.nonzero(keep & in_corridor & ~is_query)[0])
    _, first = np.unique(cloud.ids[corridor], return_index=True)
    corridor = np.concatenate([corridor[first], np.delete(corridor, first)])[:room]
    others = np.nonzero(keep & ~in_corridor & ~is_query)[0]
    if len(others) > room - len(corridor):
        others = rng.choice(others, room - len(corridor), replace=False)
    chosen = np.concatenate([query, corridor, others]).astype(np.int64)
    if len(chosen) < NUM_POINTS:  # pad by repeating points (max pooling ignores repeats)
        chosen = np.concatenate([chosen, rng.choice(chosen, NUM_POINTS - len(chosen))])
    ids = cloud.ids[chosen]
    hull_flag = np.append(hull_hits(cloud, index, theta), False)[np.where(ids >= 0, ids, -1)]
    fits = polygon_widths(cloud.hulls[index], np.array([theta]))[0] <= cloud.max_width + 1e-9
    feats = np.stack([cloud.z[chosen] / HEIGHT_SCALE, (ids == index).astype(float),
                      (ids == WALL_ID).astype(float), in_corridor[chosen].astype(float),
                      hull_flag.astype(float), ((ids == index) & fits).astype(float)], axis=1)
    return (rot[chosen] / COORD_SCALE).astype(np.float32), feats.astype(np.float32), ids


def encode_batch(cloud: StateCloud, queries: list[tuple[int, int]],
                 thetas: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stacked `encode_query` for (object index, angle index) pairs."""
    parts = [encode_query(cloud, i, float(thetas[k]), k) for i, k in queries]
    return tuple(np.stack(p) for p in zip(*parts))


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


def observe_state(scenario, observer: str) -> PlanningState:
    """Observe `scenario` ("raycast": NumPy ray caster; "drake": the Drake station) -> state."""
    from tsad_drake.perception.observe import observe, observe_raycast
    from tsad_drake.planning.state import state_from_perception

    if observer == "drake":
        from tsad_drake.station import MakeStation

        return state_from_perception(observe(MakeStation(scenario)).scene)
    return state_from_perception(observe_raycast(scenario).scene)


def scene_states(seed: int, observer: str = "raycast", relocations: int = 2,
                 reobserve: bool = True) -> list[tuple[str, PlanningState, object]]:
    """[(kind, state, oracle)] for scene `seed`: observed, relocated, re-observed."""
    from tsad_drake.planning.feasibility import OracleFeasibility
    from tsad_drake.planning.state import make_workspace
    from tsad_drake.scenario_generator import generate_scenario

    name = scenario_type(seed)
    config = training_generator(name)
    scenario = generate_scenario(name, seed, config=config)
    workspace = make_workspace(scenario)
    oracle = OracleFeasibility(scenario, workspace)
    state = observe_state(scenario, observer)
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
        again = observe_state(moved, observer)
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
        np.savez_compressed(path, **{f: getattr(self, f) for f in self.FIELDS})

    @staticmethod
    def load(path: Path) -> Samples:
        with np.load(path) as data:
            return Samples(*[data[f] for f in Samples.FIELDS])

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


def scene_samples(seed: int, observer: str = "raycast", balanced: bool = True) -> Samples | None:
    rng = np.random.default_rng([seed, 99])
    parts = [state_samples(st, orc, seed, kind, balanced, rng)
             for kind, st, orc in scene_states(seed, observer)]
    parts = [p for p in parts if p is not None]
    return Samples.concat(parts) if parts else None


def shard_name(first_seed: int, count: int, observer: str) -> str:
    return f"shard_{observer}_{first_seed:07d}_{count:04d}.npz"


def generate_dataset(out: Path, scenes: int, seed_start: int, observer: str = "raycast",
                     shard_size: int = 20, progress: bool = True) -> dict:
    """Write shards of `shard_size` scenes to `out`; existing shards are kept (resumable).

    Returns a summary (scenes, samples per split, positives, seconds).
    """
    import time

    from tqdm import tqdm

    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    bar = tqdm(total=scenes, desc="dataset scenes", unit="scene", disable=not progress)
    for first in range(seed_start, seed_start + scenes, shard_size):
        count = min(shard_size, seed_start + scenes - first)
        path = out / shard_name(first, count, observer)
        if not path.exists():
            parts = [p for p in (scene_samples(s, observer) for s in range(first, first + count))
                     if p is not None]
            if parts:
                tmp = path.with_suffix(".tmp.npz")
                Samples.concat(parts).save(tmp)
                tmp.replace(path)
        bar.update(count)
    bar.close()
    summary = dataset_summary(out)
    summary["seconds"] = round(time.perf_counter() - start, 1)
    return summary


def load_dataset(directory: Path) -> Samples:
    shards = sorted(Path(directory).glob("shard_*.npz"))
    shards = [s for s in shards if not s.name.endswith(".tmp.npz")]
    if not shards:
        raise FileNotFoundError(f"no dataset shards (shard_*.npz) in {directory}")
    return Samples.concat([Samples.load(s) for s in shards])


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
