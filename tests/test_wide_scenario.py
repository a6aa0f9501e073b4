"""Scenario `wide`: a 0.75 m shelf with a grid of the paper's cells, 3-9 objects, the target hidden
in the front view; the station reaches all of it; TSAD's plan executes in the world model."""

import numpy as np

from tsad_drake.pipeline import EpisodeSettings, run_settings
from tsad_drake.placement import place_station
from tsad_drake.scenario import validate
from tsad_drake.scenes import generate_scenario
from tsad_drake.viewpoints import CameraConfig, camera_pose, raycast, scenario_prisms


def test_wide_scenes_are_wide_varied_hidden_and_reachable():
    camera = CameraConfig()
    scenes = [generate_scenario("wide", seed) for seed in range(8)]
    counts = set()
    for scene in scenes:
        validate(scene)
        assert scene.shelf.width == 0.75 and (scene.grid.cells_x, scene.grid.cells_y) == (5, 9)
        assert 3 <= len(scene.objects) <= 9
        counts.add(len(scene.objects))
        index = scene.target_index()
        X_SC = camera_pose(scene.shelf, camera, 0.0)
        _, alone = raycast(scenario_prisms(scene, only=[index]), camera, X_SC)
        _, full = raycast(scenario_prisms(scene), camera, X_SC)
        assert np.any(alone == index) and not np.any(full == index)  # hidden, not out of view
    assert len(counts) >= 3  # the object count varies by seed
    assert generate_scenario("wide", 3) == scenes[3]  # reproducible
    placement = place_station(scenes[0])
    assert not placement.moved and not placement.report.unreachable


def test_tsad_retrieves_the_hidden_target_on_the_wide_shelf():
    scene = generate_scenario("wide", 1000)
    row = run_settings(scene, 1000, EpisodeSettings(planner="tsad", feasibility="geometric"))
    assert row["success"], row["failure_reason"]
    assert 1 <= row["num_actions"] <= 12
