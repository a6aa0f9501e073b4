"""The station: observation poses reached without collision, and renders that agree with geometry."""

import copy

import numpy as np
import pytest
from pydrake.math import RotationMatrix

from tsad_drake.geometry2d import convex_polygon_distance
from tsad_drake.scenes import generate_scenario
from tsad_drake.station import MakeStation, StationConfig
from tsad_drake.station_ik import ObservationPoseError
from tsad_drake.viewpoints import camera_pose, raycast, scenario_prisms, shelf_prisms


@pytest.fixture(scope="module")
def scenario():
    return generate_scenario("1", 3)


@pytest.fixture(scope="module")
def station(scenario):
    return MakeStation(scenario)


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    union = np.count_nonzero(a | b)
    return np.count_nonzero(a & b) / union if union else 1.0


def test_station_has_the_scenario(station, scenario):
    assert [b.name() for b in station.object_bodies] == [o.name for o in scenario.objects]
    np.testing.assert_allclose(sorted(station.observation_q), sorted(scenario.approach_angles))
    info = station.sensor.default_depth_render_camera().core().intrinsics()
    assert (info.width(), info.height()) == (128, 128)
    assert info.focal_x() == pytest.approx(station.camera_config.focal_length())
    X_WS = station.X_WS.GetAsMatrix4()
    assert X_WS[2, 3] == pytest.approx(scenario.shelf.floor_height)
    np.testing.assert_allclose(X_WS[:3, :3], np.eye(3))


def test_observation_poses_reach_the_viewpoints(station, scenario):
    for theta, q in station.observation_q.items():
        assert q.shape == (6,)
        _, _, X_SC = station.render(theta)
        wanted = camera_pose(scenario.shelf, station.camera_config, theta)
        assert np.linalg.norm(X_SC[:3, 3] - wanted[:3, 3]) < 1e-3
        angle = RotationMatrix(wanted[:3, :3].T @ X_SC[:3, :3]).ToAngleAxis().angle()
        assert np.degrees(angle) < 1.0


def test_observation_poses_are_collision_free(station):
    plant, inspector = station.plant, station.scene_graph.model_inspector()
    robot_geometries = set()
    for instance in (station.robot, station.gripper):
        for index in plant.GetBodyIndices(instance):
            robot_geometries.update(plant.GetCollisionGeometriesForBody(plant.get_body(index)))
    others = set()
    for body in [plant.GetBodyByName("shelf"), *station.object_bodies]:
        others.update(plant.GetCollisionGeometriesForBody(body))
    assert robot_geometries and others
    query_port = station.scene_graph.get_query_output_port()
    for theta, q in station.observation_q.items():
        station.set_arm_positions(q)
        query = query_port.Eval(station.scene_graph.GetMyContextFromRoot(station.context))
        for pair in query.ComputePointPairPenetration():
            assert not ({pair.id_A, pair.id_B} & robot_geometries), (
                f"theta {np.degrees(theta):.0f}: {inspector.GetName(pair.id_A)} penetrates "
                f"{inspector.GetName(pair.id_B)}")
        clearance = min(
            d.distance for d in query.ComputeSignedDistancePairwiseClosestPoints(1.0)
            if (d.id_A in robot_geometries and d.id_B in others)
            or (d.id_B in robot_geometries and d.id_A in others))
        assert clearance > 0.0


def test_depth_matches_the_shelf_surfaces(station, scenario):
    moved = copy.deepcopy(scenario.objects)
    for obj in moved:
        obj.x += 10.0  # far behind the shelf and out of range: only the shelf is left to see
    station.set_objects(moved)
    try:
        depth, label, X_SC = station.render(0.0)
    finally:
        station.set_objects(scenario.objects)
    assert np.all(label == -1)
    expected, _ = raycast(shelf_prisms(scenario.shelf), station.camera_config, X_SC)
    seen = np.isfinite(expected)
    assert np.array_equal(np.isfinite(depth), seen)
    assert np.count_nonzero(seen) > 0.5 * seen.size
    assert np.max(np.abs(depth[seen] - expected[seen])) < 0.005
    # By hand: the optical axis meets the floor at the workspace centre (the look-at point), so
    # the four pixels around the principal point see the floor at about that distance.
    look_at = np.array([scenario.shelf.depth / 2, 0.0, station.camera_config.look_at_height])
    axis_distance = np.linalg.norm(look_at - X_SC[:3, 3])
    assert np.mean(depth[63:65, 63:65]) == pytest.approx(axis_distance, abs=0.005)


