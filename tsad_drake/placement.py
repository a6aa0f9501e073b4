"""Where the robot stands for a shelf: a base pose from which the UR5e reaches every grid cell at
every approach angle, found by IK once per shelf (and process) and cached.

A (cell, angle) grasp counts when the planners could ask for it: a small probe cylinder
(`PROBE_RADIUS`) alone at the cell centre is pickable at that angle by the corridor rule (the
open gripper fits between the side walls). Such a grasp is *reached* when the motion level's IK
(`motion.keyframes.reach_keyframe`, on the shelf alone) puts the tcp at its pre-grasp and grasp
keyframes within the joint limits. A reached grasp whose every solution found touches the shelf
or the ground is *blocked by contact*: it is reported, not refused, since the motion level
verifies each action at plan time and refuses those (the narrow `real` shelf has three, where the
wrist meets the side walls at the back row). The observation viewpoints must be reachable too
(`station_ik.solve_observation_poses`), and the ready pose every plan starts from
(`motion.verify.ready_q`).

The configured `StationConfig.shelf_distance` is kept when everything is reached from it (every
built-in scenario's shelf); otherwise the robot moves along the shelf's axis to the first of
`CANDIDATE_DISTANCES` that reaches everything, and with none, `PlacementError` names the cells out
of reach from the configured distance.
"""

from __future__ import annotations

import dataclasses as dc
import json
import time

import numpy as np
from pydrake.math import RigidTransform

from tsad_drake.errors import UsageError
from tsad_drake.runtime import debug, detail
from tsad_drake.scenario import ObjectConfig, Scenario
from tsad_drake.station import StationConfig

#: m, shelf distances tried after the configured one, in order (nearest the default first)
CANDIDATE_DISTANCES = (0.70, 0.65, 0.75, 0.60, 0.80, 0.55, 0.50)
#: m, radius and height of the probe object whose grasps are checked at every cell
PROBE_RADIUS = 0.02
PROBE_HEIGHT = 0.10


class PlacementError(UsageError):
    """No candidate base pose reaches every grid cell at every approach angle (exit status 2)."""


@dc.dataclass(frozen=True)
class Grasp:
    """One (cell, angle) grasp the planners could ask for."""

    row: int  #: grid index along the depth (0: the front row)
    column: int  #: grid index along the width (0: the rightmost, -y)
    theta: float  #: rad, approach angle
    x: float  #: m, cell centre in the shelf frame
    y: float


@dc.dataclass
class ReachReport:
    """What the arm reaches from one base pose."""

    shelf_distance: float  #: m
    checked: int = 0  #: grasps checked (pickable by the corridor rule)
    unreachable: list[Grasp] = dc.field(default_factory=list)  #: no IK solution
    contact: list[Grasp] = dc.field(default_factory=list)  #: reached only touching the shelf
    #: (grasp, keyframe) -> full motion-plant positions of every reached keyframe
    solutions: dict[tuple[Grasp, str], np.ndarray] = dc.field(default_factory=dict)
    #: why the observation viewpoints or the ready pose cannot be reached ("": they can)
    views: str = ""

    @property
    def reaches_all(self) -> bool:
        return not self.unreachable and not self.views


@dc.dataclass(frozen=True)
class Placement:
    """The station placed for a shelf and what its reach check found."""

    station: StationConfig  #: the configured station, `shelf_distance` where the robot stands
    report: ReachReport
    moved: bool  #: the robot stands elsewhere than configured
    seconds: float  #: s, the reach checks that found it

    def summary(self) -> str:
        r = self.report
        where = (f"robot moved to {r.shelf_distance:.2f} m from the shelf" if self.moved
                 else f"robot at {r.shelf_distance:.2f} m from the shelf")
        blocked = (f"; {len(r.contact)} reached only touching the shelf (the motion level "
                   f"refuses those): {_names(r.contact)}" if r.contact else "")
        return (f"{where}: all {r.checked} cell-angle grasps reached{blocked} "
                f"({self.seconds:.1f} s of IK)")


