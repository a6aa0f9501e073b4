"""The closed loop's re-planning policy: what it remembers between rounds and how it asks again.

Per episode it keeps: relocations excluded for the rest of the episode (one motion planning
refused, or every relocation of a round that brought the scene back to a configuration it was in
before: no progress, and planning on the same observation would repeat it), picks vetoed until
the next executed action (a pick refused at one angle may work at another), the unexecuted rest
of the last plan (reused while a new observation still admits it) and the configurations seen.
The planner's `PlannerSpec` says which of these it takes part in.
"""

from __future__ import annotations

import dataclasses as dc
import time
from typing import Any

import numpy as np

from tsad_drake.planning.interface import FeasibilityModel, angle_index
from tsad_drake.planning.pick_veto import PickVeto
from tsad_drake.planning.plan_check import action_key, replay_plan
from tsad_drake.planning.registry import PlannerSpec
from tsad_drake.planning.solvability import unsolvable_reason
from tsad_drake.planning.types import Action, Plan, PlanningState, Workspace
from tsad_drake.scenario import Scenario

#: (object, x, y) of a relocation, see `plan_check.relocation_key`
RelocationKey = tuple[str, float, float]


def configuration(scene: Scenario) -> frozenset:
    """Every object's position in the true scene, to the millimetre. Not its yaw: an object
    picked and put back where it stood, turned, is no progress either."""
    return frozenset((o.name, round(o.x, 3), round(o.y, 3)) for o in scene.objects)


def reused(pending: Plan, state: PlanningState, feasibility: FeasibilityModel,
           workspace: Workspace, excluded: frozenset[RelocationKey] = frozenset()) -> Plan | None:
    """The rest of the last plan when the new observation still admits it and none of its
    relocations has been excluded since (`excluded`, see `action_key`), else None."""
    start = time.perf_counter()
    if any(action_key(a) in excluded for a in pending.actions):
        return None
    actions = replay_plan(state, pending.actions, pending.theta_star, feasibility, workspace)
    if actions is None:
        return None
    stats = {**pending.stats, "reused": True}
    return dc.replace(pending, actions=actions, planning_time_s=time.perf_counter() - start,
                      stats=stats)


class ReplanningPolicy:
    """One episode's re-planning memory for planner `spec` (see the module docstring)."""

    def __init__(self, spec: PlannerSpec, config: Any, closed_loop: bool, start: Scenario,
                 max_rejections: int = 8, fail_fast: bool = False, lookahead: bool = False,
                 reuse_plans: bool = False) -> None:
        """`lookahead`, `reuse_plans`, `fail_fast`, `max_rejections`: the run's `episode`
        section (`execution.episode.EpisodeConfig`)."""
        if closed_loop and spec.sub_searches and not lookahead:
            config = dc.replace(config, max_sub_searches=1)  # the paper: one sub-search per look
        self.spec, self.config, self.closed_loop = spec, config, closed_loop
        self.max_rejections = max_rejections  #: consecutive rejections that end the episode
        self.excluded: list[RelocationKey] = []
        self.vetoes: set[tuple[str, int]] = set()  #: (object, angle index) ruled out for now
        self.in_a_row = 0  #: rejections since the last executed action
        #: (configuration, actions executed so far) after each round that executed actions
        self.history: list[tuple[frozenset, int]] = [(configuration(start), 0)]
        #: the executed actions as planned: keys come from the exact cell centres (a key made
        #: from a rounded record can round the other way at a 4-decimal tie)
        self.done: list[Action] = []
        self.reuse = closed_loop and spec.reuse and reuse_plans
        self.pending: Plan | None = None  #: the unexecuted sub-searches of the last plan
        #: test solvability before asking a planner that does not itself (`solvability`)
        self.fail_fast = fail_fast and not spec.checks_solvability

    @property
    def withholds_rejected(self) -> bool:
        """A refused action is not executed and the planner asked again (else only recorded)."""
        return self.spec.exclusions

    def model(self, feasibility: FeasibilityModel) -> FeasibilityModel:
        """This round's model: `feasibility` with the vetoed picks ruled out."""
        return PickVeto(feasibility, self.vetoes) if self.vetoes else feasibility

    def plan(self, state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
             rng: np.random.Generator) -> Plan:
        """The rest of the last plan if it still holds, else the planner's new plan."""
        if self.spec.exclusions:
            self.config = dc.replace(self.config, excluded_actions=list(self.excluded))
        plan = (reused(self.pending, state, feasibility, workspace, frozenset(self.excluded))
                if self.pending else None)
        if plan is not None:
            plan.stats = {**plan.stats, "extras_used": {"reuse_plans": 1}}
        else:
            plan = self._unsolvable(state, feasibility) or self.spec.plan(
                state, feasibility, workspace, self.config, rng)
        self.pending = None
        return plan

    def _unsolvable(self, state: PlanningState, feasibility: FeasibilityModel) -> Plan | None:
        """A failed plan naming why no sequence can free the target, when `fail_fast` finds
        none can (the planner is not asked); else None."""
        if not self.fail_fast or not state.target:
            return None
        start = time.perf_counter()
        why = unsolvable_reason(state, feasibility)
        if not why:
            return None
        return Plan(self.spec.name, None, [], False, why, time.perf_counter() - start,
                    {"unsolvable": True, "checked_by": "closed loop"})

    def this_round(self, plan: Plan) -> list[Action]:
        """The actions to execute before observing again (closed loop: the first sub-search's)."""
        if not self.closed_loop:
            return plan.actions
        first = plan.actions[0].sub_search
        todo = [a for a in plan.actions if a.sub_search == first]
        rest = plan.actions[len(todo):]
        if rest and "extras_used" in plan.stats:  # sub-searches planned beyond the one executed
            plan.stats["extras_used"]["lookahead"] = len({a.sub_search for a in rest})
        if self.reuse and plan.success and rest:
            self.pending = dc.replace(plan, actions=rest)
        return todo

    def executed(self, todo: list[Action], count: int, scene: Scenario) -> None:
        """`count` of this round's `todo` were executed and left the true scene `scene`."""
        if count and self.spec.exclusions:
            self.done.extend(todo[:count])
            self.excluded.extend(self._cycle(scene))
        if count < len(todo):
            self.pending = None
        if count:
            self.vetoes, self.in_a_row = set(), 0

    def rejected(self, action: Action, pick_failure: bool, workspace: Workspace) -> bool:
        """Motion planning refused `action`: rule out its pick angle (`pick_failure`) or exclude
        the relocation. True when that makes too many rejections in a row."""
        self.in_a_row += 1
        if pick_failure:
            k = angle_index(workspace.approach_angles, action.theta_pick)
            self.vetoes.add((action.object, k))
        else:
            self.excluded.append(action_key(action))
        return self.in_a_row > self.max_rejections

    def _cycle(self, scene: Scenario) -> list[RelocationKey]:
        """Every relocation executed since the scene was last in configuration `scene`'s (none
        when it is new); records the configuration."""
        now = configuration(scene)
        earlier = next((n for config, n in self.history if config == now), None)
        self.history.append((now, len(self.done)))
        if earlier is None:
            return []
        return [action_key(a) for a in self.done[earlier:]]
