"""The World an episode acts on, and its first implementation: the geometric world.

A `World` holds the TRUE scene: it is observed (what the robot perceives), executes pick-and-places
on true objects and judges them (what moved, what fell), and takes the target out at the end. The
closed loop (`execution.episode`) only talks to this interface, so a physics world (a Drake contact
simulation that executes the motion-level trajectories and renders its next observation from the
simulated state) is another implementation of the same methods.

`GeometricWorld` decides contact with `geometry2d`: the open gripper's corridor
(`approach_corridor`) touching a true footprint knocks that object over; a placement overlapping
another footprint knocks it over too. A knocked-over object is counted once, stays where it stood
and can still be picked. A fallen target, or a placement outside the workspace, ends the episode
as a failure.
"""

from __future__ import annotations

import copy
import dataclasses as dc
from abc import ABC, abstractmethod
from collections.abc import Callable

import numpy as np

from tsad_drake.geometry2d import (
    approach_corridor,
    convex_polygons_overlap,
    side_wall_polygons,
    width_across,
)
from tsad_drake.perception.types import PerceivedScene
from tsad_drake.planning.types import Action
from tsad_drake.scenario import ObjectConfig, Scenario

#: m, how far in front of the shelf the approach corridor starts (as the planners' models)
CORRIDOR_OUTSIDE = 0.30

#: the robot's observation of a true scene (a renderer plus perception)
Observer = Callable[[Scenario], PerceivedScene]


@dc.dataclass
class Outcome:
    """What happened in the world: the numbers the paper's tables report."""

    success: bool
    num_actions: int  #: every pick-and-place, the final target retrieval included
    relocations: int  #: pick-and-places that put an object somewhere else
    falls: int  #: distinct objects knocked over
    reason: str = ""  #: failure reason, "" on success


@dc.dataclass
class ActionOutcome:
    """What one executed pick-and-place did in the world."""

    object: str  #: the true object it grasped
    moved: bool  #: the object now stands at the placement
    fallen: list[str] = dc.field(default_factory=list)  #: objects knocked over by this action
    reason: str = ""  #: why the object did not move ("" when it did)
    # -- measured by a physics world (left at their defaults by the geometric world) ----------
    #: non-picked objects displaced more than the world's threshold without falling
    disturbed: list[str] = dc.field(default_factory=list)
    placement_error_mm: float | None = None  #: mm, moved object's centre to the place point
    placement_error_deg: float | None = None  #: deg, its yaw to the intended one (symmetry-aware)
    slip_mm: float | None = None  #: mm, held object's motion in the tcp frame during transport
    slip_deg: float | None = None  #: deg, the same as a rotation
    lifted: bool | None = None  #: the object rose with the gripper after the grasp
    welded: bool | None = None  #: weld grasp mode: both fingers touched and the weld held it
    tracking_error: float | None = None  #: rad, largest arm joint error against the command
    tracking_joint: str = ""  #: the joint where it occurred
    #: "perceived" or "true": the object poses the motion was planned on; "plan": a motion
    #: planned elsewhere on the plan's own scene (`PhysicsWorld.execute_motion`, `tsad verify`)
    aimed_at: str = ""
    aim_error_mm: float | None = None  #: mm, believed centre of the picked object to the true one
    sim_seconds: float = 0.0  #: s, simulated time of the action (settling included)
    wall_seconds: float = 0.0  #: s, wall-clock time of the simulation (planning excluded)
    planning_seconds: float = 0.0  #: s, wall-clock time of its motion planning


class World(ABC):
    """The true scene an episode acts on (see the module docstring)."""

    #: whether `execute` measures its outcome in a simulation (the episode then records it)
    measures_physics = False

    def __init__(self) -> None:
        self.fallen: list[str] = []  #: names of knocked-over objects, in order
        self.num_actions = 0  #: pick-and-places executed, the final retrieval included
        self.relocations = 0  #: pick-and-places that put an object somewhere else
        self.failure = ""  #: set when the episode has failed
        self.success = False  #: set when the target has been taken out
        #: what a physics world measured of the target's retrieval (None where nothing is measured)
        self.retrieval: ActionOutcome | None = None

    @property
    def done(self) -> bool:
        return self.success or bool(self.failure)

    @abstractmethod
    def observe(self) -> PerceivedScene:
        """What the robot perceives of the scene now."""

    @abstractmethod
    def scenario(self) -> Scenario:
        """A copy of the true scene now (the oracle model and the motion level read it)."""

    @abstractmethod
    def true_name(self, name: str, x: float, y: float) -> str:
        """The true object an action on perceived object `name`, centred at (x, y), grasps."""

    @abstractmethod
    def execute(self, action: Action) -> ActionOutcome:
        """Execute one pick-and-place of the true object named `action.object`."""

    @abstractmethod
    def retrievable(self) -> bool:
        """Whether the target could be taken out now without touching anything."""

    @abstractmethod
    def retrieve(self) -> bool:
        """Take the target out if possible (one more action); True on success."""

    def outcome(self, reason: str = "") -> Outcome:
        """The episode's figures so far; `reason` explains a failure the world did not see."""
        return Outcome(self.success, self.num_actions, self.relocations, len(self.fallen),
                       "" if self.success else (self.failure or reason))