def _names(grasps: list[Grasp], limit: int = 6) -> str:
    """"cell (3, 4) at +10/+20 deg, ...": the grasps by cell, the first `limit` cells."""
    by_cell: dict[tuple[int, int], list[float]] = {}
    for g in grasps:
        by_cell.setdefault((g.row, g.column), []).append(np.degrees(g.theta))
    cells = [f"cell ({r}, {c}) at {'/'.join(f'{a:+.0f}' for a in sorted(angles))} deg"
             for (r, c), angles in by_cell.items()]
    shown = ", ".join(cells[:limit])
    return shown + (f" and {len(cells) - limit} more cells" if len(cells) > limit else "")


def probe_at(x: float, y: float) -> ObjectConfig:
    """The probe cylinder whose grasps stand for a cell's (at the cell centre x, y in S)."""
    return ObjectConfig(name="probe", shape="cylinder", size=[PROBE_RADIUS, PROBE_HEIGHT],
                        x=float(x), y=float(y))


def grasps(scenario: Scenario) -> list[Grasp]:
    """Every (cell, angle) grasp of `scenario`'s grid that the corridor rule allows for a probe
    alone at the cell centre, farthest from the robot's base first (those fail first)."""
    from tsad_drake.planning.feasibility import OracleFeasibility
    from tsad_drake.planning.state import make_workspace, true_state

    workspace = make_workspace(scenario)  # pickable answers per its (sorted) approach angles
    found = []
    for index, (x, y) in enumerate(workspace.cell_centres):
        probe = probe_at(x, y)
        alone = dc.replace(scenario, objects=[probe], target="probe", occluded=False)
        allowed = OracleFeasibility(alone).pickable(true_state(alone), 0)
        row, column = divmod(index, scenario.grid.cells_y)
        found += [Grasp(row, column, float(theta), float(x), float(y))
                  for theta, ok in zip(workspace.approach_angles, allowed, strict=True) if ok]
    return sorted(found, key=lambda g: -np.hypot(g.x, g.y))


def reach_report(scenario: Scenario, station: StationConfig, motion, distance: float,
                 stop_at_first: bool = False, checked: list[Grasp] | None = None) -> ReachReport:
    """What the arm reaches with the shelf at `distance` (m): every grasp of `checked` (default
    `grasps(scenario)`), the observation viewpoints and the ready pose (`stop_at_first`: stop at
    the first grasp out of reach)."""
    from tsad_drake.motion.keyframes import KeyframeError, keyframe_targets
    from tsad_drake.motion.scene import MotionModel
    from tsad_drake.motion.verify import ready_q
    from tsad_drake.station_ik import ObservationPoseError, solve_observation_poses

    placed = dc.replace(station, shelf_distance=float(distance))
    X_WS = placed.X_WS(scenario.shelf.floor_height)
    model = MotionModel(scenario.shelf, X_WS, [], motion)
    report = ReachReport(shelf_distance=float(distance))
    home = np.asarray(motion.home_q, dtype=float)
    last: dict[float, np.ndarray] = {}  # theta -> the last pre-grasp reached (the next seed)
    for grasp in grasps(scenario) if checked is None else checked:
        report.checked += 1
        targets = keyframe_targets(probe_at(grasp.x, grasp.y), grasp.theta, grasp.x, grasp.y,
                                   grasp.theta, motion)
        # seeded from the last pre-grasp reached at this angle, then (IK is local) from home
        starts = [last[grasp.theta], home] if grasp.theta in last else [home]
        for start in starts:
            reached = _reach_grasp(model, X_WS, targets, start)
            if reached is not None:
                break
        if reached is None:
            report.unreachable.append(grasp)
        else:
            (q_pre, q_grasp), free = reached
            report.solutions[(grasp, "pre_grasp")] = q_pre
            report.solutions[(grasp, "grasp")] = q_grasp
            last[grasp.theta] = q_pre[model.arm_indices]
            if not free:
                report.contact.append(grasp)
        if stop_at_first and report.unreachable:
            return report
    try:
        solve_observation_poses(scenario, placed.camera, RigidTransform(), X_WS,
                                np.asarray(placed.home_q), placed.ik_seeds, placed.min_distance,
                                placed.ik_position_tolerance,
                                np.radians(placed.ik_orientation_tolerance_deg))
    except ObservationPoseError as err:
        report.views = str(err)
    try:
        ready_q(scenario, [], motion, X_WS)
    except KeyframeError as err:
        report.views = report.views or f"the ready pose: {err}"
    return report


