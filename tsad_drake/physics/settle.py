"""Settling a scene in the Drake contact simulation: `tsad scene --settle`.

The scene is built as the physics world builds it (`diagram.build_sim`: the station's plant on the
SAP solver, point contact), the arm held at the ready configuration outside the shelf, and
simulated `SettleConfig.duration` seconds from rest: objects pushed into each other separate,
objects standing a little above or inside the floor come to rest on it. The settled scene keeps
every field of the input but each object's planar pose (x, y and the simulated heading).
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from tsad_drake.errors import ScenarioError
from tsad_drake.physics.config import PhysicsConfig
from tsad_drake.physics.diagram import build_sim
from tsad_drake.physics.outcome import body_pose, fall_reason
from tsad_drake.scenario import CONTACT_TOLERANCE, Scenario, interpenetrations, validate

#: m, deepest interpenetration settling starts from (deeper, the contact forces throw objects)
MAX_SETTLE_PENETRATION = 0.005


@dc.dataclass
class SettleConfig:
    """How long and with which physics a scene is settled."""

    duration: float = 1.0  #: s, simulated time from rest
    physics: PhysicsConfig = dc.field(default_factory=PhysicsConfig)


@dc.dataclass
class SettledObject:
    """How one object moved while settling."""

    name: str
    moved_mm: float  #: mm, horizontal distance its centre moved
    turned_deg: float  #: deg, change of its heading
    tilt_deg: float  #: deg, its axis against the vertical at the end


def settle_scene(scenario: Scenario, config: SettleConfig | None = None
                 ) -> tuple[Scenario, list[SettledObject]]:
    """The scene after `config.duration` s of contact simulation from rest, and how far each
    object moved. Raises ScenarioError when objects interpenetrate deeper than
    MAX_SETTLE_PENETRATION at the start, when an object falls, or when objects still
    interpenetrate deeper than CONTACT_TOLERANCE at the end. The input need not pass `validate`
    for its overlaps (everything else it must: `validate(scenario, overlaps=False)`)."""
    from tsad_drake.motion.verify import ready_q

    config = config or SettleConfig()
    _refuse_deepest(scenario, MAX_SETTLE_PENETRATION, "too deep to settle")
    ready = ready_q(scenario, scenario.objects)  # arm outside the shelf, fingers open
    sim = build_sim(scenario, ready, config.physics)
    sim.simulator.AdvanceTo(config.duration)
    X_SW = sim.X_WS.inverse()
    settled = dc.replace(scenario, objects=[])
    report = []
    for obj in scenario.objects:
        pose = body_pose(X_SW @ sim.plant.EvalBodyPoseInWorld(sim.plant_context,
                                                              sim.models.objects[obj.name]))
        fell = fall_reason(obj, pose, scenario.shelf, config.physics)
        if fell:
            raise ScenarioError(f"object {obj.name} fell while settling ({fell})")
        turned = math.remainder(pose.yaw - obj.yaw, 2 * math.pi)
        settled.objects.append(dc.replace(obj, x=pose.x, y=pose.y, yaw=obj.yaw + turned))
        report.append(SettledObject(obj.name, 1000.0 * math.hypot(pose.x - obj.x, pose.y - obj.y),
                                    math.degrees(turned), pose.tilt_deg))
    _refuse_deepest(settled, CONTACT_TOLERANCE, f"still, after {config.duration:g} s of settling")
    validate(settled)
    return settled, report


def _refuse_deepest(scenario: Scenario, tolerance: float, why: str) -> None:
    """ScenarioError naming the deepest pair interpenetrating more than `tolerance` (m)."""
    deep = interpenetrations(scenario, tolerance)
    if deep:
        i, j, depth = max(deep, key=lambda d: d[2])
        raise ScenarioError(
            f"objects {scenario.objects[i].name} and {scenario.objects[j].name} interpenetrate by "
            f"{depth * 1000:.1f} mm ({why}; more than {tolerance * 1000:g} mm): move them apart "
            "by hand")


def settle_lines(report: list[SettledObject]) -> list[str]:
    """One line per object: how far it moved and turned while settling."""
    width = max((len(r.name) for r in report), default=0)
    return [f"{r.name:<{width}}  moved {r.moved_mm:6.2f} mm  turned {r.turned_deg:+6.2f} deg  "
            f"tilt {r.tilt_deg:4.1f} deg" for r in report]


def largest_move_mm(report: list[SettledObject]) -> float:
    """mm, the largest distance any object moved."""
    return float(np.max([r.moved_mm for r in report])) if report else 0.0
