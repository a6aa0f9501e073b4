"""The public API at `tsad_drake`: every advertised name resolves, and one episode runs through it."""

import subprocess
import sys

import pytest

import tsad_drake as td


@pytest.mark.parametrize("name", sorted(td._PUBLIC))
def test_every_public_name_resolves_to_its_module(name):
    value = getattr(td, name)
    assert value.__module__.startswith("tsad_drake") and name in dir(td)


def test_verify_plan_is_the_plan_verifier_with_a_report():
    """`td.verify_plan` is `tsad verify`'s (the motion level alone stays in motion.verify)."""
    assert td.verify_plan.__module__ == "tsad_drake.verification"
    assert td.VerificationReport.__module__ == "tsad_drake.verification"
    from tsad_drake.motion import verify

    assert verify.verify_plan is not td.verify_plan


def test_unknown_names_are_attribute_errors():
    with pytest.raises(AttributeError, match="no attribute 'plan_tsad'"):
        td.plan_tsad  # noqa: B018


def test_importing_the_package_loads_neither_drake_nor_torch():
    code = "import sys, tsad_drake; print(any(m in sys.modules for m in ('pydrake', 'torch')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_an_episode_through_the_public_api_retrieves_the_target():
    import math

    from frozen_scenes import load_scene

    from tsad_drake.planning.types import Action

    scenario = load_scene("1", 0)  # generate_scenario("1", 0), frozen
    doc = td.plan_episode(scenario, 0, td.EpisodeSettings(planner="tsad", variant="paper")).to_json()
    assert doc["success"] and doc["variant"] == "paper" and doc["actions"]
    # the recorded actions, replayed in a fresh world model, free the target without a fall
    world = td.GeometricWorld(scenario)
    for record in doc["actions"]:
        action = Action(record["true_object"], math.radians(record["theta_pick_deg"]),
                        *record["place_xy"], math.radians(record["theta_place_deg"]))
        assert world.execute(action).moved
    assert world.retrievable() and not world.fallen