def _reach_grasp(model, X_WS: RigidTransform, targets: dict, start: np.ndarray
                 ) -> tuple[tuple[np.ndarray, np.ndarray], bool] | None:
    """((pre-grasp, grasp) positions, both collision-free) from arm positions `start`, or None
    when either keyframe has no IK solution."""
    from tsad_drake.motion.keyframes import reach_keyframe
    from tsad_drake.station_models import FINGER_OPEN

    q_pre, free_pre = reach_keyframe(model, X_WS @ targets["pre_grasp"], start, FINGER_OPEN,
                                     retry_unreachable=False)
    if q_pre is None:
        return None
    q_grasp, free = reach_keyframe(model, X_WS @ targets["grasp"], q_pre[model.arm_indices],
                                   FINGER_OPEN, retry_unreachable=False)
    return None if q_grasp is None else ((q_pre, q_grasp), free_pre and free)


_CACHE: dict[str, Placement] = {}


def _cache_key(scenario: Scenario, station: StationConfig, motion) -> str:
    """Everything the placement depends on: the shelf, grid, gripper and angles, the station
    and the motion settings (not the objects)."""
    return json.dumps([dc.asdict(scenario.shelf), dc.asdict(scenario.grid),
                       dc.asdict(scenario.gripper), list(scenario.approach_angles_deg),
                       dc.asdict(station), dc.asdict(motion)], sort_keys=True, default=float)


def place_station(scenario: Scenario, station: StationConfig | None = None, motion=None
                  ) -> Placement:
    """The station placed for `scenario`'s shelf (see the module docstring); cached per shelf,
    grid, gripper, angles and settings. Raises PlacementError naming the cells out of reach."""
    from tsad_drake.motion.scene import MotionConfig

    station = station or StationConfig()
    motion = motion or MotionConfig()
    key = _cache_key(scenario, station, motion)
    if key in _CACHE:
        return _CACHE[key]
    start = time.perf_counter()
    checked = grasps(scenario)  # the same at every distance
    configured = reach_report(scenario, station, motion, station.shelf_distance, checked=checked)
    if configured.reaches_all:
        found = configured
    else:
        found = None
        for distance in CANDIDATE_DISTANCES:
            if abs(distance - station.shelf_distance) < 1e-9:
                continue
            # stops only at a grasp out of reach: one that reaches all is a whole report
            candidate = reach_report(scenario, station, motion, distance, stop_at_first=True,
                                     checked=checked)
            if candidate.reaches_all:
                found = candidate
                break
        if found is None:
            raise PlacementError(_refusal(scenario, configured))
    placement = Placement(dc.replace(station, shelf_distance=found.shelf_distance), found,
                          moved=found is not configured, seconds=time.perf_counter() - start)
    (detail if placement.moved else debug)(f"station: {placement.summary()}")
    _CACHE[key] = placement
    # placing the placed station again finds it where it stands (a checked pose, no new IK)
    _CACHE.setdefault(_cache_key(scenario, placement.station, motion),
                      dc.replace(placement, moved=False))
    return placement


def placed_config(scenario: Scenario, config):
    """`config` (a RunConfig) with its station placed for `scenario`'s shelf (`place_station`);
    raises PlacementError."""
    return dc.replace(config, station=place_station(scenario, config.station,
                                                    config.motion).station)


def _refusal(scenario: Scenario, report: ReachReport) -> str:
    shelf = scenario.shelf
    what = (f"{len(report.unreachable)} of {report.checked} cell-angle grasps are out of the "
            f"arm's reach ({_names(report.unreachable)})" if report.unreachable
            else f"the arm cannot take its poses outside the shelf ({report.views})")
    return (f"no robot placement reaches the whole {shelf.width:.2f} x {shelf.depth:.2f} m shelf "
            f"(floor at {shelf.floor_height:.2f} m; shelf distances "
            f"{', '.join(f'{d:.2f}' for d in CANDIDATE_DISTANCES)} m tried): from "
            f"{report.shelf_distance:.2f} m {what}; lower the shelf, make it shallower or narrower, or "
            "set grid.margin / grid.cells_x / grid.cells_y to keep the grid within reach")
