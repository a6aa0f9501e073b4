"""Perception under the realistic sensor: touching objects split, footprints repeat within their
stated uncertainty, pickability survives the noise, and a plan made under it works in the world."""

import dataclasses as dc

import numpy as np
import pytest

from studies.hull_errors import DIRECTIONS, support
from tsad_drake.perception.observe import observe_raycast, perception_config
from tsad_drake.perception.segmentation import point_iou_matching, segment
from tsad_drake.perception.sensor import sensor_config
from tsad_drake.pipeline import EpisodeSettings, run_settings
from tsad_drake.planning.feasibility import GeometricFeasibility, OracleFeasibility
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.scenario import ObjectConfig, Scenario
from tsad_drake.scenes import generate_scenario

REALISTIC = sensor_config("realistic")


def _observe(scenario, segmentation="label", noise_seed=0, sensor=REALISTIC):
    return observe_raycast(scenario, segmentation=segmentation, sensor=sensor,
                           config=perception_config(sensor), noise_seed=noise_seed)


def _cluster_iou(scenario: Scenario, noise_seed: int) -> tuple[int, float]:
    obs = _observe(scenario, noise_seed=noise_seed)
    names = [o.name for o in scenario.objects]
    clusters = segment(obs.cloud, "cluster", names, 0, perception_config(REALISTIC).cluster)
    mean_iou, _ = point_iou_matching([s.indices for s in obs.segments],
                                     [c.indices for c in clusters])
    return len(clusters), mean_iou


@pytest.mark.parametrize("noise_seed", [0, 1])
def test_touching_boxes_of_equal_height_split_under_noise(noise_seed):
    """Two long boxes end to end, 2 mm apart, same height: one cluster would be longer than any
    object, so it is split in the floor plane."""
    objects = [
        ObjectConfig("a", "rectangular", "box", [0.045, 0.12, 0.14], 0.16, 0.062, 0.0),
        ObjectConfig("b", "rectangular", "box", [0.045, 0.12, 0.14], 0.16, -0.060, 0.0),
    ]
    count, mean_iou = _cluster_iou(Scenario(objects=objects, target="a"), noise_seed)
    assert count == 2 and mean_iou >= 0.85


@pytest.fixture(scope="module")
def scene_2_0():
    return generate_scenario("2", 0)


def test_cylinder_footprints_from_two_noise_seeds_agree_within_their_uncertainty(scene_2_0):
    """Well-seen cylinders (>= 300 points): the two outlines differ, in every direction, by less
    than the sum of their stated uncertainties (boxes: see docs/known-issues.md)."""
    first = {o.name: o for o in _observe(scene_2_0, noise_seed=1).scene.objects}
    second = {o.name: o for o in _observe(scene_2_0, noise_seed=2).scene.objects}
    checked = 0
    for name, a in first.items():
        b = second.get(name)
        if b is None or a.shape != "cylinder" or b.shape != "cylinder" or len(a.points) < 300:
            continue
        diff = np.abs(support(a.outline, DIRECTIONS) - support(b.outline, DIRECTIONS)).max()
        assert diff <= a.uncertainty + b.uncertainty, name
        assert 0 < a.uncertainty < 0.003
        checked += 1
    assert checked >= 3


def test_robust_pipeline_keeps_pickability_under_noise(scene_2_0):
    """Against the oracle, the ideal pipeline's hulls on realistic readings lose nearly every pick
    (the noisy hulls close the corridors); the fitted footprints keep almost all of them."""
    workspace = make_workspace(scene_2_0)
    oracle = OracleFeasibility(scene_2_0, workspace)

    def true_picks(config, noise_seed):
        obs = observe_raycast(scene_2_0, sensor=REALISTIC, config=config, noise_seed=noise_seed)
        state = state_from_perception(obs.scene)
        model = GeometricFeasibility(workspace)
        both = wrong = 0
        for i in range(len(state.objects)):
            mine, truth = model.pickable(state, i), oracle.pickable(state, i)
            both += int((mine & truth).sum())
            wrong += int((mine & ~truth).sum())
        return np.array([both, wrong])

    ideal_state = state_from_perception(observe_raycast(scene_2_0).scene)
    reference = 3 * sum(int(oracle.pickable(ideal_state, i).sum())
                        for i in range(len(ideal_state.objects)))
    robust = sum(true_picks(perception_config(REALISTIC), seed) for seed in range(3))
    plain = sum(true_picks(None, seed) for seed in range(3))
    assert robust[0] >= 0.7 * reference and robust[1] == 0
    assert plain[0] <= 0.3 * reference


