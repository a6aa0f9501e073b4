"""Hand-built scene for the motion tests (independent of the scenario generator)."""

import pytest

from tsad_drake.scenario import ObjectConfig, Scenario, validate


def small_scene() -> Scenario:
    """Four objects with room to move: a front cylinder, a box, a side cylinder, the target."""
    objects = [
        ObjectConfig(name="front", kind="cylinder", shape="cylinder", size=[0.03, 0.15],
                     x=0.08, y=0.0),
        ObjectConfig(name="box", kind="square_pillar", shape="box", size=[0.045, 0.045, 0.14],
                     x=0.20, y=0.10, yaw=0.3),
        ObjectConfig(name="side", kind="cylinder", shape="cylinder", size=[0.03, 0.16],
                     x=0.18, y=-0.12),
        ObjectConfig(name="target", kind="cylinder", shape="cylinder", size=[0.03, 0.13],
                     x=0.25, y=0.0),
    ]
    scenario = Scenario(name="motion-test", objects=objects, target="target")
    validate(scenario)
    return scenario


@pytest.fixture(scope="module")
def scene() -> Scenario:
    return small_scene()
