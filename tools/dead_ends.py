"""Why TSAD's sub-searches find no terminal state: observe a generated scene once, plan it, and
print every sub-search that ended without one, with its root's rearrangement set R_{theta*,s}.

    python tools/dead_ends.py --scenario 3 --seed 1001 [--feasibility net] [--set field=value]
        [--limit 5] [--optimal] [--exhaustive]

Per dead end: iterations, root children, then each member of R with its blockers per approach
angle, and each of those blockers with its pickability and its own blockers, on the search's model
and on its rollout model (`TSADExtras.fast_rollouts`; a disagreement means rollouts judge another
problem than the tree). `--optimal` also runs the `optimal` planner (IDA*, pruned to relevant
objects and a few cells each) from the first dead end's root on both models: "no plan" there
suggests the root itself has no solution. `--exhaustive` enumerates every feasible action
sequence from the first dead end's root to the sub-search's depth d_max (breadth first, distinct
states) on both models: no terminal state there proves the sub-search could not have found one
(the dead end is the problem's, not the tree search's); one found is a miss of the search.
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np

from tsad_drake.perception.sensor import sensor_config
from tsad_drake.pipeline import RaycastObserver, make_feasibility
from tsad_drake.planners.optimal import OptimalConfig, plan_optimal
from tsad_drake.planners.tsad.sub_search import SubSearch
from tsad_drake.planning.actions import object_actions
from tsad_drake.planning.interface import FeasibilityModel
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.registry import get_planner, make_config
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.planning.types import Action, PlanningState
from tsad_drake.scenes import generate_scenario


def describe(state: PlanningState, model: FeasibilityModel, k: int) -> list[str]:
    """Lines: R at angle index k, each member's blockers per angle, their pickability and
    blockers."""
    names = [o.name for o in state.objects]
    members = sorted(model.blockers(state, state.target_index)[k])
    lines = [f"  {model.name}: R = {[names[i] for i in members]}"]
    for i in members:
        per_angle = [sorted(names[j] for j in b) for b in model.blockers(state, i)]
        lines.append(f"    {names[i]} pickable {bool(model.pickable(state, i).any())}, "
                     f"blockers per angle {per_angle}")
        for j in sorted(set().union(*model.blockers(state, i)) - {state.target_index}):
            blockers = [sorted(names[m] for m in b) for b in model.blockers(state, j)]
            lines.append(f"      {names[j]} pickable at {model.pickable(state, j).astype(int).tolist()}"
                         f", blockers per angle {blockers}")
    return lines


def terminal_within(search: SubSearch, rollout: bool) -> tuple[list[int], list[Action] | None]:
    """Breadth-first over every feasible pick-and-place from the search's root (distinct states)
    to its depth d_max, on its rollout model (`rollout`) or its own: the number of new
    non-terminal states at each depth, and the first action sequence reaching a state the search
    itself would call terminal (`SubSearch.reward`), or None when no sequence reaches one."""
    model = search.rollout_model if rollout else search.feasibility
    frontier, seen, counts = [(search.root.state, [])], {search.root.state.key()}, []
    for _ in range(search.config.max_depth):
        grown = []
        for state, path in frontier:
            for i, obj in enumerate(state.objects):
                if obj.name == state.target:
                    continue
                for action in object_actions(model, state, i, search.workspace, search.theta):
                    nxt = simulate_pick_place(state, action)
                    if nxt.key() in seen:
                        continue
                    seen.add(nxt.key())
                    if search.reward(nxt, rollout=rollout)[1]:
                        return counts, path + [action]
                    grown.append((nxt, path + [action]))
        counts.append(len(grown))
        frontier = grown
    return counts, None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="3")
    parser.add_argument("--seed", type=int, default=1001)
    parser.add_argument("--feasibility", default="net")
    parser.add_argument("--sensor", default="realistic")
    parser.add_argument("--segmentation", default="cluster")
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--set", action="append", default=[],
                        help="planner field=value, e.g. iteration_budget=3000")
    parser.add_argument("--limit", type=int, default=5, help="dead ends described in full")
    parser.add_argument("--optimal", action="store_true",
                        help="run IDA* from the first dead end's root on both models")
    parser.add_argument("--exhaustive", action="store_true",
                        help="enumerate every action sequence to d_max from the first dead end's "
                             "root on both models (slow on the network)")
    args = parser.parse_args()
    overrides, defaults = {}, make_config("tsad")
    for item in args.set:
        key, _, value = item.partition("=")
        default = getattr(defaults, key, None)
        if isinstance(default, bool) or not isinstance(default, (int, float, str)):
            parser.error(f"--set {item}: not a number or text field of TSADConfig")
        overrides[key] = type(getattr(defaults, key))(value)
    sensor = sensor_config(args.sensor, **({"frames": args.frames} if args.sensor != "ideal" else {}))
    scenario = generate_scenario(args.scenario, args.seed)
    segmentation = args.segmentation if args.sensor != "ideal" else "label"
    state = state_from_perception(RaycastObserver(segmentation, sensor, args.seed)(scenario))
    workspace = make_workspace(scenario)
    model = make_feasibility(args.feasibility, scenario, workspace, args.sensor)

    shapes: Counter[tuple[int, bool]] = Counter()
    run = SubSearch.run

    def observed_run(search: SubSearch, budget) -> None:
        run(search, budget)
        if search.root.has_terminal:
            return
        root, k = search.root.state, search.k
        members = sorted(search.feasibility.blockers(root, root.target_index)[k])
        pickable = any(search.feasibility.pickable(root, i).any() for i in members)
        shapes[(len(members), pickable)] += 1
        if sum(shapes.values()) > args.limit:
            return
        print(f"dead end {sum(shapes.values())}: {search.iterations} iterations, "
              f"{len(search.root.children)} root children, theta* "
              f"{np.degrees(search.theta):+.0f} deg")
        for m in {id(search.feasibility): search.feasibility,
                  id(search.rollout_model): search.rollout_model}.values():
            print("\n".join(describe(root, m, k)))
        if args.exhaustive and sum(shapes.values()) == 1:
            models = {search.rollout_model.name: True, search.feasibility.name: False}
            for name, rollout in models.items():
                counts, path = terminal_within(search, rollout)
                print(f"  exhaustive on {name}, new states per depth {counts}: "
                      + ("no terminal state within d_max" if path is None else
                         "terminal state by " + ", ".join(
                             f"{a.object} -> ({a.x:.3f}, {a.y:.3f})" for a in path)))
        if args.optimal and sum(shapes.values()) == 1:
            for m in (search.rollout_model, search.feasibility):
                plan = plan_optimal(root, m, workspace, OptimalConfig())
                print(f"  optimal on {m.name}: "
                      + (f"{len(plan.actions)} relocations" if plan.success
                         else plan.failure_reason))

    SubSearch.run = observed_run
    try:
        plan = get_planner("tsad").plan(state, model, workspace, make_config("tsad", **overrides),
                                        np.random.default_rng(args.seed))
    finally:
        SubSearch.run = run
    print(f"plan: success {plan.success}, {len(plan.actions)} actions, "
          f"{plan.stats.get('iterations_total')} iterations {plan.failure_reason}")
    print("dead ends by (|R| at the root, a member pickable):", dict(shapes))


if __name__ == "__main__":
    main()
