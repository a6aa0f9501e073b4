"""Write a plan by hand for a small scene (tsad-plan/1 JSON) and verify it at the motion level.

Run: python examples/verify_hand_made_plan.py [OUT_DIR]   (then: tsad verify OUT_DIR/plan.tsad.json)
"""

import json
import math
import sys
from pathlib import Path

import tsad_drake as td
from tsad_drake.planning.types import Action
from tsad_drake.scenario import ObjectConfig, Scenario


def scene() -> Scenario:
    """The target stands behind `front`; `side` and `box` are in the way of wide angles."""
    return Scenario(name="hand-made", target="target", objects=[
        ObjectConfig(name="front", shape="cylinder", size=[0.03, 0.15], x=0.08, y=0.0),
        ObjectConfig(name="box", kind="square_pillar", shape="box", size=[0.045, 0.045, 0.14],
                     x=0.20, y=0.10, yaw=0.3),
        ObjectConfig(name="side", shape="cylinder", size=[0.03, 0.16], x=0.18, y=-0.12),
        ObjectConfig(name="target", shape="cylinder", size=[0.03, 0.13], x=0.25, y=0.0)])


#: object, theta_pick (rad), place x, y (m, shelf frame), theta_place (rad)
ACTIONS = [Action("front", 0.0, 0.08, 0.16, 0.0),
           Action("side", math.radians(-10), 0.08, -0.16, math.radians(-10))]


def main() -> int:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/hand_made")
    out.mkdir(parents=True, exist_ok=True)
    scenario = scene()
    document = td.plan_json(scenario, ACTIONS, retrieve_target=True)
    (out / "plan.tsad.json").write_text(json.dumps(document, indent=2))
    plan = td.load_plan(out / "plan.tsad.json")  # validated as `tsad verify` reads it
    report = td.verify_plan(plan.scenario, plan.actions, world="geometric",
                            retrieve_target=plan.retrieve_target)
    for verdict in report.actions:
        print(f"{verdict.action.object}: {verdict.status} ({verdict.planning_time_s:.2f} s)"
              + (f", {verdict.cause['kind']}: {' vs '.join(verdict.cause['bodies'])}"
                 if verdict.cause else ""))
    (out / "report.json").write_text(json.dumps(report.to_json(), indent=2))
    print("plan verified" if report.success else f"NOT verified: {report.failure_reason}")
    return 0 if report.success else 1


if __name__ == "__main__":
    raise SystemExit(main())