def test_a_plan_made_under_realistic_sensing_succeeds_in_the_world():
    """Scenario 2 seed 5, label segmentation, realistic sensor: TSAD on the geometric model
    plans on noisy readings, the geometric world executes on the true scene."""
    settings = EpisodeSettings(sensor="realistic", segmentation="label")
    row = run_settings(generate_scenario("2", 5), 5, settings)
    assert row["success"] and row["falls"] == 0 and row["num_actions"] <= 4
    assert row["sensor"] == "realistic"


def test_bad_sensor_name_in_settings_is_a_value_error():
    with pytest.raises(ValueError, match="unknown sensor"):
        EpisodeSettings(sensor="lidar").sensor_config()



def test_a_box_seen_on_one_face_is_a_box_not_a_wide_cylinder():
    """A flat face can fit a circle of the largest plausible radius as well as a rectangle: on
    scenario 2 seed 2 under realistic sensing (cluster segmentation with DBSCAN min_points 6) the
    45 mm target box came out as a 60 mm-radius cylinder, too wide for the gripper, and the episode
    failed at once. A circle held at that bound is a face."""
    from tsad_drake.perception.footprint import fit_cylinder, fit_footprint
    from tsad_drake.perception.pose import estimate_planar_pose

    sensor = sensor_config("realistic")
    config = perception_config(sensor)
    config.cluster = dc.replace(config.cluster, min_points=6, top_join_gap=0.05)
    scenario = generate_scenario("2", 2)
    observation = observe_raycast(scenario, segmentation="cluster", sensor=sensor, config=config,
                                  noise_seed=2)
    points = next(s for s in observation.segments if s.is_target).points
    _, radius, _ = fit_cylinder(points, config.pose, config.footprint)
    assert radius == pytest.approx(config.pose.max_radius)  # the case the rule is for
    fit = fit_footprint(points, estimate_planar_pose(points, config.pose), config.pose,
                        config.footprint)
    target = scenario.object(scenario.target)
    assert fit.shape == "box"
    assert max(fit.size) == pytest.approx(target.size[0], abs=0.008)



def test_a_piece_inside_a_neighbours_outline_joins_it():
    """`explained_points`: a small segment whose points a bigger neighbour's fitted outline holds
    (a corner of a box cut off by an occluder) joins that neighbour; a small object beside it,
    and the target, stay objects of their own."""
    from tsad_drake.geometry2d import footprint_polygon
    from tsad_drake.perception.footprint import FootprintConfig
    from tsad_drake.perception.observe import join_explained
    from tsad_drake.perception.types import PerceivedObject

    def obj(name, x, y, n, size=0.05, target=False):
        rng = np.random.default_rng(n)
        pts = np.c_[rng.uniform(x - size / 2, x + size / 2, n),
                    rng.uniform(y - size / 2, y + size / 2, n), rng.uniform(0, 0.1, n)]
        return PerceivedObject(name, pts, x, y, 0.0, is_target=target, shape="box",
                               size=(size, size),
                               outline=footprint_polygon("box", (size, size), x, y, 0.0))

    big = obj("big", 0.10, 0.0, 1500)
    corner = obj("corner", 0.118, 0.018, 40, size=0.01)  # inside big's outline
    beside = obj("beside", 0.10, 0.07, 40, size=0.01)  # 45 mm off big's side
    small_target = obj("target", 0.12, -0.02, 40, size=0.01, target=True)
    config = FootprintConfig(fitted=True, explained_points=150)
    joined = join_explained([big, corner, beside, small_target], config)
    names = [o.name for o in joined]
    assert names == ["big", "beside", "target"]
    assert len(joined[0].points) == 1540
    off = join_explained([big, corner, beside], FootprintConfig(fitted=True, explained_points=30))
    assert [o.name for o in off] == ["big", "corner", "beside"]  # 40 points are no piece below 30


