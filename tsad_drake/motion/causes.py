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


def failure_cause(failure: str) -> dict:
    """The cause of a named motion failure as data: which half of the action (pick / place, when
    the failure carries the prefix), where (keyframe or segment), the kind (clearance: a named body
    pair within the bound; unreachable: no IK; optimiser: no segment and no pair named; width: the
    object does not fit the fingers), the body pair, its classes and the margin in mm."""
    half, _, rest = failure.partition(": ") if failure.startswith(("pick: ", "place: ")) \
        else ("", "", failure)
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
