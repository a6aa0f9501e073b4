"""Planar pose fits: circle and rectangle models, hidden-extent completion, accuracy on scenes."""

import math

import numpy as np
import pytest

from studies.perception_timing import pose_errors
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.perception.pose import (
    PoseConfig,
    estimate_planar_pose,
    fit_circle,
    fit_rectangle_yaw,
)
from tsad_drake.prehensile.dataset import training_generator
from tsad_drake.scenes import generate_scenario

#: stated tolerances for visible objects (>= 100 fused points) on noise-free ray-cast scenes
CENTRE_TOLERANCE = 0.005  #: m
YAW_TOLERANCE_DEG = 3.0  #: deg, modulo 90 for boxes


def _column(xy: np.ndarray, height: float = 0.15, levels: int = 20) -> np.ndarray:
    """Stack 2D outline samples into a vertical wall of 3D points (no top cap)."""
    return np.concatenate([np.c_[xy, np.full(len(xy), z)]
                           for z in np.linspace(0.01, height - 0.01, levels)])


def test_circle_fit_recovers_centre_from_a_front_arc():
    angles = np.radians(np.linspace(120, 240, 40))  # the front (-x) quarter-third of the circle
    xy = np.c_[0.2 + 0.03 * np.cos(angles), -0.05 + 0.03 * np.sin(angles)]
    centre, radius, rms = fit_circle(xy, 0.015, 0.06)
    np.testing.assert_allclose(centre, [0.2, -0.05], atol=1e-6)
    assert radius == pytest.approx(0.03, abs=1e-6) and rms < 1e-6


def test_circle_fit_clamps_the_radius_of_a_flat_face():
    xy = np.c_[np.zeros(30), np.linspace(-0.02, 0.02, 30)]
    centre, radius, _ = fit_circle(xy, 0.015, 0.06)
    assert radius == pytest.approx(0.06)
    assert centre[0] > 0  # the circle lies behind the face (away from the camera at -x)


def test_rectangle_yaw_from_two_visible_faces():
    yaw = math.radians(25.0)
    c, s = math.cos(yaw), math.sin(yaw)
    t = np.linspace(-0.025, 0.025, 30)
    front = np.c_[np.full(30, -0.025), t]  # faces at u = -a/2 and v = -a/2 in the box frame
    side = np.c_[t, np.full(30, -0.025)]
    local = np.concatenate([front, side])
    xy = local @ np.array([[c, s], [-s, c]]) + [0.15, 0.0]
    found, rms = fit_rectangle_yaw(xy)
    assert abs(found - yaw) < math.radians(0.2) and rms < 1e-4


def test_front_face_only_box_is_pushed_back():
    """Only the front face of a 50 mm pillar is seen: centre completes to half a side behind it."""
    face = np.c_[np.full(40, 0.175), np.linspace(-0.025, 0.025, 40)]
    pose = estimate_planar_pose(_column(face), PoseConfig())
    assert pose.shape == "box"
    assert math.hypot(pose.x - 0.2, pose.y) < 0.002  # the centroid would be 25 mm off
    assert abs(pose.yaw) < math.radians(1.0)


def test_round_and_flat_segments_are_told_apart():
    angles = np.radians(np.linspace(100, 260, 50))
    arc = np.c_[0.1 + 0.03 * np.cos(angles), 0.03 * np.sin(angles)]
    assert estimate_planar_pose(_column(arc)).shape == "cylinder"
    face = np.c_[np.full(40, 0.1), np.linspace(-0.02, 0.02, 40)]
    assert estimate_planar_pose(_column(face)).shape == "box"


@pytest.fixture(scope="module")
def scene_errors():
    rows = []
    for name, seed in [("1", 0), ("2", 0), ("3", 0), ("2", 3)]:
        # the network's training scenes (see tests/perception/test_observe.py's fixture)
        scenario = generate_scenario(name, seed, config=training_generator(name))
        rows += pose_errors(scenario, observe_raycast(scenario))
    return rows


def test_centres_and_yaws_match_truth_on_generated_scenes(scene_errors):
    visible = [r for r in scene_errors if r["points"] >= 100]
    assert len(visible) >= 35
    for row in visible:
        assert row["centre_error"] < CENTRE_TOLERANCE, row
        assert row["shape_ok"], row
        if row["yaw_error_deg"] is not None:
            assert row["yaw_error_deg"] < YAW_TOLERANCE_DEG, row


def test_pose_survives_depth_noise():
    """1 mm depth noise: median centre error stays within a few millimetres."""
    scenario = generate_scenario("1", 1)
    rows = pose_errors(scenario, observe_raycast(scenario, depth_noise=0.001, noise_seed=1))
    centre = np.array([r["centre_error"] for r in rows])
    assert np.median(centre) < 0.004
    assert np.mean([r["shape_ok"] for r in rows]) >= 0.8