def test_label_image_agrees_with_raycast(station, scenario):
    prisms = scenario_prisms(scenario)
    for theta in scenario.approach_angles:
        depth, label, X_SC = station.render(theta)
        expected_depth, expected = raycast(prisms, station.camera_config, X_SC)
        assert depth.dtype == np.float32 and label.dtype == np.int32
        assert set(np.unique(label)) <= set(range(-1, len(scenario.objects)))
        # every pixel's label agrees but for a thin band along silhouettes
        assert np.mean(label == expected) > 0.99
        # per object IoU, for objects big enough in the image for IoU to mean something
        visible = [i for i in range(len(scenario.objects)) if np.count_nonzero(expected == i) >= 30]
        assert visible
        for i in visible:
            iou = _iou(label == i, expected == i)
            assert iou >= 0.9, f"theta {np.degrees(theta):.0f}, object {i}: IoU {iou:.3f}"


def _free_spot(scenario, index):
    """A pose for object `index` in the front half, clear of every other object, or None."""
    others = [o.footprint() for j, o in enumerate(scenario.objects) if j != index]
    obj = copy.deepcopy(scenario.objects[index])
    for x in np.linspace(0.05, 0.15, 5):
        for y in np.linspace(-0.2, 0.2, 17):
            obj.x, obj.y = float(x), float(y)
            poly = obj.footprint()
            inside = poly[:, 0].min() > 0 and abs(poly[:, 1]).max() < scenario.shelf.width / 2
            if inside and min(convex_polygon_distance(poly, o) for o in others) > 0.01:
                return obj
    return None


def test_set_objects_moves_an_object_in_the_image(station, scenario):
    index = scenario.target_index()
    moved_object = _free_spot(scenario, index)
    assert moved_object is not None
    before = station.render(0.0)[1] == index
    moved = copy.deepcopy(scenario.objects)
    moved[index] = moved_object
    station.set_objects(moved)
    try:
        _, label, X_SC = station.render(0.0)
        pose = station.plant.EvalBodyPoseInWorld(station.plant_context,
                                                 station.object_bodies[index])
    finally:
        station.set_objects(scenario.objects)
    p_S = station.X_WS.inverse() @ pose.translation()
    np.testing.assert_allclose(p_S, [moved_object.x, moved_object.y, moved_object.height / 2])
    moved_scenario = copy.deepcopy(scenario)
    moved_scenario.objects = moved
    _, expected = raycast(scenario_prisms(moved_scenario), station.camera_config, X_SC)
    after = label == index
    assert np.count_nonzero(after) > 50
    assert _iou(after, expected == index) >= 0.9
    assert _iou(after, before) < 0.5
    # restored: the original image comes back
    assert np.array_equal(station.render(0.0)[1] == index, before)


def test_every_observation_pose_renders_its_own_view(station):
    """Each approach angle gives a depth image with the shelf in it, seen from its own camera pose
    (frame rates are measured by `python -m studies.station_timing`, not asserted)."""
    views = {theta: station.render(theta) for theta in station.observation_q}
    for depth, _, _ in views.values():
        assert np.isfinite(depth).mean() > 0.5 and np.nanmin(depth[np.isfinite(depth)]) > 0.0
    thetas = sorted(views)
    for a, b in zip(thetas[:-1], thetas[1:]):
        depth_a, _, pose_a = views[a]
        depth_b, _, pose_b = views[b]
        assert not np.allclose(np.asarray(pose_a), np.asarray(pose_b))
        seen_a, seen_b = (np.where(np.isfinite(d), d, 0.0) for d in (depth_a, depth_b))
        assert np.abs(seen_a - seen_b).max() > 0.01


def test_unreachable_viewpoint_raises_a_clear_error(scenario):
    config = StationConfig(shelf_distance=2.0, ik_seeds=2)
    with pytest.raises(ObservationPoseError, match="theta = 0.0 deg"):
        MakeStation(scenario, config=config)
