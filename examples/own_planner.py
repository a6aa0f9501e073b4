"""Plug in a planner of your own: a greedy one, run in a closed-loop episode next to TSAD's world.

Run: python examples/own_planner.py [--scenario 1] [--seed 0]
Or with the command line, which imports this file and finds `greedy` registered:
    tsad --plugin examples/own_planner.py plan --scenario 1 --planner greedy --out out/greedy
    tsad --plugin examples/own_planner.py bench --scenario 1 --planner greedy --episodes 2 \
        --out out/greedy.json
"""

import argparse
import dataclasses as dc

import numpy as np

from tsad_drake.execution.episode import run_episode
from tsad_drake.execution.world import GeometricWorld
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.pipeline import make_feasibility
from tsad_drake.planning.actions import object_actions
from tsad_drake.planning.interface import FeasibilityModel
from tsad_drake.planning.pointcloud_sim import simulate_pick_place
from tsad_drake.planning.registry import PlannerSpec, register
from tsad_drake.planning.types import Plan, PlanningState, Workspace
from tsad_drake.scenes import generate_scenario


@dc.dataclass
class GreedyConfig:
    """The greedy planner's settings (`tsad config --planner greedy --dump` prints them)."""

    max_moves: int = 8  #: relocations it tries before giving up


def plan_greedy(state: PlanningState, feasibility: FeasibilityModel, workspace: Workspace,
                config: GreedyConfig, rng: np.random.Generator) -> Plan:
    """Retrieve along the angle with the fewest blockers; move blockers one by one, each to the
    first cell that leaves fewer of them."""
    target = state.target_index
    k = int(np.argmin([len(b) for b in feasibility.blockers(state, target)]))
    actions = []
    for _ in range(config.max_moves):
        blocking = feasibility.blockers_at(state, target, k)
        if not blocking:
            return Plan("greedy", float(workspace.approach_angles[k]), actions, True)
        better = [a for i in sorted(blocking) for a in object_actions(feasibility, state, i, workspace)
                  if len(feasibility.blockers_at(simulate_pick_place(state, a), target, k))
                  < len(blocking)]
        if not better:
            break
        actions.append(better[0])
        state = simulate_pick_place(state, better[0])
    return Plan("greedy", None, actions, False, "no move frees the target")


#: one call makes it a planner of the command line: `tsad --plugin examples/own_planner.py ...`
GREEDY = PlannerSpec("greedy", plan_greedy, default_config=GreedyConfig)
register(GREEDY)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="1")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    scenario = generate_scenario(args.scenario, args.seed)
    world = GeometricWorld(scenario, lambda truth: observe_raycast(truth).scene)
    def model(truth, workspace):
        return make_feasibility("geometric", truth, workspace)

    result = run_episode(world, GREEDY, model, GreedyConfig(), args.seed,
                         feasibility_name="geometric")
    print(f"greedy on scenario {args.scenario} seed {args.seed}: success {result.success}, "
          f"{result.num_actions} actions, {result.falls} falls {result.failure_reason}")


if __name__ == "__main__":
    main()
