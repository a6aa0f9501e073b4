"""The planning layer's shared types: workspace, state, action, plan (the model interface: `interface`).

The planners see only these, a FeasibilityModel and the point-cloud simulation; nothing here
imports Drake or reads true object shapes (except the `oracle` model, which is given the scenario).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np


@dc.dataclass(frozen=True)
class Workspace:
    """Fixed facts of the shelf the planner may use: its size, grid, angles and gripper."""

    depth: float  #: m, along +x of the shelf frame S
    width: float  #: m, along y
    wall_thickness: float  #: m
    approach_angles: np.ndarray  #: rad, Theta (sorted)
    cell_centres: np.ndarray  #: (Gx*Gy, 2) m, placement candidates (x, y) in S
    stroke: float  #: m, gripper stroke
    grasp_margin: float  #: m, object must be this much narrower than the stroke
    swept_half_width: float  #: m, half width of the open gripper's swept corridor
    finger_reach: float  #: m, fingertip sweep past the grasp centre
    min_empty_distance: float  #: m, d_min: a cell is empty when no object point lies closer


@dc.dataclass(frozen=True)
class PlanObject:
    """An object as the planner knows it: perceived points plus the planar pose estimate."""

    name: str
    points: np.ndarray  #: (P, 3) m in S; never mutated in place (copy on move)
    x: float  #: m
    y: float  #: m
    yaw: float  #: rad
    #: (x, y, yaw) as perceived; kept by the simulation so a model can recover the motion since
    origin: tuple[float, float, float] | None = None
    #: fitted footprint model from perception, "cylinder" or "box" ("" when not estimated)
    shape: str = ""
    #: m, fitted (radius,) or (sx, sy) along yaw and across; () when not estimated
    size: tuple[float, ...] = ()
    #: (K, 2) m, fitted footprint outline in S at the current pose (moved with the points);
    #: None: the footprint is the completed hull of the points
    outline: np.ndarray | None = None
    uncertainty: float = 0.0  #: m, the outline is padded by this (perceived pose uncertainty)

    @property
    def pose(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.yaw)

    @property
    def moved(self) -> bool:
        """True when the simulation has moved this object since it was perceived."""
        return self.origin is not None and self.origin != self.pose


@dc.dataclass(frozen=True)
class PlanningState:
    """Objects (as perceived, then as simulated) and the name of the target."""

    objects: tuple[PlanObject, ...]
    target: str
    #: `key()`, computed once (states are immutable; every cache of the search is keyed by it)
    _key: tuple = dc.field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        key = (self.target,) + tuple((o.name, o.x, o.y, o.yaw) for o in self.objects)
        object.__setattr__(self, "_key", key)

    def key(self) -> tuple:
        """Hashable identity of the state (states are immutable): target and object poses."""
        return self._key

    def index(self, name: str) -> int:
        for i, obj in enumerate(self.objects):
            if obj.name == name:
                return i
        raise KeyError(name)

    @property
    def target_index(self) -> int:
        return self.index(self.target)


@dc.dataclass(frozen=True)
class Action:
    """Pick-and-place {n, theta_pick, x, y, theta_place}; n is an object name."""

    object: str
    theta_pick: float  #: rad
    x: float  #: m, placement cell centre in S
    y: float  #: m
    theta_place: float  #: rad
    sub_search: int = 0  #: which sub-MCTS (or planner stage) produced it


@dc.dataclass
class Plan:
    """A planner's answer: relocations, then the target taken out at theta_star."""

    planner: str
    theta_star: float | None  #: rad, retrieval angle; None when planning failed
    actions: list[Action]
    success: bool  #: the planner claims the target can be retrieved after `actions`
    failure_reason: str = ""
    planning_time_s: float = 0.0
    stats: dict = dc.field(default_factory=dict)  #: iterations, nodes, |R| per sub-search, ...
    #: the search reached its wall-clock safety stop (a failure, whatever it had found)
    timed_out: bool = False
