"""Convert a PDDL-style step list into a tsad-plan/1 file that `tsad verify` checks.

    (pick obj2 0.0) (place obj2 0.10 -0.05 0.3) ... (retrieve target)

`(pick OBJECT THETA_PICK)` then `(place OBJECT X Y THETA_PLACE)` make one action: angles in
radians (the paper's theta), x and y in metres in the shelf frame; a closing `(retrieve NAME)`
asks for the target's retrieval. docs/plan-format.md describes the format.

Run: python examples/pddl_to_plan.py STEPS.txt SCENE.yaml OUT.tsad.json
"""

import json
import re
import sys
from pathlib import Path

import tsad_drake as td
from tsad_drake.planning.types import Action

STEP = re.compile(r"\(\s*([A-Za-z_-]+)((?:\s+[^\s()]+)*)\s*\)")


def pddl_actions(text: str) -> tuple[list[Action], bool]:
    """The actions of a step list and whether it ends by retrieving; ValueError naming the step
    that does not fit."""
    actions, held, retrieve = [], None, False
    steps = STEP.findall(text)
    if not steps or STEP.sub("", text).strip():
        raise ValueError("steps must be (pick OBJ THETA), (place OBJ X Y THETA) or (retrieve OBJ)")
    for k, (verb, rest) in enumerate(steps):
        args = rest.split()
        where = f"step {k + 1} ({verb} {' '.join(args)})"
        if retrieve:
            raise ValueError(f"{where}: nothing may follow (retrieve ...)")
        try:
            numbers = [float(a) for a in args[1:]]
        except ValueError:
            raise ValueError(f"{where}: its arguments after the object must be numbers") from None
        if verb == "pick" and len(args) == 2 and held is None:
            held = (args[0], numbers[0])
        elif verb == "place" and len(args) == 4 and held is not None and held[0] == args[0]:
            actions.append(Action(args[0], held[1], numbers[0], numbers[1], numbers[2]))
            held = None
        elif verb == "retrieve" and len(args) == 1 and held is None:
            retrieve = True
        else:
            raise ValueError(f"{where}: expected "
                             + ("(place OBJ X Y THETA) of the held object" if held else
                                "(pick OBJ THETA) or (retrieve OBJ)"))
    if held is not None:
        raise ValueError(f"{held[0]} is picked but never placed")
    return actions, retrieve


def main() -> int:
    steps, scene, out = sys.argv[1:4]
    actions, retrieve = pddl_actions(Path(steps).read_text())
    # the scenario by path (absolute here; a relative one is taken from the plan file's folder)
    document = td.plan_json(str(Path(scene).resolve()), actions, retrieve_target=retrieve,
                            meta={"source": f"pddl steps {steps}"})
    Path(out).write_text(json.dumps(document, indent=2))
    td.load_plan(out)  # the scenario and every action checked, as `tsad verify` will
    print(f"wrote {out}: {len(actions)} actions" + (", then the retrieval" if retrieve else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
