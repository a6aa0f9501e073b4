"""Can the arm carry out the grasps the planners allow? `python -m studies.arm_reach`.

For each seed of a built-in scenario and each object alone in its scene (so only the shelf can be
in the way), every approach angle the planners call pickable (the oracle's corridor rule) is
planned on the motion level as a whole pick-and-place back to the same cell
(`motion.verify.plan_action` from the ready pose). Prints how many are motion-feasible, for the
targets too, and the refusals by keyframe or segment and body pair: the check that found the
UR5e's wrist links against the real shelf's walls (65 of 88 with the gripper on the flange and
the shelf at 0.60 m; 86 of 88 with the 0.10 m tool extension and the shelf at 0.70 m).
"""

from __future__ import annotations

import argparse
import collections
import dataclasses as dc


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="real", help="built-in scenario (default real)")
    parser.add_argument("--seeds", type=int, default=6, help="number of seeds from 0 (default 6)")
    parser.add_argument("--shelf-distance", type=float, default=None,
                        help="m, StationConfig.shelf_distance (default: the station's)")
    parser.add_argument("--lateral", type=float, default=0.0,
                        help="m, StationConfig.shelf_lateral_offset (default 0)")
    args = parser.parse_args(argv)

    from tsad_drake.motion.causes import failure_cause
    from tsad_drake.motion.verify import plan_action, ready_q
    from tsad_drake.planning.feasibility import OracleFeasibility
    from tsad_drake.planning.state import true_state
    from tsad_drake.planning.types import Action
    from tsad_drake.scenes import generate_scenario
    from tsad_drake.station import StationConfig

    station = StationConfig(shelf_lateral_offset=args.lateral)
    if args.shelf_distance is not None:
        station = dc.replace(station, shelf_distance=args.shelf_distance)
    feasible = checked = target_feasible = target_checked = 0
    refusals: collections.Counter = collections.Counter()
    for seed in range(args.seeds):
        scenario = generate_scenario(args.scenario, seed)
        X_WS = station.X_WS(scenario.shelf.floor_height)
        for obj in scenario.objects:
            alone = dc.replace(scenario, objects=[obj], target=obj.name)
            allowed = OracleFeasibility(alone).pickable(true_state(alone), 0)
            start = ready_q(alone, alone.objects, X_WS=X_WS)
            for theta, ok in zip(scenario.approach_angles, allowed, strict=True):
                if not ok:
                    continue
                motion = plan_action(alone, alone.objects,
                                     Action(obj.name, float(theta), obj.x, obj.y, float(theta)),
                                     start, X_WS=X_WS)
                checked += 1
                feasible += motion.verified
                if obj.name == scenario.target:
                    target_checked += 1
                    target_feasible += motion.verified
                if not motion.verified:
                    cause = failure_cause(motion.failure)
                    refusals[(cause["where"], cause["kind"], " vs ".join(cause["bodies"]))] += 1
    print(f"scenario {args.scenario}, {args.seeds} seeds, shelf at {station.shelf_distance} m "
          f"({station.shelf_lateral_offset:+} m): {feasible}/{checked} planner-pickable grasps "
          f"motion-feasible, targets {target_feasible}/{target_checked}")
    for (where, kind, bodies), count in refusals.most_common(8):
        print(f"  {count:3d}  {where} {kind} {bodies}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
