"""Perception timing and accuracy: `python -m studies.perception_timing`.

Times one full observation (depth at every approach angle, fusion, segmentation, pose fits) with
the NumPy ray caster and, when `tsad_drake.station` is importable, with the Drake station; then
measures planar pose errors (centre, and yaw modulo 90 degrees for boxes) and cluster/label IoU
against the true scenarios on generated scenes.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from tsad_drake.perception.observe import Observation, observe, observe_raycast
from tsad_drake.perception.segmentation import point_iou_matching
from tsad_drake.scenario import Scenario
from tsad_drake.scenes import generate_scenario


def best_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def time_raycast(scenario: Scenario, segmentation: str, repeats: int = 3) -> float:
    """Seconds (best of `repeats`) for one ray-cast observation of `scenario`."""
    return best_time(lambda: observe_raycast(scenario, segmentation=segmentation), repeats)


def time_station(scenario: Scenario, segmentation: str, repeats: int = 3
                 ) -> tuple[float, float] | None:
    """(build seconds, observation seconds) with the Drake station, None when it is unavailable."""
    try:
        from tsad_drake.station import MakeStation
    except ImportError:
        return None
    start = time.perf_counter()
    station = MakeStation(scenario)
    build = time.perf_counter() - start
    return build, best_time(lambda: observe(station, segmentation=segmentation), repeats)


def heldout_observations(seeds: int) -> list[float]:
    """Seconds of one observation as the robot senses (realistic sensor, its frames fused per
    view, `cluster` segmentation, the perception config for that sensor; ray caster) per scene of
    scenarios 1-3, held-out seeds 1000 on (one untimed observation first)."""
    from tsad_drake.perception.observe import perception_config
    from tsad_drake.perception.sensor import sensor_config

    sensor = sensor_config("realistic")
    config = perception_config(sensor)
    times = []
    for k, (name, seed) in enumerate((n, s) for n in ("1", "2", "3")
                                     for s in range(1000, 1000 + seeds)):
        scenario = generate_scenario(name, seed)
        for _ in range(2 if k == 0 else 1):
            start = time.perf_counter()
            observe_raycast(scenario, segmentation="cluster", config=config, sensor=sensor,
                            noise_seed=seed)
        times.append(time.perf_counter() - start)
    return times


def _wrap_quarter(angle: float) -> float:
    """Angle difference folded into [-pi/4, pi/4) (a box's yaw is known modulo 90 degrees)."""
    return (angle + math.pi / 4) % (math.pi / 2) - math.pi / 4


def pose_errors(scenario: Scenario, obs: Observation) -> list[dict]:
    """Per perceived object: the true object it covers (majority pixel label) and its errors."""
    rows = []
    for seg, obj in zip(obs.segments, obs.scene.objects, strict=True):
        labels = obs.cloud.labels[seg.indices]
        labels = labels[labels >= 0]
        if len(labels) == 0:
            continue
        truth = scenario.objects[int(np.bincount(labels).argmax())]
        rows.append({
            "name": obj.name, "truth": truth.name, "kind": truth.kind, "points": len(seg.indices),
            "centre_error": float(math.hypot(obj.x - truth.x, obj.y - truth.y)),
            "yaw_error_deg": (abs(math.degrees(_wrap_quarter(obj.yaw - truth.yaw)))
                              if truth.shape == "box" else None),
            "shape_ok": obj.shape == truth.shape,
        })
    return rows


def accuracy(scenes: list[tuple[str, int]], segmentation: str, depth_noise: float = 0.0
             ) -> dict:
    """Pose error statistics over `scenes` and the mean cluster/label IoU (cluster mode)."""
    rows, ious = [], []
    for name, seed in scenes:
        scenario = generate_scenario(name, seed)
        obs = observe_raycast(scenario, segmentation="label", depth_noise=depth_noise,
                              noise_seed=seed)
        if segmentation == "cluster":
            found = observe_raycast(scenario, segmentation="cluster", depth_noise=depth_noise,
                                    noise_seed=seed)
            ious.append(point_iou_matching([s.indices for s in obs.segments],
                                           [s.indices for s in found.segments])[0])
            obs = found
        rows += pose_errors(scenario, obs)
    centre = np.array([r["centre_error"] for r in rows])
    yaw = np.array([r["yaw_error_deg"] for r in rows if r["yaw_error_deg"] is not None])
    return {
        "objects": len(rows),
        "centre_median_mm": 1000 * float(np.median(centre)),
        "centre_p90_mm": 1000 * float(np.percentile(centre, 90)),
        "yaw_median_deg": float(np.median(yaw)),
        "yaw_p90_deg": float(np.percentile(yaw, 90)),
        "shape_correct": float(np.mean([r["shape_ok"] for r in rows])),
        "mean_iou": float(np.mean(ious)) if ious else None,
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="1", help="built-in scenario timed (1, 2, 3, real)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the timed scene")
    parser.add_argument("--repeats", type=int, default=3, help="timing repeats (best is shown)")
    parser.add_argument("--seeds", type=int, default=5,
                        help="seeds per scenario 1-3 for the accuracy table (0: skip it)")
    parser.add_argument("--noise-mm", type=float, default=1.0,
                        help="depth noise (std, mm) of the second accuracy row")
    parser.add_argument("--heldout", type=int, default=10,
                        help="seeds (1000 on) per scenario 1-3 of the realistic-sensing "
                             "observation timing (0: skip it)")
    args = parser.parse_args(argv)
    if args.heldout > 0:
        times = heldout_observations(args.heldout)
        print(f"one observation as the robot senses it (realistic, fused frames, cluster, ray "
              f"caster), scenarios 1-3 seeds 1000-{999 + args.heldout}: median "
              f"{np.median(times):.3f} s, worst {max(times):.3f} s over {len(times)} scenes")

    scenario = generate_scenario(args.scenario, args.seed)
    views = len(scenario.approach_angles)
    print(f"full observation ({views} views + fusion + segmentation + poses), "
          f"scenario {args.scenario} seed {args.seed}, best of {args.repeats}:")
    for mode in ("label", "cluster"):
        print(f"  ray caster, {mode:<7}: {time_raycast(scenario, mode, args.repeats):7.3f} s")
    for mode in ("label", "cluster"):
        result = time_station(scenario, mode, args.repeats)
        if result is None:
            print("  Drake station: not available (tsad_drake.station missing)")
            break
        print(f"  Drake station, {mode:<7}: {result[1]:7.3f} s (station build {result[0]:.2f} s)")
    if args.seeds <= 0:
        return
    scenes = [(name, seed) for name in ("1", "2", "3") for seed in range(args.seeds)]
    print(f"\npose accuracy vs truth, scenarios 1-3 x seeds 0-{args.seeds - 1} (ray caster):")
    print(f"{'segmentation':<13} {'noise':>6} {'objects':>7} {'centre med':>10} {'p90':>7} "
          f"{'yaw med':>8} {'p90':>6} {'shape ok':>8} {'IoU':>6}")
    for mode in ("label", "cluster"):
        for noise in (0.0, args.noise_mm):
            r = accuracy(scenes, mode, noise / 1000)
            iou = f"{r['mean_iou']:.3f}" if r["mean_iou"] is not None else "-"
            print(f"{mode:<13} {noise:>4.1f}mm {r['objects']:>7d} {r['centre_median_mm']:>8.1f}mm "
                  f"{r['centre_p90_mm']:>5.1f}mm {r['yaw_median_deg']:>6.1f}deg "
                  f"{r['yaw_p90_deg']:>4.1f}deg {r['shape_correct']:>8.2f} {iou:>6}")


if __name__ == "__main__":
    main()
