"""Re-checking and shortening plans on a state, with the feasibility model and the point-cloud simulation.

`replay_plan` re-derives a plan's actions on a state: each object must be pickable (at its recorded
theta_pick, else the nearest angle where it is and the cell admits a placement), each placement
cell valid with a pickable theta_place, the target clear and pickable at theta* at the end, and,
at the end of each sub-search's actions, TSAD's two termination conditions (R shrank, nothing new
in it).

The closed loop uses it to keep the rest of the last plan while a new observation still admits it
(a re-plan would otherwise wander off to a different, often longer plan); `shorten_plan` uses it to
drop actions a search's random rollouts left in a plan (a detour, an object moved twice) while the
plan stays valid, like shortcutting a sampled path, and `regroup` splits the shorter plan into
sub-searches again.
"""

from __future__ import annotations

import dataclasses as dc

from tsad_drake.planning.actions import rederive
from tsad_drake.planning.interface import FeasibilityModel, angle_index
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.types import Action, PlanningState, Workspace


def relocation_key(name: str, x: float, y: float) -> tuple[str, float, float]:
    """What identifies a relocation for exclusion: the object and its placement cell."""
    return (name, round(float(x), 4), round(float(y), 4))


def action_key(action: Action) -> tuple[str, float, float]:
    """`relocation_key` of an action."""
    return relocation_key(action.object, action.x, action.y)


def rearrangement_set(state: PlanningState, feasibility: FeasibilityModel, k: int) -> frozenset[str]:
    """Names in R_{theta_k,s}, the target's blockers at angle k (names compare across states)."""
    return frozenset(state.objects[i].name
                     for i in feasibility.blockers_at(state, state.target_index, k))


def replay_plan(state: PlanningState, actions: list[Action], theta_star: float,
                feasibility: FeasibilityModel, workspace: Workspace,
                groups: bool = True) -> list[Action] | None:
    """`actions` re-derived on `state` (theta_pick / theta_place may change), or None if invalid.

    With `groups` False the termination conditions at the ends of the actions' sub-searches are
    not checked (see `regroup`)."""
    if state.target not in {o.name for o in state.objects}:
        return None
    k = angle_index(workspace.approach_angles, theta_star)
    current, out = state, []
    group_start = rearrangement_set(state, feasibility, k)
    for n, (action, (step, current)) in enumerate(zip(actions, _replayed(
            state, actions, feasibility, workspace))):
        out.append(step)
        if groups and (n + 1 == len(actions) or actions[n + 1].sub_search != action.sub_search):
            now = rearrangement_set(current, feasibility, k)
            if not (now < group_start):  # termination conditions: R shrank, nothing new in it
                return None
            group_start = now
    if len(out) < len(actions):
        return None
    t = current.target_index
    if feasibility.blockers(current, t)[k] or not feasibility.pickable(current, t)[k]:
        return None
    return out


def _replayed(state: PlanningState, actions: list[Action], feasibility: FeasibilityModel,
              workspace: Workspace):
    """(re-derived action, state after it) for each of `actions` in turn, ending before the
    first one `feasibility` refuses or that moves the target or an object not in `state`:
    the search's own rule (the pick angle nearest the recorded one that reaches the cell; a
    cell where the object already is is no move: a merge of two moves can end there)."""
    names = {o.name for o in state.objects}
    current = state
    for action in actions:
        if action.object not in names or action.object == state.target:
            return
        redone = rederive(feasibility, current, action, workspace, action.theta_pick)
        if redone is None:
            return
        step = dc.replace(redone, sub_search=action.sub_search)
        current = simulate_pick_place(current, step)
        yield step, current


def certified_prefix(state: PlanningState, actions: list[Action],
                     feasibility: FeasibilityModel, workspace: Workspace) -> list[Action]:
    """The longest prefix of `actions` that `feasibility` accepts from `state`, each action
    re-derived as `replay_plan` re-derives it (sub-search labels kept)."""
    return [step for step, _ in _replayed(state, actions, feasibility, workspace)]


def regroup(state: PlanningState, actions: list[Action], theta_star: float,
            feasibility: FeasibilityModel, workspace: Workspace) -> list[Action] | None:
    """`actions` with sub-search labels that meet TSAD's termination conditions: a sub-search
    ends at the first state whose R_{theta*} is a proper subset of R at its start (some member
    left, nothing new came in). Any plan that clears the target splits this way (the paper's
    Theorem 1 argument); None when actions trail after the last such state."""
    k = angle_index(workspace.approach_angles, theta_star)
    current, start, group, out = state, rearrangement_set(state, feasibility, k), 0, []
    for action in actions:
        current = simulate_pick_place(current, action)
        out.append(dc.replace(action, sub_search=group))
        now = rearrangement_set(current, feasibility, k)
        if now < start:
            group, start = group + 1, now
    return out if not actions or out[-1].sub_search < group else None


def plan_still_valid(state: PlanningState, actions: list[Action], theta_star: float,
                     feasibility: FeasibilityModel, workspace: Workspace) -> bool:
    """Whether `actions` from `state` are each feasible and leave the target pickable at theta*."""
    return replay_plan(state, actions, theta_star, feasibility, workspace) is not None


def _candidates(actions: list[Action]):
    """Shorter variants of a plan, two actions shorter first: two actions dropped (a move there
    and back among them: merging those would be a move to where the object already is, which is
    no action), one action dropped, or an object's two moves made one."""
    for i in range(len(actions)):
        for j in range(i + 1, len(actions)):
            yield actions[:i] + actions[i + 1:j] + actions[j + 1:]
    for i in range(len(actions)):
        yield actions[:i] + actions[i + 1:]
    for i in range(len(actions)):
        for j in range(i + 1, len(actions)):
            if actions[j].object == actions[i].object:
                merged = dc.replace(actions[i], x=actions[j].x, y=actions[j].y)
                yield actions[:i] + [merged] + actions[i + 1:j] + actions[j + 1:]


def shorten_plan(state: PlanningState, actions: list[Action], theta_star: float,
                 feasibility: FeasibilityModel, workspace: Workspace,
                 excluded: frozenset[tuple[str, float, float]] = frozenset()) -> list[Action]:
    """Greedily drop or merge actions while the plan stays valid; `actions` if none can go.

    A shorter plan only has to be feasible and clear the target: its sub-search labels are
    derived afresh (`regroup`), so an action can go even when the search's own split of the
    plan needed it. A shortened plan holds no `excluded` relocation (see `action_key`); a merge
    could make one.
    """
    current = actions
    improved = True
    while improved and current:
        improved = False
        for candidate in _candidates(current):
            if any(action_key(a) in excluded for a in candidate):
                continue
            replayed = replay_plan(state, candidate, theta_star, feasibility, workspace,
                                   groups=False)
            if replayed is not None:
                replayed = regroup(state, replayed, theta_star, feasibility, workspace)
            if replayed is not None:
                current, improved = replayed, True
                break
    return current
