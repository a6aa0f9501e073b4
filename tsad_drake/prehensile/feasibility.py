"""The `net` FeasibilityModel: the prehensile decision network answers the planners' questions.

One network query is (state, object i, approach angle theta) -> whether i fits the stroke and its
corridor misses the walls (`reach`) and, per object j, the probability that j lies in the corridor
(the per-object head; `blocker_set` turns them into R with the calibrated thresholds). From these:

- blockers(state, i)[a]: R_{theta_a, s} for i (the smallest rearrangement set when i is the target);
- pickable(state, i)[a]: reach and no blocker, so theta_pick = a pickable angle;
- state.blockers_at(i, a): R for one angle, one query (what the planners read where they need
  one angle only). Pickability has no one-angle form: `choose_theta_pick` walks about five of the
  seven angles on average (profiled on scenario 1), and `pickable`'s batch of seven costs about
  four single queries on one thread (two on two threads);
- place_options(state, i, theta_pick): theta_place per grid cell. The point-cloud simulation
  proposes cells where i's perceived footprint fits (inside the shelf, clear of the others'
  footprints; the `geometric` model's placement test) with an angle; the network then decides on
  the next state s' whether i is pickable there at that angle (the paper's theta_place from s').

Queries are encoded and run in batches; answers are cached per state key (states are immutable),
so a repeated query inside a search costs a dictionary lookup. Answers are also cached by the
encoded input itself: a query sees only the points in its crop window, so in a state where the
search moved an object outside that window (before and after the move) the input is bit for bit
the one of the parent state, and its answer is reused without a forward pass (exact, not an
approximation). `evaluations` counts forward passes (network evaluations) for throughput
reports, `reused_inputs` the queries answered from an identical input.
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path

import numpy as np
import torch

from tsad_drake.planning.interface import FeasibilityModel, angle_index
from tsad_drake.planning.types import Action, PlanningState, Workspace
from tsad_drake.prehensile import encoding
from tsad_drake.prehensile.network import query_scores

#: states kept in the cache before it is cleared
CACHE_LIMIT = 50_000
#: proposed cells evaluated per batch by `first_place_option` (most proposals are accepted, so
#: a small batch wastes little and runs cheaper per query than single ones)
PLACE_CHUNK = 4


def blocker_set(prob: np.ndarray, index: int, block_threshold: float,
                set_threshold: float) -> frozenset[int]:
    """Objects in the corridor from per-object block probabilities `prob` (queried object
    `index` excluded): the approach collides when the largest probability exceeds
    `block_threshold` (tuned for pickability), and R holds every object above `set_threshold`
    (tuned for exact sets), plus the most likely one when the approach collides, so that
    "pickable" and "R empty" never disagree."""
    p = np.array(prob, dtype=float)
    p[index] = -1.0
    members = set(np.nonzero(p > set_threshold)[0].tolist())
    if len(p) and p.max() > block_threshold:
        members.add(int(p.argmax()))
    return frozenset(members)


class NetFeasibility(FeasibilityModel):
    """FeasibilityModel backed by the prehensile network (weights: the shipped file by default)."""

    name = "net"
    answers_one_cell = True  #: one forward pass per proposed cell (`first_place_option`)

    def __init__(self, workspace: Workspace, weights: str | Path | None = None,
                 batch_size: int = 64, threads: int | None = None,
                 placement_gap: float | None = None) -> None:
        from tsad_drake.planning.feasibility import GeometricFeasibility
        from tsad_drake.planning.pointcloud_sim import PERCEIVED_PLACEMENT_GAP
        from tsad_drake.prehensile.checkpoint import load_checkpoint

        self.workspace = workspace
        self.net, self.meta = load_checkpoint(weights)  # WeightsError (a UsageError) on bad files
        self.batch_size = batch_size
        #: decision thresholds calibrated by `tsad train` on fresh scenes (defaults: logit 0, p 0.5)
        self.reach_threshold = float(self.meta.get("reach_threshold", 0.0))
        self.block_threshold = float(self.meta.get("block_threshold", 0.5))
        self.set_threshold = float(self.meta.get("set_threshold", self.block_threshold))
        if threads is not None:
            torch.set_num_threads(threads)
        gap = PERCEIVED_PLACEMENT_GAP if placement_gap is None else placement_gap
        self.placement_model = GeometricFeasibility(workspace, gap)
        self.placement_gap = gap
        #: state key -> {(object, angle index): (reach, blockers)}
        self._answers: dict[tuple, dict[tuple[int, int], tuple[bool, frozenset[int]]]] = {}
        self._clouds: dict[tuple, encoding.StateCloud] = {}
        self._place_memo: dict[tuple, np.ndarray] = {}
        #: digest of an encoded input -> its answer (reach, blockers)
        self._by_input: dict[bytes, tuple[bool, frozenset[int]]] = {}
        #: angle index at which the target's R was asked last (`blockers_at`): a placement's next
        #: state s' is usually the next search node, whose reward asks exactly that query, so
        #: `first_place_option` runs it in the placement's batch (a batching hint: no answer
        #: depends on it)
        self._target_angle: int | None = None
        self.evaluations = 0  #: network queries run (cache misses)
        self.reused_inputs = 0  #: queries answered from an identical encoded input
        self.network_seconds = 0.0  #: wall time spent encoding and running them

    # -- batched core --------------------------------------------------------------------------
    def _cloud(self, state: PlanningState) -> encoding.StateCloud:
        key = state.key()
        cloud = self._clouds.get(key)
        if cloud is None:
            cloud = self._clouds[key] = encoding.state_cloud(state, self.workspace)
        return cloud

    def evaluate(self, requests: list[tuple[PlanningState, int, int]]) -> None:
        """Run every uncached (state, object index, angle index) request, in batches."""
        if len(self._answers) > CACHE_LIMIT:
            self._answers.clear()
            self._clouds.clear()
            self._place_memo.clear()
            self._by_input.clear()
        todo, seen = [], set()
        for state, i, k in requests:
            key = state.key()
            if (i, k) in self._answers.get(key, {}) or (key, i, k) in seen:
                continue
            seen.add((key, i, k))
            todo.append((state, i, k))
        if not todo:
            return
        start = time.perf_counter()
        thetas = self.workspace.approach_angles
        run: dict[bytes, tuple] = {}  # new inputs: digest -> (request, encoded input)
        digests = []
        for s, i, k in todo:
            encoded = encoding.encode_query(self._cloud(s), i, float(thetas[k]), k)
            digest = hashlib.blake2b(b"".join(a.tobytes() for a in encoded), digest_size=16).digest()
            digests.append(digest)
            if digest not in self._by_input and digest not in run:
                run[digest] = ((s, i, k), encoded)
        items = list(run.items())
        for first in range(0, len(items), self.batch_size):
            chunk = items[first:first + self.batch_size]
            xy, feats, ids = (np.stack(p) for p in zip(*(enc for _, (_, enc) in chunk)))
            num = max(len(s.objects) for _, ((s, _, _), _) in chunk)
            reach, prob = query_scores(self.net, xy, feats, ids, [i for _, ((_, i, _), _) in chunk],
                                       num)
            prob = prob.numpy()
            for row, (digest, ((s, i, _), _)) in enumerate(chunk):
                blockers = blocker_set(prob[row, :len(s.objects)], i, self.block_threshold,
                                       self.set_threshold)
                self._by_input[digest] = (bool(reach[row] > self.reach_threshold), blockers)
        for (s, i, k), digest in zip(todo, digests):
            self._answers.setdefault(s.key(), {})[(i, k)] = self._by_input[digest]
        self.evaluations += len(run)
        self.reused_inputs += len(todo) - len(run)
        self.network_seconds += time.perf_counter() - start

    def _object_answers(self, state: PlanningState, index: int) -> list[tuple[bool, frozenset[int]]]:
        num_angles = len(self.workspace.approach_angles)
        self.evaluate([(state, index, k) for k in range(num_angles)])
        answers = self._answers[state.key()]
        return [answers[(index, k)] for k in range(num_angles)]

    def evaluate_all(self, state: PlanningState) -> None:
        """Answer every (object, angle) of `state` in one batch (prefetch for planners)."""
        num_angles = len(self.workspace.approach_angles)
        self.evaluate([(state, i, k) for i in range(len(state.objects)) for k in range(num_angles)])

    # -- FeasibilityModel ----------------------------------------------------------------------
    def blockers(self, state: PlanningState, index: int) -> list[frozenset[int]]:
        """Per approach angle, the objects the network puts in the corridor to object `index`."""
        return [b for _, b in self._object_answers(state, index)]

    def blockers_at(self, state: PlanningState, index: int, k: int) -> frozenset[int]:
        """R_{theta_k,s} for object `index`: one network query (cached)."""
        if index == state.target_index:
            self._target_angle = k
        self.evaluate([(state, index, k)])
        return self._answers[state.key()][(index, k)][1]

    def reachable(self, state: PlanningState, index: int) -> np.ndarray:
        """(A,) the network says object `index` fits the stroke and its corridor misses the walls."""
        return np.array([r for r, _ in self._object_answers(state, index)], dtype=bool)

    def unreachable_detail(self, state: PlanningState, index: int) -> str:
        """The perceived footprint's reading (the placement model's), when it agrees."""
        if self.placement_model.reachable(state, index).any():
            return ""
        return "perceived footprint: " + self.placement_model.unreachable_detail(state, index)

    def pickable(self, state: PlanningState, index: int) -> np.ndarray:
        """(A,) reachable and no blocker, per approach angle."""
        return np.array([r and not b for r, b in self._object_answers(state, index)], dtype=bool)

    def pickable_at(self, state: PlanningState, index: int, k: int) -> bool:
        """Reachable with no blocker at angle k: one network query (cached)."""
        request = (state, index, k)
        self.evaluate([request])
        return self._pickable_answer(request)

    def place_options(self, state: PlanningState, index: int, theta_pick: float) -> np.ndarray:
        """(C,) theta_place per grid cell for object `index` picked at theta_pick; nan where none.

        Cells and a candidate angle come from the point-cloud placement test (footprint fits, the
        least rotation that the perceived geometry allows); the network keeps the cell when object
        `index` is pickable at that angle in the simulated next state s'.
        """
        memo_key = (state.key(), index, round(float(theta_pick), 9))
        if memo_key in self._place_memo:
            return self._place_memo[memo_key]
        proposal = self.placement_model.place_options(state, index, theta_pick)
        cells = np.nonzero(~np.isnan(proposal))[0]
        requests = [self._place_request(state, index, theta_pick, c, proposal[c]) for c in cells]
        self.evaluate(requests)
        result = np.full(len(self.workspace.cell_centres), np.nan)
        for c, request in zip(cells, requests):
            if self._pickable_answer(request):
                result[c] = proposal[c]
        self._place_memo[memo_key] = result
        return result

    def first_place_option(self, state: PlanningState, index: int, theta_pick: float,
                           cells: list[int]) -> tuple[int, float] | None:
        """The first of `cells` (in that order) where `place_options` would allow the placement,
        with its theta_place, querying the network for `PLACE_CHUNK` proposed cells at a time
        (with, in the same batch, the target's R in each next state at the angle last asked:
        the reward of the node the placement makes, one forward pass fewer when it is asked)."""
        proposal = self.placement_model.place_options(state, index, theta_pick)
        proposed = [c for c in cells if not np.isnan(proposal[c])]
        k = self._target_angle
        for first in range(0, len(proposed), PLACE_CHUNK):
            chunk = proposed[first:first + PLACE_CHUNK]
            requests = [self._place_request(state, index, theta_pick, c, proposal[c]) for c in chunk]
            companions = [] if k is None or index == state.target_index else [
                (nxt, nxt.target_index, k) for nxt, _, _ in requests]
            self.evaluate(requests + companions)
            for c, request in zip(chunk, requests):
                if self._pickable_answer(request):
                    return c, float(proposal[c])
        return None

    def _place_request(self, state: PlanningState, index: int, theta_pick: float, cell: int,
                       theta_place: float) -> tuple[PlanningState, int, int]:
        """(s', index, angle index of theta_place): object `index` moved to `cell` in s'."""
        from tsad_drake.planning.pointcloud_sim import simulate_pick_place

        x, y = self.workspace.cell_centres[cell]
        nxt = simulate_pick_place(state, Action(state.objects[index].name, float(theta_pick),
                                                float(x), float(y), float(theta_place)))
        return nxt, index, angle_index(self.workspace.approach_angles, theta_place)

    def _pickable_answer(self, request: tuple[PlanningState, int, int]) -> bool:
        """Reach and no blocker for an evaluated (state, object, angle index) request."""
        state, i, k = request
        reach, blockers = self._answers[state.key()][(i, k)]
        return reach and not blockers

    def rollout_model(self) -> FeasibilityModel:
        """The cheap model TSAD's rollouts draw random actions with (`TSADExtras.fast_rollouts`)."""
        return self.placement_model

    def throughput(self) -> float:
        """Network evaluations per second of network time so far (0 before any)."""
        return self.evaluations / self.network_seconds if self.network_seconds else 0.0
