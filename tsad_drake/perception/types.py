"""What perception hands the planners: per-object point clouds with planar poses (NumPy only)."""

from __future__ import annotations

import dataclasses as dc

import numpy as np


@dc.dataclass
class PerceivedObject:
    """One segmented object as the robot sees it; the planners never read true shapes."""

    name: str  #: object name (label segmentation) or "cluster<k>" (cluster segmentation)
    points: np.ndarray  #: (P, 3) float, metres, in the shelf frame S
    x: float  #: m, estimated planar centre in S
    y: float  #: m
    yaw: float  #: rad, estimated orientation about +z
    is_target: bool = False
    shape: str = ""  #: fitted footprint model, "cylinder" or "box" ("" when not estimated)
    size: tuple[float, ...] = ()  #: m, fitted (radius,) or (sx, sy) along yaw and across
    #: (K, 2) m, fitted footprint outline in S (`perception.footprint`); None: the planners
    #: complete the hull of the seen points instead
    outline: np.ndarray | None = None
    uncertainty: float = 0.0  #: m, how far the true footprint may reach past `outline`


@dc.dataclass
class PerceivedScene:
    """All segmented objects from one (fused) observation."""

    objects: list[PerceivedObject]
    target: str | None  #: name of the target among `objects`, None when it was not seen

    def names(self) -> list[str]:
        return [o.name for o in self.objects]

    def target_object(self) -> PerceivedObject | None:
        for obj in self.objects:
            if obj.name == self.target:
                return obj
        return None
