"""`tsad render`: build the station, observe from every approach angle, write the results.

Everything is computed in memory first and written into a hidden temporary folder inside the
output directory, then renamed into place, so an interrupted or failed run never leaves files that
look complete and nothing is written outside the output directory.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from tsad_drake.outputs import OutputDir
from tsad_drake.runtime import detail
from tsad_drake.scenario import Scenario, save_scenario

OUTPUT_FILES = ("depth.npy", "depth.png", "labels.npy", "cloud.ply", "segments.npy",
                "segments.json", "scene.yaml")


def _depth_sheet(views, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(views), figsize=(2.2 * len(views), 2.6))
    axes = np.atleast_1d(axes)
    finite = np.concatenate([v.depth[np.isfinite(v.depth)] for v in views])
    vmin, vmax = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    for ax, view in zip(axes, views):
        ax.imshow(np.where(np.isfinite(view.depth), view.depth, np.nan), cmap="viridis",
                  vmin=vmin, vmax=vmax)
        ax.set_title(f"{math.degrees(view.theta):+.0f} deg", fontsize=9)
        ax.axis("off")
    fig.suptitle(f"wrist-camera depth [{vmin:.2f}, {vmax:.2f}] m", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _write_cloud(points: np.ndarray, segment_index: np.ndarray, path: Path) -> None:
    import open3d as o3d

    palette = np.array([[0.12, 0.47, 0.71], [1.0, 0.5, 0.05], [0.17, 0.63, 0.17],
                        [0.84, 0.15, 0.16], [0.58, 0.4, 0.74], [0.55, 0.34, 0.29],
                        [0.89, 0.47, 0.76], [0.5, 0.5, 0.5], [0.74, 0.74, 0.13],
                        [0.09, 0.75, 0.81]])
    colours = np.where(segment_index[:, None] >= 0,
                       palette[np.maximum(segment_index, 0) % len(palette)], 0.8)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    cloud.colors = o3d.utility.Vector3dVector(colours)
    if not o3d.io.write_point_cloud(str(path), cloud):
        raise OSError(f"open3d could not write {path}")


def render_and_write(scenario: Scenario, out: OutputDir | Path, segmentation: str = "label",
                     sensor: str = "ideal", noise_seed: int = 0) -> dict:
    """Observe `scenario` through the Drake station (depth through the `sensor` preset, its
    noise drawn from `noise_seed`) and write the render outputs into `out`."""
    from tsad_drake.perception.observe import observe, perception_config, summary_table
    from tsad_drake.perception.sensor import sensor_config
    from tsad_drake.station import MakeStation

    t0 = time.perf_counter()
    station = MakeStation(scenario)
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    model = sensor_config(sensor)
    observation = observe(station, segmentation=segmentation, config=perception_config(model),
                          sensor=model, noise_seed=noise_seed)
    t_observe = time.perf_counter() - t0

    cloud = observation.cloud
    segment_index = np.full(len(cloud), -1, dtype=np.int64)
    for k, seg in enumerate(observation.segments):
        segment_index[seg.indices] = k
    segments_array = np.concatenate([cloud.points, segment_index[:, None]], axis=1)
    summary = {
        "scenario": scenario.name, "seed": scenario.seed, "segmentation": segmentation,
        "sensor": sensor,
        "approach_angles_deg": [math.degrees(v.theta) for v in observation.views],
        "camera_poses_X_SC": [v.X_SC.tolist() for v in observation.views],
        "target": observation.scene.target,
        "segments": [{"index": k, "name": o.name, "points": int(len(o.points)),
                      "x": o.x, "y": o.y, "yaw_deg": math.degrees(o.yaw),
                      "is_target": o.is_target}
                     for k, o in enumerate(observation.scene.objects)],
        "station_build_s": t_build, "observation_s": t_observe,
    }
    out = out if isinstance(out, OutputDir) else OutputDir(out)
    staging = Path(tempfile.mkdtemp(prefix=".staging-", dir=out.root))
    try:
        np.save(staging / "depth.npy", np.stack([v.depth for v in observation.views])
                .astype(np.float32))
        np.save(staging / "labels.npy", np.stack([v.label for v in observation.views])
                .astype(np.int32))
        _depth_sheet(observation.views, staging / "depth.png")
        _write_cloud(cloud.points, segment_index, staging / "cloud.ply")
        np.save(staging / "segments.npy", segments_array.astype(np.float32))
        (staging / "segments.json").write_text(json.dumps(summary, indent=2))
        save_scenario(scenario, staging / "scene.yaml")
        for name in OUTPUT_FILES:
            os.replace(staging / name, out / name)
    finally:
        shutil.rmtree(staging, ignore_errors=True)

    print(f"scenario {scenario.name} seed {scenario.seed}: {len(scenario.objects)} objects, "
          f"target {scenario.target}; station built in {t_build:.2f} s, "
          f"{len(observation.views)} views + {segmentation} segmentation in {t_observe:.2f} s")
    detail(summary_table(observation.scene))
    print(f"wrote {', '.join(OUTPUT_FILES)} to {out}")
    return summary