class GeometricWorld(World):
    """The true scene, changed by actions under the 2-D corridor rule, observed by `observer`
    (None: a world that only executes and judges, as tests and plan checks use it)."""

    def __init__(self, scenario: Scenario, observer: Observer | None = None) -> None:
        super().__init__()
        self._scenario = copy.deepcopy(scenario)
        self._observer = observer
        self._walls = side_wall_polygons(scenario.shelf.depth, scenario.shelf.width,
                                         scenario.shelf.wall_thickness)

    # -- the World interface -------------------------------------------------------------------
    def observe(self) -> PerceivedScene:
        if self._observer is None:
            raise RuntimeError("this GeometricWorld was built without an observer")
        return self._observer(self.scenario())

    def scenario(self) -> Scenario:
        return copy.deepcopy(self._scenario)

    def true_name(self, name: str, x: float, y: float) -> str:
        """`name` itself when a true object has it (label segmentation), else the true object
        whose centre is nearest (x, y)."""
        try:
            self.object(name)
            return name
        except KeyError:
            return self.nearest(x, y)

    def execute(self, action: Action) -> ActionOutcome:
        if self.done:
            return ActionOutcome(action.object, False, reason="the episode is over")
        obj = self.object(action.object)
        fallen_before = len(self.fallen)
        self.num_actions += 1
        moved, reason = self._pick_and_place(obj, action)
        return ActionOutcome(obj.name, moved, self.fallen[fallen_before:], reason)

    def retrievable(self) -> bool:
        return self.retrieval_angle() is not None

    def retrieve(self) -> bool:
        if self.done:
            return self.success
        if self.retrieval_angle() is None:
            return False
        self.num_actions += 1
        self.success = True
        return True

    # -- the 2-D rule --------------------------------------------------------------------------
    def object(self, name: str) -> ObjectConfig:
        return self._scenario.object(name)

    def nearest(self, x: float, y: float) -> str:
        """Name of the true object whose centre is nearest (x, y)."""
        objs = self._scenario.objects
        return objs[int(np.argmin([np.hypot(o.x - x, o.y - y) for o in objs]))].name

    def corridor(self, x: float, y: float, theta: float) -> np.ndarray:
        g = self._scenario.gripper
        return approach_corridor(x, y, theta, g.swept_half_width, g.finger_reach, CORRIDOR_OUTSIDE)

    def touched(self, polygon: np.ndarray, exclude: str) -> list[str]:
        """Names of the objects (other than `exclude`) whose true footprint meets `polygon`."""
        return [o.name for o in self._scenario.objects
                if o.name != exclude and convex_polygons_overlap(polygon, o.footprint())]

    def hits_wall(self, polygon: np.ndarray) -> bool:
        return any(convex_polygons_overlap(polygon, w) for w in self._walls)

    def fits(self, obj: ObjectConfig, theta: float) -> bool:
        g = self._scenario.gripper
        return width_across(obj.shape, obj.size, obj.yaw, theta) <= g.stroke - g.grasp_margin + 1e-9

    def retrieval_angle(self) -> float | None:
        """An angle (nearest 0) at which the target comes out untouched, else None."""
        target = self.object(self._scenario.target)
        for theta in sorted(self._scenario.approach_angles, key=abs):
            corridor = self.corridor(target.x, target.y, theta)
            if (self.fits(target, theta) and not self.hits_wall(corridor)
                    and not self.touched(corridor, target.name)):
                return float(theta)
        return None

    def _knock(self, names: list[str]) -> None:
        for name in names:
            if name not in self.fallen:
                self.fallen.append(name)
            if name == self._scenario.target and not self.failure:
                self.failure = "target fell"

    def _pick_and_place(self, obj: ObjectConfig, action: Action) -> tuple[bool, str]:
        """Apply one pick-and-place; (whether the object moved, why not)."""
        pick_corridor = self.corridor(obj.x, obj.y, action.theta_pick)
        if self.hits_wall(pick_corridor):
            return False, "the arm stops at a side wall"  # a wasted action, nothing moves
        self._knock(self.touched(pick_corridor, obj.name))
        if not self.fits(obj, action.theta_pick):
            self._knock([obj.name])  # the fingers close on it badly: it tips over where it stood
            return False, "too wide for the gripper at theta_pick"
        if self.failure:
            return False, self.failure
        moved = dc.replace(obj, x=float(action.x), y=float(action.y),
                           yaw=float(obj.yaw + action.theta_place - action.theta_pick))
        poly = moved.footprint()
        shelf = self._scenario.shelf
        if (poly[:, 0].min() < 0.0 or poly[:, 0].max() > shelf.depth
                or np.abs(poly[:, 1]).max() > shelf.width / 2):
            self.failure = "object out of workspace"
            return False, self.failure
        self._scenario.objects[self._scenario.objects.index(obj)] = moved
        self.relocations += 1
        place_corridor = self.corridor(moved.x, moved.y, action.theta_place)
        self._knock(self.touched(place_corridor, moved.name) + self.touched(poly, moved.name))
        return True, ""


def retrieval_angles(scenario: Scenario) -> list[float]:
    """The angles (rad) to try taking the target out at, best first: the corridor rule's clear
    angle on `scenario` (`GeometricWorld.retrieval_angle`), then every approach angle by |theta|."""
    clear = GeometricWorld(scenario).retrieval_angle()
    angles = sorted((float(a) for a in scenario.approach_angles), key=abs)
    if clear is None:
        return angles
    return [clear] + [a for a in angles if abs(a - clear) > 1e-9]
