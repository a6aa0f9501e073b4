"""Segmentation: label mode finds every visible object; cluster mode matches it from geometry."""

import numpy as np
import pytest

from tsad_drake.perception.observe import observe_raycast
from tsad_drake.perception.pointcloud import LabelledCloud
from tsad_drake.perception.segmentation import (
    point_iou_matching,
    segment,
    segment_by_cluster,
    segment_by_label,
)
from tsad_drake.scenario import ObjectConfig, Scenario
from tsad_drake.scenes import generate_scenario

SCENES = [("1", 0), ("1", 1), ("2", 0), ("2", 1), ("3", 0), ("3", 1)]


@pytest.fixture(scope="module")
def scenarios():
    return {key: generate_scenario(*key) for key in SCENES}


@pytest.fixture(scope="module")
def observations(scenarios):
    return {key: observe_raycast(scenario) for key, scenario in scenarios.items()}


@pytest.mark.parametrize("key", SCENES)
def test_label_segments_cover_every_visible_object(scenarios, observations, key):
    obs = observations[key]
    scenario = scenarios[key]
    visible = {scenario.objects[i].name for i in np.unique(obs.cloud.labels) if i >= 0}
    assert len(visible) >= 8
    assert set(obs.scene.names()) == visible
    assert obs.scene.target == scenario.target
    assert [o.name for o in obs.scene.objects if o.is_target] == [scenario.target]
    for seg in obs.segments:  # every point of a segment carries that object's label
        index = [o.name for o in scenario.objects].index(seg.name)
        assert np.all(obs.cloud.labels[seg.indices] == index)


@pytest.mark.parametrize("key", SCENES)
def test_cluster_segmentation_matches_labels(scenarios, observations, key):
    obs = observations[key]
    target_label = scenarios[key].target_index()
    clusters = segment_by_cluster(obs.cloud, target_label)
    mean_iou, matches = point_iou_matching([s.indices for s in obs.segments],
                                           [c.indices for c in clusters])
    assert mean_iou >= 0.8
    # the marked cluster is the one matched to the target segment
    target_row = [s.is_target for s in obs.segments].index(True)
    matched = {r: c for r, c, _ in matches}
    assert clusters[matched[target_row]].is_target
    assert sum(c.is_target for c in clusters) == 1
    # names are cluster<k> in order of centroid x (to 0.1 mm), then y
    assert [c.name for c in clusters] == [f"cluster{k}" for k in range(len(clusters))]
    keys = [tuple(np.round(c.points[:, :2].mean(axis=0), 4)) for c in clusters]
    assert keys == sorted(keys)


def test_touching_objects_of_different_heights_separate():
    """1-2 mm gaps (below the DBSCAN radius): the height-aware step still splits them."""
    objects = [
        ObjectConfig("a", "cylinder", "cylinder", [0.03, 0.18], 0.15, 0.0, 0.0),
        ObjectConfig("b", "square_pillar", "box", [0.05, 0.05, 0.12], 0.15, 0.057, 0.0),
        ObjectConfig("c", "cylinder", "cylinder", [0.03, 0.15], 0.15, -0.061, 0.0),
    ]
    obs = observe_raycast(Scenario(objects=objects, target="a"))
    clusters = segment(obs.cloud, "cluster", ["a", "b", "c"], 0)
    assert len(clusters) == 3
    mean_iou, _ = point_iou_matching([s.indices for s in obs.segments],
                                     [c.indices for c in clusters])
    assert mean_iou >= 0.9


def test_tiny_and_flat_clusters_are_dropped():
    rng = np.random.default_rng(0)
    column = np.c_[rng.uniform(0.10, 0.13, (400, 2)), rng.uniform(0.0, 0.15, 400)]
    speck = np.array([[0.25, -0.1, 0.05], [0.2502, -0.1, 0.051]])
    flat = np.c_[rng.uniform(0.2, 0.24, (200, 2)) - [0, 0.1], np.full(200, 0.01)]
    cloud = LabelledCloud(np.concatenate([column, speck, flat]),
                          np.r_[np.zeros(400), np.ones(2), np.full(200, 2)].astype(np.int32))
    clusters = segment_by_cluster(cloud, target_label=0)
    assert len(clusters) == 1 and clusters[0].is_target and len(clusters[0].indices) == 400


def test_label_segmentation_skips_background_and_unknown_mode():
    cloud = LabelledCloud(np.zeros((4, 3)), np.array([-1, 0, 0, 1], dtype=np.int32))
    segs = segment_by_label(cloud, ["a", "b"], target_label=1)
    assert [s.name for s in segs] == ["a", "b"] and [s.is_target for s in segs] == [False, True]
    with pytest.raises(ValueError, match="unknown segmentation"):
        segment(cloud, "magic", ["a", "b"], None)


def test_point_iou_matching_counts_missed_segments():
    truth = [np.arange(0, 10), np.arange(10, 20)]
    found = [np.arange(10, 20)]
    mean_iou, matches = point_iou_matching(truth, found)
    assert mean_iou == pytest.approx(0.5) and matches == [(1, 0, 1.0)]
