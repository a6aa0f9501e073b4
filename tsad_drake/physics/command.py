"""From a verified motion (motion/verify.py) to the command trajectory the physics world plays.

The motion's segments hold motion-plant positions (six UR5e joints in rad, two finger joints in m)
over the action's time line. The command keeps the arm joints and the left finger (the right one
follows through the coupler constraint). While the object is held (from the start of the "close"
segment to the end of the carry, the "open" segment excluded), the finger is commanded `squeeze`
inside the planned closed opening (ramped in over the "close" segment), so that the PD actuator
saturates at its effort limit, the grip force.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from tsad_drake.motion.verify import ActionMotion


@dc.dataclass
class Command:
    """The seven commanded joints over time, and when each segment ends (simulator clock, s)."""

    trajectory: PiecewisePolynomial
    segment_ends: dict[str, float]  #: segment name -> end time
    start: float  #: s
    end: float  #: s


def command_samples(motion: ActionMotion, squeeze: float) -> tuple[np.ndarray, np.ndarray]:
    """Times (N,) from 0 and commanded positions (N, 7), duplicate segment joints removed."""
    times: list[float] = []
    rows: list[np.ndarray] = []
    for segment in motion.segments:
        holding = segment.held is not None and segment.name != "open"
        t0, t1 = segment.times[0], segment.times[-1]
        for t, q in zip(segment.times, segment.q, strict=True):
            if times and t <= times[-1] + 1e-9:
                continue
            ramp = (t - t0) / (t1 - t0) if segment.name == "close" and t1 > t0 else 1.0
            finger = max(q[6] - (squeeze * ramp if holding else 0.0), 0.0)
            times.append(float(t))
            rows.append(np.concatenate([q[:6], [finger]]))
    t0 = motion.segments[0].times[0]
    return np.asarray(times) - t0, np.asarray(rows)


def make_command(motion: ActionMotion, start: float, squeeze: float) -> Command:
    """The command of a verified `motion`, starting at simulator time `start`."""
    if not motion.verified:
        raise ValueError("only a verified motion can be executed")
    times, rows = command_samples(motion, squeeze)
    times = times + start
    trajectory = PiecewisePolynomial.CubicShapePreserving(times, rows.T, True)
    t0 = motion.segments[0].times[0]
    ends = {s.name: float(s.times[-1] - t0 + start) for s in motion.segments}
    return Command(trajectory, ends, float(times[0]), float(times[-1]))