def test_a_short_box_side_grows_at_its_hidden_end_not_at_the_face_seen():
    """A box seen on its front and one side face, whose top cap is cut short on the hidden side,
    is completed to the smallest plausible side at the hidden end: the face seen stays where its
    points are. (Held-out scenario 2 seed 1020: a 44 mm box grown symmetrically was drawn 2 mm
    into the target's corridor, which the truth cleared, and the episode ran to its action limit.)
    """
    from tsad_drake.perception.footprint import fit_box

    config = perception_config(REALISTIC)
    rng = np.random.default_rng(7)
    length, width, height, yaw = 0.12, 0.044, 0.13, np.radians(-12.5)
    # box frame (u along the box, v across): the front face and the cap seen up to 12 mm short of
    # the hidden +v side (a neighbour hides it), the -v side face, the back hidden
    front = np.c_[np.full(300, -length / 2), rng.uniform(-width / 2, width / 2 - 0.012, 300),
                  rng.uniform(0.01, height - 0.01, 300)]
    side = np.c_[rng.uniform(-length / 2, length / 2 - 0.01, 400), np.full(400, -width / 2),
                 rng.uniform(0.01, height - 0.01, 400)]
    cap = np.c_[rng.uniform(-length / 2, length / 2 - 0.01, 300),
                rng.uniform(-width / 2, width / 2 - 0.012, 300), np.full(300, height)]
    local = np.concatenate([front, side, cap])
    local += rng.normal(0.0, 0.0003, local.shape)
    c, s = np.cos(yaw), np.sin(yaw)
    centre_true = np.array([0.19, -0.03])
    points = local.copy()
    points[:, :2] = local[:, :2] @ np.array([[c, s], [-s, c]]) + centre_true
    centre, size, _ = fit_box(points, yaw, config.pose, config.footprint)
    axis_u, axis_v = np.array([c, s]), np.array([-s, c])
    offset = centre - centre_true
    seen_side = offset @ axis_v - size[1] / 2  # where the fit puts the -v face (truth -width/2)
    front_face = offset @ axis_u - size[0] / 2
    assert size[1] == pytest.approx(config.pose.min_box_side, abs=1e-6)  # completed: 32 -> 40 mm
    assert seen_side == pytest.approx(-width / 2, abs=0.0005)
    assert front_face == pytest.approx(-length / 2, abs=0.0005)


def test_a_long_box_seen_end_on_keeps_the_width_between_its_seen_sides():
    """A long box seen end-on looks like a short one; it may be completed as a square pillar
    along its hidden length, but not across: both its sides were seen (one as a face, the other
    as the corner's edge), so its width is measured. (Held-out scenario 2 seed 1004: a 42 mm wide
    box squared to 51 mm was drawn 5 mm into a corridor the truth cleared by 4 mm.)"""
    from tsad_drake.perception.footprint import fit_box

    config = perception_config(REALISTIC)
    rng = np.random.default_rng(11)
    length, width, height = 0.12, 0.042, 0.15
    seen = 0.05  # of the length (longer than the width): the rest is hidden behind the front
    front = np.c_[np.full(400, -length / 2), rng.uniform(-width / 2, width / 2, 400),
                  rng.uniform(0.01, height - 0.01, 400)]
    side = np.c_[rng.uniform(-length / 2, -length / 2 + seen, 250), np.full(250, -width / 2),
                 rng.uniform(0.01, height - 0.01, 250)]
    corner = np.c_[rng.uniform(-length / 2, -length / 2 + 0.002, 30), np.full(30, width / 2),
                   rng.uniform(0.01, height - 0.01, 30)]
    cap = np.c_[rng.uniform(-length / 2, -length / 2 + seen, 300),
                rng.uniform(-width / 2, width / 2, 300), np.full(300, height)]
    points = np.concatenate([front, side, corner, cap])
    points += rng.normal(0.0, 0.0003, points.shape)
    points[:, :2] += np.array([0.2, 0.0])
    centre, size, _ = fit_box(points, 0.0, config.pose, config.footprint)
    assert size[1] == pytest.approx(width, abs=0.001)
    assert centre[1] == pytest.approx(0.0, abs=0.0005)
    assert size[0] > config.pose.min_box_side  # the hidden length is still completed
