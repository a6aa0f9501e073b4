"""Perceived footprints against true ones: `python -m studies.hull_errors`.

The geometric model (and the network's placement test) plan with `pointcloud_sim.perceived_hull`:
the hull of an object's seen points completed by reflection through its estimated centre. This
measures, on generated scenes observed through the ray caster, how far each true footprint reaches
past its perceived hull (the error a placement gap or an edge margin must absorb) and how far the
hull reaches past the truth (space the planner wrongly thinks is taken), per object kind and per
side of the object as the camera sees it (front: towards the camera, -x).
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import json

import numpy as np

from tsad_drake.bench.study_pages import STUDY
from tsad_drake.cli.common import MAX_FRAMES, frame_count
from tsad_drake.outputs import atomic_write_text
from tsad_drake.perception.observe import PerceptionConfig, observe_raycast, perception_config
from tsad_drake.perception.sensor import SENSOR_PRESETS, SensorConfig, sensor_config
from tsad_drake.planning.pointcloud_sim import perceived_hull
from tsad_drake.planning.state import state_from_perception
from tsad_drake.scenario import Scenario
from tsad_drake.scenes import generate_scenario

#: sides reported, as directions in the shelf frame (x into the shelf, away from the camera)
SIDES = {"front": np.pi, "back": 0.0, "left": np.pi / 2, "right": -np.pi / 2}
#: directions over which the largest shortfall / excess of an object is taken
DIRECTIONS = np.arange(32) * 2 * np.pi / 32


@dc.dataclass
class HullError:
    """One perceived object against the true object of the same name (metres)."""

    name: str
    kind: str
    shortfall: float  #: largest distance the true footprint reaches past the perceived hull
    excess: float  #: largest distance the perceived hull reaches past the true footprint
    sides: dict[str, float]  #: per side: perceived support minus true support (+: hull too big)


def support(polygon: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(len(angles),) support distance of `polygon` along each direction."""
    return (polygon @ np.stack([np.cos(angles), np.sin(angles)])).max(axis=0)


def hull_errors(scenario: Scenario, sensor: SensorConfig | None = None,
                segmentation: str = "label", noise_seed: int = 0,
                plain: bool = False) -> list[HullError]:
    """Errors of every perceived object of `scenario` (ray caster through `sensor`, perception
    configured for it, or with `plain` the ideal sensor's pipeline whatever the sensor); a
    cluster stands for the true object nearest its centre."""
    config = PerceptionConfig() if plain else perception_config(sensor)
    observation = observe_raycast(scenario, segmentation=segmentation, sensor=sensor,
                                  config=config, noise_seed=noise_seed)
    state = state_from_perception(observation.scene)
    truth = {o.name: o for o in scenario.objects}
    side_angles = np.array(list(SIDES.values()))
    rows = []
    for obj in state.objects:
        true = truth.get(obj.name)
        if true is None:
            true = min(scenario.objects, key=lambda o: np.hypot(o.x - obj.x, o.y - obj.y))
        hull, footprint = perceived_hull(obj), np.asarray(true.footprint())
        diff = support(hull, DIRECTIONS) - support(footprint, DIRECTIONS)
        sides = support(hull, side_angles) - support(footprint, side_angles)
        rows.append(HullError(obj.name, true.kind, float(max(-diff.min(), 0.0)),
                              float(max(diff.max(), 0.0)),
                              {s: float(v) for s, v in zip(SIDES, sides, strict=True)}))
    return rows


def summary(rows: list[HullError]) -> dict[str, dict[str, float]]:
    """Per kind (and "all"): objects, shortfall / excess median, p90 and max in mm, and the
    median signed error per side in mm."""
    out = {}
    for kind in sorted({r.kind for r in rows}) + ["all"]:
        sel = [r for r in rows if kind in ("all", r.kind)]
        short = 1000 * np.array([r.shortfall for r in sel])
        excess = 1000 * np.array([r.excess for r in sel])
        entry = {"objects": len(sel),
                 "shortfall_median_mm": float(np.median(short)),
                 "shortfall_p90_mm": float(np.percentile(short, 90)),
                 "shortfall_max_mm": float(short.max()),
                 "excess_median_mm": float(np.median(excess)),
                 "excess_p90_mm": float(np.percentile(excess, 90)),
                 "excess_max_mm": float(excess.max())}
        for side in SIDES:
            entry[f"{side}_median_mm"] = 1000 * float(np.median([r.sides[side] for r in sel]))
        out[kind] = entry
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", default="1,2,3", help="comma-separated built-in scenarios")
    parser.add_argument("--seeds", type=int, default=10, help="seeds of each scenario")
    parser.add_argument("--seed-start", type=int, default=0, help="first seed")
    parser.add_argument("--sensor", default="ideal", choices=list(SENSOR_PRESETS))
    parser.add_argument("--noise-mm", type=float, default=None,
                        help="constant depth noise (mm) instead of the sensor's range law")
    parser.add_argument("--frames", type=frame_count, default=None, metavar="N",
                        help=f"depth frames fused per view, 1-{MAX_FRAMES} (default: the sensor's)")
    parser.add_argument("--segmentation", default="label", choices=["label", "cluster"])
    parser.add_argument("--plain", action="store_true",
                        help="the ideal sensor's perception (point hulls) whatever the sensor")
    parser.add_argument("--json", default="", metavar="FILE",
                        help="also write the summary here; `tsad report` turns such files into "
                             "a section of the results page")
    args = parser.parse_args(argv)
    overrides = {} if args.frames is None else {"frames": args.frames}
    if args.noise_mm is not None:
        overrides.update(noise_sigma0=args.noise_mm / 1000, noise_sigma2=0.0)
    try:
        sensor = sensor_config(args.sensor, **overrides)
    except ValueError as error:
        parser.error(str(error))
    rows = []
    seeds = range(args.seed_start, args.seed_start + args.seeds)
    for name in args.scenarios.split(","):
        for seed in seeds:
            rows += hull_errors(generate_scenario(name, seed), sensor, args.segmentation, seed,
                                args.plain)
    print(f"perceived hull vs true footprint, scenarios {args.scenarios} x seeds "
          f"{seeds.start}-{seeds.stop - 1} (ray caster, sensor {args.sensor}"
          f"{'' if args.noise_mm is None else f' at {args.noise_mm} mm'}, "
          f"{sensor.frames} frame(s) per view"
          f"{', plain pipeline' if args.plain else ''}, {args.segmentation} segmentation; mm):")
    print(f"{'kind':<14} {'objects':>7} {'short med':>9} {'p90':>5} {'max':>5} {'excess med':>10} "
          f"{'p90':>5}   signed per side (front back left right)")
    table = summary(rows)
    if args.json:
        settings = {"scenarios": args.scenarios.split(","), "seeds": [seeds.start, seeds.stop - 1],
                    "sensor": args.sensor, "noise_mm": args.noise_mm, "frames": sensor.frames,
                    "segmentation": args.segmentation, "plain": args.plain}
        atomic_write_text(args.json, json.dumps({"study": STUDY, "settings": settings,
                                                 "summary": table}, indent=1))
    for kind, e in table.items():
        sides = " ".join(f"{e[f'{s}_median_mm']:+5.1f}" for s in SIDES)
        print(f"{kind:<14} {e['objects']:>7d} {e['shortfall_median_mm']:>9.1f} "
              f"{e['shortfall_p90_mm']:>5.1f} {e['shortfall_max_mm']:>5.1f} "
              f"{e['excess_median_mm']:>10.1f} {e['excess_p90_mm']:>5.1f}   {sides}")


if __name__ == "__main__":
    main()
