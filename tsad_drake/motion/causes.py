"""Why a motion failed, as data: parses the named failures of `motion/verify.py`.

No Drake import here: the episode loop and the bench read causes without loading the motion level.
"""

from __future__ import annotations

import re

#: "closest: A vs B (-0.3 mm from the bound)" or "between A and B (-0.3 mm from the bound)"
_PAIR = re.compile(r"(?:closest:|between) (\S+) (?:vs|and) (\S+) "
                   r"\(([-+]?\d+(?:\.\d+)?) mm from the bound\)")


def _body_class(name: str) -> str:
    """What kind of body a checker name is: finger, palm, camera, arm, shelf or object."""
    body = name.split("::")[-1]
    if body.endswith("_finger"):
        return "finger"
    if body in ("gripper_base", "tool_adapter"):
        return "palm"
    if body == "camera_link":
        return "camera"
    if "::" in name:
        return "arm"
    return "shelf" if body.startswith("shelf_") or body == "ground" else "object"


#: keyframes of the pick half of an action (failures there do not depend on the placement)
PICK_KEYFRAMES = ("pre_grasp", "grasp", "lift", "retreat")


def failure_phase(failure: str) -> str:
    """The half of the action a named motion failure lies in: "pick" (the object cannot be taken
    at theta_pick, whatever the placement) or "place"; "" for no failure. A failure recorded
    with its phase as a prefix ("pick: ...", plan.json rows written before `phase` was a field)
    keeps it."""
    if not failure:
        return ""
    if failure.startswith(("pick: ", "place: ")):
        return failure.partition(": ")[0]
    words = failure.split()
    if len(words) < 2 or words[0] not in ("keyframe", "segment"):
        return "place"
    name = words[1].rstrip(":")
    if words[0] == "keyframe":
        return "pick" if name in PICK_KEYFRAMES else "place"
    pick = name in ("preshape", "close") or name.split("->")[-1] in PICK_KEYFRAMES
    return "pick" if pick else "place"


def failure_cause(failure: str) -> dict:
    """The cause of a named motion failure as data: which half of the action (`failure_phase`:
    pick / place), where (keyframe or segment), the kind (clearance: a named body pair within the
    bound; unreachable: no IK; optimiser: no segment and no pair named; width: the object does not
    fit the fingers), the body pair, its classes and the margin in mm."""
    half = failure_phase(failure)
    rest = failure.partition(": ")[2] if failure.startswith(("pick: ", "place: ")) else failure
    words = rest.split()
    where = words[1].rstrip(":") if len(words) > 1 and words[0] in ("keyframe", "segment") else ""
    pair = _PAIR.findall(rest)
    cause = {"half": half, "where": where, "kind": "other", "bodies": [], "classes": "",
             "margin_mm": None}
    if pair:
        a, b, margin = pair[-1]
        cause.update(kind="clearance", bodies=[a, b], margin_mm=float(margin),
                     classes=" vs ".join(sorted((_body_class(a), _body_class(b)))))
    elif "unreachable" in rest:
        cause["kind"] = "unreachable"
    elif "failed to optimise" in rest:
        cause["kind"] = "optimiser"
    elif "wider than its stroke" in rest:
        cause["kind"] = "width"
    return cause


def cause_label(cause: dict) -> str:
    """Short label of a cause for tables: the kind, and for clearance the body classes."""
    return f"{cause['kind']}: {cause['classes']}" if cause.get("classes") else cause["kind"]
