"""Run a `tsad` command with another default planning clearance (measurements for issue 20).

    python tools/with_clearance.py 0.0015 bench --scenario 2 --planner tsad --motion ...

Generated scenes take their gripper from `GripperConfig()`; this sets the default of
`GripperConfig.planning_clearance` for this process only, so the scene generator, its
solvability check and the planners all use the given clearance (the value
`scenario.SHARED_CLEARANCE` matches the motion level). Bench files written this way record the
scenes' digests, so they are never mixed with rows of the default clearance on resume.
"""

from __future__ import annotations

import sys

from tsad_drake.cli.main import main
from tsad_drake.scenario import GripperConfig


def set_default_clearance(clearance: float) -> None:
    names = [f for f in GripperConfig.__dataclass_fields__]
    defaults = list(GripperConfig.__init__.__defaults__)
    defaults[len(defaults) - len(names) + names.index("planning_clearance")] = clearance
    GripperConfig.__init__.__defaults__ = tuple(defaults)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        print("usage: python tools/with_clearance.py CLEARANCE_M TSAD_COMMAND [ARGS...]",
              file=sys.stderr)
        sys.exit(2)
    try:
        value = float(sys.argv[1])
    except ValueError:
        print(f"with_clearance: {sys.argv[1]!r} is not a number of metres", file=sys.stderr)
        sys.exit(2)
    if not 0.0 <= value <= 0.1:
        print("with_clearance: the clearance must lie in [0, 0.1] m", file=sys.stderr)
        sys.exit(2)
    set_default_clearance(value)
    assert GripperConfig().planning_clearance == value
    sys.exit(main(sys.argv[2:]))
