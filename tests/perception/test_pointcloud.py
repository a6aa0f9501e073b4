"""Depth -> point cloud: back-projection accuracy, shelf removal, label-consistent fusion."""

import numpy as np
import pytest

from tsad_drake.perception.pointcloud import (
    BACKGROUND_LABEL,
    CloudConfig,
    depth_to_cloud,
    fuse_clouds,
    majority_label,
    remove_shelf,
    views_to_cloud,
    workspace_mask,
)
from tsad_drake.scenario import ObjectConfig, Scenario
from tsad_drake.viewpoints import CameraConfig, camera_pose, raycast, scenario_prisms

BOX = ObjectConfig("box", "square_pillar", "box", [0.05, 0.05, 0.15], 0.15, 0.06, 0.3)
CYLINDER = ObjectConfig("can", "cylinder", "cylinder", [0.03, 0.17], 0.18, -0.08, 0.0)


@pytest.fixture(scope="module")
def scene():
    return Scenario(objects=[BOX, CYLINDER], target="can")


def _render(scenario, theta):
    camera = CameraConfig()
    X_SC = camera_pose(scenario.shelf, camera, theta)
    depth, label = raycast(scenario_prisms(scenario), camera, X_SC)
    return depth, label, X_SC, camera.intrinsics()


def _surface_distance(obj: ObjectConfig, p: np.ndarray) -> np.ndarray:
    """Unsigned distance of points on or near an upright prism to its surface."""
    c, s = np.cos(obj.yaw), np.sin(obj.yaw)
    u = (p[:, 0] - obj.x) * c + (p[:, 1] - obj.y) * s
    v = -(p[:, 0] - obj.x) * s + (p[:, 1] - obj.y) * c
    z = p[:, 2]
    to_cap = np.abs(z - obj.height)
    if obj.shape == "cylinder":
        side = np.abs(np.hypot(u, v) - obj.size[0])
    else:
        side = np.minimum(np.abs(np.abs(u) - obj.size[0] / 2), np.abs(np.abs(v) - obj.size[1] / 2))
    return np.minimum(side, to_cap)


@pytest.mark.parametrize("theta_deg", [-30.0, 0.0, 20.0])
def test_back_projection_lies_on_the_true_surfaces(scene, theta_deg):
    depth, label, X_SC, K = _render(scene, np.radians(theta_deg))
    cloud = depth_to_cloud(depth, K, X_SC, label)
    assert len(cloud) == np.count_nonzero(np.isfinite(depth))
    for index, obj in enumerate(scene.objects):
        pts = cloud.points[cloud.labels == index]
        assert len(pts) > 100
        assert _surface_distance(obj, pts).max() < 0.002


def test_box_front_face_is_reproduced(scene):
    """Axis-aligned box seen head on: its front face points sit on x = x0 - sx/2 and span it."""
    box = ObjectConfig("box", "square_pillar", "box", [0.06, 0.05, 0.15], 0.15, 0.0, 0.0)
    scenario = Scenario(objects=[box], target="box")
    depth, label, X_SC, K = _render(scenario, 0.0)
    cloud = depth_to_cloud(depth, K, X_SC, label)
    pts = cloud.points[cloud.labels == 0]
    front = pts[pts[:, 2] < box.height - 0.002]  # everything below the top cap
    assert np.abs(front[:, 0] - (box.x - box.size[0] / 2)).max() < 0.002
    assert front[:, 1].min() < -0.022 and front[:, 1].max() > 0.022
    assert front[:, 2].max() > 0.14


def test_shelf_points_are_removed(scene):
    depth, label, X_SC, K = _render(scene, np.radians(10.0))
    raw = depth_to_cloud(depth, K, X_SC, label)
    assert np.count_nonzero(raw.labels == BACKGROUND_LABEL) > 1000  # floor, walls, back seen
    kept = remove_shelf(raw, scene.shelf)
    assert np.count_nonzero(kept.labels == BACKGROUND_LABEL) == 0
    assert np.all(workspace_mask(kept.points, scene.shelf))
    # no object point is lost except those touching the floor
    for index in range(len(scene.objects)):
        lost = raw.points[(raw.labels == index)][~workspace_mask(
            raw.points[raw.labels == index], scene.shelf)]
        assert np.all(lost[:, 2] <= CloudConfig().floor_tolerance)


def test_majority_label_per_group():
    group = np.array([0, 0, 0, 1, 1, 2])
    labels = np.array([3, 3, 5, -1, 4, 7])
    assert majority_label(group, labels, 4).tolist() == [3, 4, 7, BACKGROUND_LABEL]


def test_fusion_keeps_labels_consistent(scene):
    views = [_render(scene, np.radians(t)) for t in (-30.0, 0.0, 30.0)]
    K = views[0][3]
    per_view = [remove_shelf(depth_to_cloud(d, K, X, lab), scene.shelf) for d, lab, X, _ in views]
    fused = fuse_clouds(per_view, voxel_size=0.004)
    raw_total = sum(len(c) for c in per_view)
    assert 0 < len(fused) < raw_total
    # each fused point's label is the label of the raw points next to it
    from scipy.spatial import cKDTree

    raw_points = np.concatenate([c.points for c in per_view])
    raw_labels = np.concatenate([c.labels for c in per_view])
    _, nearest = cKDTree(raw_points).query(fused.points)
    assert np.mean(raw_labels[nearest] == fused.labels) > 0.99
    assert set(np.unique(fused.labels)) == {0, 1}
    again = views_to_cloud([(d, lab, X) for d, lab, X, _ in views], K, scene.shelf,
                           CloudConfig(voxel_size=0.004))
    np.testing.assert_allclose(again.points, fused.points)
