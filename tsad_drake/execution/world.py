"""A symbolic world model on the TRUE scene: applies pick-and-places and counts what falls.

Contact is `geometry2d`'s: the open gripper's corridor (`approach_corridor`) touching a true
footprint knocks that object over; a placement overlapping another footprint knocks it over too.
A knocked-over object is counted once, stays where it stood and can still be picked. A fallen
target, or a placement outside the workspace, ends the episode as a failure. Physics execution in
Drake can replace this class: it only needs `apply`, `retrieval_angle`, `retrieve` and `scenario`.
"""

from __future__ import annotations

import copy
import dataclasses as dc

import numpy as np

from tsad_drake.geometry2d import (
    approach_corridor,
    convex_polygons_overlap,
    side_wall_polygons,
    width_across,
)
from tsad_drake.planning.types import Action
from tsad_drake.scenario import ObjectConfig, Scenario

#: m, how far in front of the shelf the approach corridor starts (as the planners' models)
CORRIDOR_OUTSIDE = 0.30


@dc.dataclass
class Outcome:
    """What happened in the world: the numbers the paper's tables report."""

    success: bool
    num_actions: int  #: every pick-and-place, the final target retrieval included
    relocations: int  #: pick-and-places that put an object somewhere else
    falls: int  #: distinct objects knocked over
    reason: str = ""  #: failure reason, "" on success


class WorldModel:
    """The true scene, changed by actions."""

    def __init__(self, scenario: Scenario) -> None:
        self._scenario = copy.deepcopy(scenario)
        self._walls = side_wall_polygons(scenario.shelf.depth, scenario.shelf.width,
                                         scenario.shelf.wall_thickness)
        self.fallen: list[str] = []  #: names of knocked-over objects, in order
        self.num_actions = 0
        self.relocations = 0
        self.failure = ""  #: set when the episode has failed
        self.success = False

    # -- queries -------------------------------------------------------------------------------
    def scenario(self) -> Scenario:
        """A copy of the current true scene (for re-observation)."""
        return copy.deepcopy(self._scenario)

    @property
    def done(self) -> bool:
        return self.success or bool(self.failure)

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

    # -- changes -------------------------------------------------------------------------------
    def _knock(self, names: list[str]) -> None:
        for name in names:
            if name not in self.fallen:
                self.fallen.append(name)
            if name == self._scenario.target and not self.failure:
                self.failure = "target fell"

    def apply(self, action: Action) -> None:
        """Execute one pick-and-place of the true object named `action.object`."""
        if self.done:
            return
        obj = self.object(action.object)
        self.num_actions += 1
        pick_corridor = self.corridor(obj.x, obj.y, action.theta_pick)
        if self.hits_wall(pick_corridor):
            return  # the arm stops at the wall: a wasted action, nothing moves
        self._knock(self.touched(pick_corridor, obj.name))
        if not self.fits(obj, action.theta_pick):
            self._knock([obj.name])  # the fingers close on it badly: it tips over where it stood
            return
        if self.failure:
            return
        moved = dc.replace(obj, x=float(action.x), y=float(action.y),
                           yaw=float(obj.yaw + action.theta_place - action.theta_pick))
        poly = moved.footprint()
        shelf = self._scenario.shelf
        if (poly[:, 0].min() < 0.0 or poly[:, 0].max() > shelf.depth
                or np.abs(poly[:, 1]).max() > shelf.width / 2):
            self.failure = "object out of workspace"
            return
        self._scenario.objects[self._scenario.objects.index(obj)] = moved
        self.relocations += 1
        place_corridor = self.corridor(moved.x, moved.y, action.theta_place)
        self._knock(self.touched(place_corridor, moved.name) + self.touched(poly, moved.name))

    def retrieve(self) -> bool:
        """Take the target out if some angle allows it (one more action); True on success."""
        if self.done:
            return self.success
        if self.retrieval_angle() is None:
            return False
        self.num_actions += 1
        self.success = True
        return True

    def outcome(self, reason: str = "") -> Outcome:
        return Outcome(self.success, self.num_actions, self.relocations, len(self.fallen),
                       "" if self.success else (self.failure or reason))
