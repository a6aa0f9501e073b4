"""Pick-and-place actions: theta_pick / theta_place from a feasibility model (paper IV-D), action sets.

The search picks {n, x, y}; theta_pick is an angle where object n is pickable in s (nearest the
preferred angle, the retrieval angle or 0, among those from which cell (x, y) admits a
placement), theta_place one where the moved object is pickable in the next state s' (least
rotation), as the model's `place_options` answers it for every cell.
"""

from __future__ import annotations

import weakref
from collections.abc import Iterator

import numpy as np

from tsad_drake.planning.interface import FeasibilityModel, approach_order
from tsad_drake.planning.types import Action, PlanningState, Workspace

#: m, a placement this close to the object's current centre is no move at all
SAME_PLACE = 0.01


def pick_angles(feasibility: FeasibilityModel, state: PlanningState, index: int,
                workspace: Workspace, prefer: float = 0.0) -> list[float]:
    """The angles at which object `index` is pickable in `state`, nearest `prefer` first."""
    ok = feasibility.pickable(state, index)
    return [float(workspace.approach_angles[k])
            for k in approach_order(workspace.approach_angles, prefer) if ok[k]]


def choose_theta_pick(feasibility: FeasibilityModel, state: PlanningState, index: int,
                      workspace: Workspace, prefer: float = 0.0) -> float | None:
    """An angle at which object `index` is pickable in `state` (nearest `prefer`), else None."""
    angles = pick_angles(feasibility, state, index, workspace, prefer)
    return angles[0] if angles else None



def object_actions(feasibility: FeasibilityModel, state: PlanningState, index: int,
                   workspace: Workspace, prefer: float = 0.0) -> list[Action]:
    """Every feasible pick-and-place of object `index` to a grid cell (cell order): the cells
    `UntriedActions.check` accepts (the footprint models answer every cell in its first call)."""
    theta_pick, theta_place = move_table(feasibility, state, index, workspace, prefer)
    name, cells = state.objects[index].name, workspace.cell_centres
    return [Action(name, float(theta_pick[c]), float(cells[c, 0]), float(cells[c, 1]),
                   float(theta_place[c])) for c in np.nonzero(~np.isnan(theta_place))[0]]


#: model -> {(state key, object index, prefer): (pick angles, (theta_pick, theta_place) or None)}
_MOVE_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: entries one model's move table keeps before it is cleared
MOVE_TABLE_LIMIT = 200_000
#: [weak reference to the model asked last, its table]: a search asks one model ~10^5 times,
#: and a `WeakKeyDictionary` lookup (a new weak reference per call) was 3% of a plan
_LAST_TABLE: list = [None, None]


def _move_entry(feasibility: FeasibilityModel, state: PlanningState, index: int,
                prefer: float) -> list:
    """The memo entry [pick angles, cell moves or None] of (state, object, prefer) for a model:
    states are immutable and the answers depend on nothing else, so every search node, rollout
    and round asking the same question shares one answer."""
    last, table = _LAST_TABLE
    if last is None or last() is not feasibility or len(table) > MOVE_TABLE_LIMIT:
        table = _MOVE_TABLES.get(feasibility)
        if table is None or len(table) > MOVE_TABLE_LIMIT:
            table = _MOVE_TABLES[feasibility] = {}
        _LAST_TABLE[:] = [weakref.ref(feasibility), table]
    key = (state.key(), index, round(float(prefer), 9))
    entry = table.get(key)
    if entry is None:
        entry = table[key] = [None, None]
    return entry


def cached_pick_angles(feasibility: FeasibilityModel, state: PlanningState, index: int,
                       workspace: Workspace, prefer: float = 0.0) -> list[float]:
    """`pick_angles`, memoised per model, state, object and preferred angle."""
    entry = _move_entry(feasibility, state, index, prefer)
    if entry[0] is None:
        entry[0] = pick_angles(feasibility, state, index, workspace, prefer)
    return entry[0]


