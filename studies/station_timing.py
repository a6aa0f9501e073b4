"""Station timing: build time, 128x128 depth frames per second, and one sweep over all views.

Run with `python -m studies.station_timing [--scenario 1] [--seed 0] [--frames 200]`.
"""

from __future__ import annotations

import argparse
import os
import time


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="1", help="built-in scenario name (1, 2, 3, real)")
    parser.add_argument("--seed", type=int, default=0, help="generator seed")
    parser.add_argument("--frames", type=int, default=200, help="depth frames to time")
    args = parser.parse_args(argv)
    os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")

    from tsad_drake.scenes import generate_scenario
    from tsad_drake.station import MakeStation

    scenario = generate_scenario(args.scenario, args.seed)
    start = time.perf_counter()
    station = MakeStation(scenario)
    build = time.perf_counter() - start

    thetas = list(station.observation_q)
    start = time.perf_counter()
    station.render(thetas[0])
    first = time.perf_counter() - start

    # Depth only, alternating views so every frame is a fresh render (not a cached output).
    port = station.sensor.depth_image_32F_output_port()
    start = time.perf_counter()
    for k in range(args.frames):
        station.set_arm_positions(station.observation_q[thetas[k % len(thetas)]])
        port.Eval(station.sensor_context)
    fps = args.frames / (time.perf_counter() - start)

    start = time.perf_counter()
    for theta in thetas:
        station.render(theta)  # depth + label + camera pose
    sweep = time.perf_counter() - start

    print(f"scenario {args.scenario} seed {args.seed}: {len(scenario.objects)} objects, "
          f"{len(thetas)} views")
    print(f"station build (diagram + observation IK): {build:.3f} s")
    print(f"first frame (renderer warm-up):           {first:.3f} s")
    print(f"depth frames per second (128x128):        {fps:.1f}")
    print(f"all {len(thetas)} views, depth + label:            {sweep * 1000:.1f} ms")


if __name__ == "__main__":
    main()
