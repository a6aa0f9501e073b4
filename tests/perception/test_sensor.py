"""The depth sensor model: noise law, quantisation, silhouette effects, presets and bad input."""

import numpy as np
import pytest

from tsad_drake.perception.sensor import (
    SENSOR_PRESETS,
    SensorConfig,
    apply_sensor,
    fuse_frames,
    noise_level_sensor,
    read_depth,
    sensor_config,
)


def _step_image(near: float = 0.4, far: float = 0.6, size: int = 128) -> np.ndarray:
    """Left half at `near`, right half at `far`: one vertical depth edge."""
    depth = np.full((size, size), far)
    depth[:, : size // 2] = near
    return depth


def test_ideal_sensor_returns_the_rendering() -> None:
    depth = _step_image()
    depth[0, 0] = np.inf
    out = apply_sensor(depth, SENSOR_PRESETS["ideal"], np.random.default_rng(0))
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out, depth.astype(np.float32))


def test_noise_grows_with_range_as_stated() -> None:
    sensor = SensorConfig(noise_sigma0=0.0005, noise_sigma2=0.005)
    rng = np.random.default_rng(1)
    for z in (0.3, 0.6):
        depth = np.full((256, 256), z)
        err = apply_sensor(depth, sensor, rng).astype(float) - z
        assert abs(err.mean()) < 1e-4
        assert err.std() == pytest.approx(sensor.sigma(z), rel=0.05)
    assert sensor.sigma(0.6) > 2 * sensor.sigma(0.3) - sensor.noise_sigma0


def test_quantisation_rounds_to_millimetres() -> None:
    sensor = SensorConfig(quantisation=0.001)
    depth = np.full((8, 8), 0.43217)
    out = apply_sensor(depth, sensor, np.random.default_rng(0)).astype(float)
    np.testing.assert_allclose(out, 0.432, atol=1e-6)


def test_silhouettes_drop_out_or_fly_and_the_rest_stays() -> None:
    sensor = SensorConfig(edge_dropout=0.5, flying_pixel=1.0, edge_jump=0.01)
    depth = _step_image()
    out = apply_sensor(depth, sensor, np.random.default_rng(2)).astype(float)
    edge_columns = out[:, 63:65]
    dropped = ~np.isfinite(edge_columns)
    assert 0.35 < dropped.mean() < 0.65  # half the silhouette pixels give no reading
    flying = edge_columns[~dropped]
    assert np.all((flying >= 0.4 - 1e-6) & (flying <= 0.6 + 1e-6))
    assert np.mean((flying > 0.41) & (flying < 0.59)) > 0.8  # between the two surfaces
    interior = np.delete(out, [63, 64], axis=1)
    np.testing.assert_allclose(interior, np.delete(depth, [63, 64], axis=1), atol=1e-6)


def test_same_seed_same_reading() -> None:
    sensor = SENSOR_PRESETS["realistic"]
    depth = _step_image()
    a = apply_sensor(depth, sensor, np.random.default_rng(5))
    b = apply_sensor(depth, sensor, np.random.default_rng(5))
    c = apply_sensor(depth, sensor, np.random.default_rng(6))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_presets_and_overrides() -> None:
    realistic = sensor_config("realistic")
    assert not realistic.ideal and sensor_config("ideal").ideal
    assert realistic.frames == 8 and sensor_config("ideal").frames == 1
    assert realistic.sigma(0.4) == pytest.approx(0.0005 + 0.005 * 0.16)
    assert sensor_config("realistic", noise_sigma0=0.002).noise_sigma0 == 0.002
    assert noise_level_sensor(0.004).sigma(0.9) == pytest.approx(0.004)


@pytest.mark.parametrize("bad", [
    lambda: sensor_config("kinect"),
    lambda: sensor_config("realistic", noise=0.1),
    lambda: SensorConfig(noise_sigma0=-0.001),
    lambda: SensorConfig(edge_dropout=1.5),
    lambda: SensorConfig(edge_jump=0.0),
    lambda: SensorConfig(frames=0),
    lambda: sensor_config("realistic", frames=2.5),
])
def test_bad_sensor_input_is_a_value_error(bad) -> None:
    with pytest.raises(ValueError):
        bad()


