"""Plug in a feasibility model of your own: implement `blockers` and `pickable`, plan with it.

The model below sees each object only through its perceived points: an object blocks an approach
when one of its points lies in the gripper's swept corridor, and an object can be picked when
nothing blocks it and its points' width across the approach fits the stroke (it ignores the side
walls, so the world may refuse some of its picks). Every other question a planner asks
(placements, one angle's blockers, rollouts) falls back to the interface's defaults.

Run: python examples/own_feasibility_model.py [--scenario 1] [--seed 0]
"""

import argparse

import numpy as np

from tsad_drake.execution.world import GeometricWorld
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.planning.interface import FeasibilityModel
from tsad_drake.planning.registry import get_planner, make_config
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.planning.types import PlanningState, Workspace
from tsad_drake.scenes import generate_scenario


class PointCorridorModel(FeasibilityModel):
    """Blockers: objects with a perceived point in the corridor; pickable: none, and it fits."""

    name = "point-corridor"

    def __init__(self, workspace: Workspace) -> None:
        self.workspace = workspace

    def _frame(self, state: PlanningState, index: int, theta: float):
        """Every object's points in the approach frame of object `index` (along, across)."""
        obj = state.objects[index]
        along = np.array([np.cos(theta), np.sin(theta)])
        across = np.array([-along[1], along[0]])
        return [((o.points[:, :2] - (obj.x, obj.y)) @ along,
                 (o.points[:, :2] - (obj.x, obj.y)) @ across) for o in state.objects]

    def blockers(self, state: PlanningState, index: int) -> list[frozenset[int]]:
        ws, out = self.workspace, []
        for theta in ws.approach_angles:
            hit = [j for j, (s, n) in enumerate(self._frame(state, index, theta)) if j != index
                   and np.any((s <= ws.finger_reach) & (np.abs(n) <= ws.swept_half_width))]
            out.append(frozenset(hit))
        return out

    def pickable(self, state: PlanningState, index: int) -> np.ndarray:
        ws = self.workspace
        fits = [np.ptp(self._frame(state, index, theta)[index][1]) <= ws.stroke - ws.grasp_margin
                for theta in ws.approach_angles]
        return np.array([f and not b for f, b in zip(fits, self.blockers(state, index))])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="1")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    scenario = generate_scenario(args.scenario, args.seed)
    workspace = make_workspace(scenario)
    state = state_from_perception(observe_raycast(scenario).scene)
    model = PointCorridorModel(workspace)
    plan = get_planner("gp3").plan(state, model, workspace, make_config("gp3"),
                                   np.random.default_rng(args.seed))
    world = GeometricWorld(scenario)  # judges the plan on the true shapes
    for action in plan.actions:
        world.execute(action)
    print(f"GP3 on {model.name}: {len(plan.actions)} relocations planned "
          f"({plan.failure_reason or 'claims success'}); in the world: target retrieved "
          f"{world.retrieve()}, {len(world.fallen)} falls")


if __name__ == "__main__":
    main()