def lazy_pick_angles(feasibility: FeasibilityModel, state: PlanningState, index: int,
                     workspace: Workspace, prefer: float = 0.0) -> Iterator[float]:
    """`cached_pick_angles` in order, asking a model that `answers_one_cell` (the network) about
    the angle nearest `prefer` alone first: a caller that takes the first angle it is given
    (`UntriedActions.check`, `random_action`: the first pick angle with a placement wins) costs
    one query instead of a batch of seven when that angle works. The other angles are asked
    in one batch only when the caller wants more. The same angles as `cached_pick_angles`, in
    the same order (a query's answer does not depend on its batch)."""
    entry = _move_entry(feasibility, state, index, prefer)
    if entry[0] is None and feasibility.answers_one_cell:
        first = int(approach_order(workspace.approach_angles, prefer)[0])
        if feasibility.pickable_at(state, index, first):
            yield float(workspace.approach_angles[first])
            yield from cached_pick_angles(feasibility, state, index, workspace, prefer)[1:]
            return
    yield from cached_pick_angles(feasibility, state, index, workspace, prefer)


def move_table(feasibility: FeasibilityModel, state: PlanningState, index: int,
               workspace: Workspace, prefer: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """`cell_moves` of object `index` from its `pick_angles` nearest `prefer` (memoised)."""
    entry = _move_entry(feasibility, state, index, prefer)
    if entry[1] is None:
        angles = cached_pick_angles(feasibility, state, index, workspace, prefer)
        entry[1] = cell_moves(feasibility, state, index, workspace, angles)
    return entry[1]


def cell_moves(feasibility: FeasibilityModel, state: PlanningState, index: int,
               workspace: Workspace, angles: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """(C,) theta_pick and (C,) theta_place per grid cell for moving object `index` (nan where
    move): per cell, the first of the pick `angles` (see `pick_angles`) from which the cell
    admits a placement, from the model's `place_options`; a cell within `SAME_PLACE` of the
    object's centre is no move.

    The object turns with the gripper by theta_place - theta_pick, so the pick angle decides
    which orientations a cell can take it in: a long box that fits a cell only turned by 20
    degrees needs a pick angle 20 degrees from a valid place angle."""
    cells = workspace.cell_centres
    theta_pick = np.full(len(cells), np.nan)
    theta_place = np.full(len(cells), np.nan)
    for angle in angles:
        options = feasibility.place_options(state, index, angle)
        new = np.isnan(theta_place) & np.isfinite(options)
        theta_pick[new], theta_place[new] = angle, options[new]
    obj = state.objects[index]
    same = np.hypot(cells[:, 0] - obj.x, cells[:, 1] - obj.y) < SAME_PLACE
    theta_pick[same] = theta_place[same] = np.nan
    return theta_pick, theta_place




class UntriedActions:
    """A search node's untried actions {n, x, y}: candidates checked when drawn.

    Candidates are (object index, cell) pairs in the caller's order, drawn from the end. A drawn
    candidate becomes an action when the object is pickable (theta_pick, nearest `prefer`), the
    cell is not its current place and the placement is feasible (theta_place); otherwise it is
    dropped and the next one is drawn. Enumerating every feasible action up front costs a
    pickability answer per object and a placement answer per cell (with the network, a forward
    pass each) while progressive widening expands only a few children of most nodes; drawn
    lazily, the feasible actions come out in the same order as a filtered eager list.
    """

    def __init__(self, feasibility: FeasibilityModel, state: PlanningState, workspace: Workspace,
                 candidates: list[tuple[int, int]], prefer: float = 0.0) -> None:
        self.feasibility, self.state, self.workspace, self.prefer = (
            feasibility, state, workspace, prefer)
        self._candidates = candidates
        self._next: Action | None = None

    def cell_moves(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """`cell_moves` of object `index` (memoised per model: `move_table`)."""
        return move_table(self.feasibility, self.state, index, self.workspace, self.prefer)

    def check(self, index: int, cell: int) -> Action | None:
        """The action moving object `index` to cell `cell`, or None when it is infeasible.

        A model that `answers_one_cell` (the network) is asked about this cell only: per pick
        angle in `pick_angles` order, `first_place_option` over [cell], the first answer wins
        (the same action `cell_moves` gives, at one query per pick angle tried instead of one
        per cell and pick angle)."""
        obj = self.state.objects[index]
        x, y = self.workspace.cell_centres[cell]
        if self.feasibility.answers_one_cell:
            if np.hypot(x - obj.x, y - obj.y) < SAME_PLACE:
                return None
            for theta_pick in lazy_pick_angles(self.feasibility, self.state, index,
                                               self.workspace, self.prefer):
                found = self.feasibility.first_place_option(self.state, index, theta_pick, [cell])
                if found is not None:
                    return Action(obj.name, theta_pick, float(x), float(y), float(found[1]))
            return None
        theta_pick, theta_place = self.cell_moves(index)
        if np.isnan(theta_place[cell]):
            return None
        return Action(obj.name, float(theta_pick[cell]), float(x), float(y),
                      float(theta_place[cell]))

    def peek(self) -> Action | None:
        """The next feasible action (drawn, not yet taken), or None when none is left."""
        while self._next is None and self._candidates:
            self._next = self.check(*self._candidates.pop())
        return self._next

    def pop(self) -> Action | None:
        """Take the next feasible action (None when none is left)."""
        action = self.peek()
        self._next = None
        return action

    def discard(self, name: str, x: float, y: float) -> None:
        """Drop the move of object `name` to (x, y) (it was tried another way)."""
        if self._next is not None and (self._next.object, self._next.x, self._next.y) == (name, x, y):
            self._next = None
        cells = self.workspace.cell_centres
        self._candidates = [(i, c) for i, c in self._candidates
                            if not (self.state.objects[i].name == name
                                    and (float(cells[c, 0]), float(cells[c, 1])) == (x, y))]


def rederive(feasibility: FeasibilityModel, state: PlanningState, action: Action,
             workspace: Workspace, prefer: float) -> Action | None:
    """`action`'s object moved to the grid cell nearest its (x, y) in `state`, with theta_pick
    and theta_place chosen as the search chooses them (`UntriedActions.check`: the pickable
    angle nearest `prefer` from which the cell admits a placement), or None when the model
    refuses it (a cell where the object already is included)."""
    cells = workspace.cell_centres
    cell = int(np.argmin(np.hypot(cells[:, 0] - action.x, cells[:, 1] - action.y)))
    return UntriedActions(feasibility, state, workspace, [], prefer).check(
        state.index(action.object), cell)


def random_action(feasibility: FeasibilityModel, state: PlanningState, workspace: Workspace,
                  rng: np.random.Generator, prefer: float = 0.0,
                  among: list[int] | None = None) -> Action | None:
    """A uniformly random feasible action (random object, then random valid cell), or None.

    `among` restricts the objects considered (default: every object but the target). A model
    that `answers_one_cell` (the network) checks cells one at a time in a random order instead
    of all of them: the first valid cell of a random permutation is uniform over the valid ones,
    at a fraction of the queries.
    """
    movable = [i for i, o in enumerate(state.objects) if o.name != state.target]
    if among is not None:
        movable = [i for i in movable if i in among]
    cells = workspace.cell_centres
    for i in rng.permutation(movable):
        if not feasibility.answers_one_cell:
            theta_pick, theta_place = move_table(feasibility, state, int(i), workspace, prefer)
            valid = np.nonzero(~np.isnan(theta_place))[0]
            if len(valid):
                c = valid[int(rng.integers(len(valid)))]
                return Action(state.objects[int(i)].name, float(theta_pick[c]),
                              float(cells[c, 0]), float(cells[c, 1]), float(theta_place[c]))
            continue
        obj = state.objects[int(i)]
        order = [int(c) for c in rng.permutation(len(cells))
                 if np.hypot(cells[c, 0] - obj.x, cells[c, 1] - obj.y) >= SAME_PLACE]
        for theta_pick in lazy_pick_angles(feasibility, state, int(i), workspace, prefer):
            found = feasibility.first_place_option(state, int(i), theta_pick, order)
            if found is not None:
                c, theta_place = found
                return Action(obj.name, theta_pick, float(cells[c, 0]), float(cells[c, 1]),
                              float(theta_place))
    return None