def test_one_frame_reads_as_the_sensor_alone() -> None:
    """frames=1 draws exactly what `apply_sensor` draws: rows measured before frames existed
    reproduce."""
    sensor = sensor_config("realistic", frames=1)
    depth = _step_image()
    np.testing.assert_array_equal(read_depth(depth, sensor, np.random.default_rng(4)),
                                  apply_sensor(depth, sensor, np.random.default_rng(4)))


def test_fused_frames_average_the_noise_and_drop_flying_pixels() -> None:
    """Eight frames of the realistic sensor: the noise on a flat surface falls by more than 2x
    without bias, flying pixels at the silhouette are gone, and more silhouette pixels are read
    than in one frame."""
    eight = sensor_config("realistic")
    one = sensor_config("realistic", frames=1)
    depth = _step_image(0.4, 0.6, 256)
    single = read_depth(depth, one, np.random.default_rng(7)).astype(float)
    fused = read_depth(depth, eight, np.random.default_rng(7)).astype(float)
    flat = np.delete(np.arange(256), [127, 128])
    for out in (single, fused):
        assert np.isfinite(out[:, flat]).mean() > 0.98
    err_single = (single - depth)[:, flat][np.isfinite(single[:, flat])]
    err_fused = (fused - depth)[:, flat][np.isfinite(fused[:, flat])]
    assert abs(err_fused.mean()) < 1e-4
    assert err_fused.std() < err_single.std() / 2
    edge = fused[:, 127:129]
    read = np.isfinite(edge)
    assert read.mean() > np.isfinite(single[:, 127:129]).mean()
    def flying(out: np.ndarray) -> float:
        seen = out[np.isfinite(out)]
        return float(np.mean((seen > 0.41) & (seen < 0.59)))

    assert flying(single[:, 127:129]) > 0.15
    assert flying(edge) < 0.05  # a flying reading in a minority of frames is left out


def test_a_pixel_read_in_fewer_than_half_the_frames_is_no_reading() -> None:
    frames = np.full((4, 1, 3), 0.5)
    frames[:3, 0, 0] = np.inf  # read once
    frames[:2, 0, 1] = np.inf  # read twice: kept
    frames[0, 0, 2] = 0.45  # one outlier among four readings
    out = fuse_frames(frames, SensorConfig(noise_sigma0=0.001))
    assert not np.isfinite(out[0, 0])
    assert out[0, 1] == pytest.approx(0.5)
    assert out[0, 2] == pytest.approx(0.5)


def test_station_path_and_ray_caster_read_through_the_same_sensor() -> None:
    """`observe(station)` and `observe_raycast` apply one sensor model: a station that renders
    with the ray caster gives the very same noisy views for the same noise seed."""
    from tsad_drake.perception.observe import observe, observe_raycast, perception_config
    from tsad_drake.scenes import generate_scenario
    from tsad_drake.viewpoints import CameraConfig, camera_pose, raycast, scenario_prisms

    scenario = generate_scenario("1", 0)
    camera = CameraConfig()

    class RaycastStation:
        def __init__(self) -> None:
            self.scenario, self.camera = scenario, camera

        def render(self, theta: float):
            X_SC = camera_pose(scenario.shelf, camera, theta)
            depth, label = raycast(scenario_prisms(scenario), camera, X_SC)
            return depth, label, X_SC

    sensor = SENSOR_PRESETS["realistic"]
    config = perception_config(sensor)
    a = observe(RaycastStation(), sensor=sensor, config=config, noise_seed=[3, 0])
    b = observe_raycast(scenario, camera, sensor=sensor, config=config, noise_seed=[3, 0])
    for va, vb in zip(a.views, b.views, strict=True):
        np.testing.assert_array_equal(va.depth, vb.depth)
    assert not np.array_equal(a.views[0].depth, observe_raycast(scenario).views[0].depth)
    np.testing.assert_allclose(a.cloud.points, b.cloud.points)
