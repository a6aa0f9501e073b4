"""The built-in scenes: the seeded generator with the `optimal` planner as its solvability check.

Every generated scene the bench, the command line and the tests use comes from here, so the
check (the `optimal` planner on the oracle model and the true shapes, node-budgeted, no time
limit) is injected in one place and the generator itself imports no planner.
"""

from __future__ import annotations

from tsad_drake.planners.optimal import OptimalConfig, plan_optimal
from tsad_drake.planning.feasibility import OracleFeasibility
from tsad_drake.planning.state import make_workspace, true_state
from tsad_drake.scenario import GridConfig, Scenario, ShelfConfig
from tsad_drake.scenario_generator import BUILTIN_SCENARIOS, GeneratorConfig, generate_scene
from tsad_drake.viewpoints import CameraConfig

__all__ = ["BUILTIN_SCENARIOS", "generate_scenario", "plan_solvable"]


def plan_solvable(scenario: Scenario, max_nodes: int) -> bool:
    """Whether the `optimal` planner, on the oracle model and the true state, finds relocations
    after which the target can be taken out, within `max_nodes` expanded nodes (no time limit, so
    the answer does not depend on the machine)."""
    workspace = make_workspace(scenario)
    config = OptimalConfig(max_nodes=max_nodes, safety_stop_s=float("inf"))
    plan = plan_optimal(true_state(scenario), OracleFeasibility(scenario, workspace), workspace,
                        config)
    return plan.success


def generate_scenario(name: str, seed: int, occluded: bool = False,
                      config: GeneratorConfig | None = None,
                      camera: CameraConfig | None = None, shelf: ShelfConfig | None = None,
                      grid: GridConfig | None = None) -> Scenario:
    """A random scene of built-in scenario `name`, reproducible by seed, checked solvable (on
    `shelf` and `grid` in place of the scenario's own when given)."""
    return generate_scene(name, seed, plan_solvable, occluded, config, camera, shelf, grid)
