"""Whether a perceived problem can be solved at all, decided before (and between) searches.

A pick-and-place moves an object only after picking it where it stands, and an object blocks
another's approach corridor only by standing in it. So removing objects is the best any
rearrangement can do for a corridor: if no remove-only sequence frees the target, no plan of
relocations does either. `freeable` is that sequence's reach (the least fixed point of "object i
can be taken out at some angle it is reachable at once every blocker there can be taken out"),
read off the model's answers in the state as it is. For the footprint models (corridor tests
between pairs of footprints) the verdict is exact; for a model that answers from the whole
scene (the network) it is the model's own reading of the current state.

The typical unsolvable perception: segmentation cut one object into two pieces whose hulls
overlap, so each lies in the other's corridor at every angle and neither can ever be picked
(`mutually_blocking`). A round on such a state ends at once with the reason instead of searching
until its budget is spent; the closed loop then observes again.
"""

from __future__ import annotations

import numpy as np

from tsad_drake.planning.interface import FeasibilityModel
from tsad_drake.planning.types import PlanningState


def freeable(state: PlanningState, feasibility: FeasibilityModel) -> set[int]:
    """Indices of the objects that some remove-only sequence can pick (the target included when
    it can be retrieved that way)."""
    feasibility.evaluate_all(state)
    options = []
    for i in range(len(state.objects)):
        reach = np.asarray(feasibility.reachable(state, i), dtype=bool)
        sets = feasibility.blockers(state, i)
        options.append([sets[k] - {i} for k in np.nonzero(reach)[0]])
    free: set[int] = set()
    changed = True
    while changed:
        changed = False
        for i, sets in enumerate(options):
            if i not in free and any(s <= free for s in sets):
                free.add(i)
                changed = True
    return free


def mutually_blocking(state: PlanningState, feasibility: FeasibilityModel,
                      stuck: set[int]) -> list[tuple[int, int]]:
    """Pairs (i, j), i < j, of `stuck` objects each of which blocks the other at every angle it
    is reachable at (two pieces of one object whose hulls overlap, or a real deadlock)."""
    def always(i: int, j: int) -> bool:
        reach = np.asarray(feasibility.reachable(state, i), dtype=bool)
        sets = feasibility.blockers(state, i)
        return bool(reach.any()) and all(j in sets[k] for k in np.nonzero(reach)[0])

    ordered = sorted(stuck)
    return [(i, j) for n, i in enumerate(ordered) for j in ordered[n + 1:]
            if always(i, j) and always(j, i)]


def _ungraspable(state: PlanningState, feasibility: FeasibilityModel, index: int) -> str:
    """"NAME cannot be grasped at any approach angle (why)" for an object reachable nowhere."""
    detail = feasibility.unreachable_detail(state, index)
    return (f"{state.objects[index].name} cannot be grasped at any approach angle"
            + (f" ({detail})" if detail else ""))


def unsolvable_reason(state: PlanningState, feasibility: FeasibilityModel) -> str:
    """"" when some remove-only sequence frees the target, else why none can (one line naming
    the objects): the target reachable at no angle (with the model's reason, e.g. its width
    against the stroke), or its blockers never pickable (those reachable at no angle named with
    their reason, and the mutually blocking pairs)."""
    t = state.target_index
    if np.asarray(feasibility.pickable(state, t), dtype=bool).any():
        return ""  # the cheap case first: nothing to free
    names = [o.name for o in state.objects]
    reach = np.asarray(feasibility.reachable(state, t), dtype=bool)
    if not reach.any():
        return "unsolvable: the target " + _ungraspable(state, feasibility, t)
    free = freeable(state, feasibility)
    if t in free:
        return ""
    stuck = set(range(len(state.objects))) - free - {t}
    sets = feasibility.blockers(state, t)
    fewest = min((sets[k] & stuck for k in np.nonzero(reach)[0]), key=len)
    why = f"unsolvable: no sequence can make {', '.join(names[i] for i in sorted(fewest))} pickable"
    never = [i for i in sorted(fewest)
             if not np.asarray(feasibility.reachable(state, i), dtype=bool).any()]
    if never:
        why += ": " + "; ".join(_ungraspable(state, feasibility, i) for i in never)
    pairs = mutually_blocking(state, feasibility, stuck)
    if pairs:
        why += " (mutually blocking: " + ", ".join(f"{names[i]} and {names[j]}"
                                                   for i, j in pairs) + ")"
    return why
