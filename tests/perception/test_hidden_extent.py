"""Tops seen at a grazing angle and hidden box ends: the far-side filter keeps a slope, a top seen
in rows joins its object, and a box whose back is hidden grows into space no camera saw through."""

import dataclasses as dc

import numpy as np
import pytest

from tsad_drake.perception.footprint import FootprintConfig, fit_box
from tsad_drake.perception.free_space import FreeSpace
from tsad_drake.perception.pointcloud import depth_to_cloud, drop_far_side_of_edges
from tsad_drake.perception.pose import PoseConfig
from tsad_drake.perception.segmentation import ClusterConfig, join_tops
from tsad_drake.scenario import ObjectConfig, Scenario
from tsad_drake.viewpoints import CameraConfig, camera_pose, raycast, scenario_prisms

#: a long box, its long side pointing into the shelf, alone on the floor
LONG = ObjectConfig("long", "rectangular", "box", [0.12, 0.045, 0.15], 0.2, 0.0, 0.0)


@pytest.fixture(scope="module")
def views():
    scenario = Scenario(objects=[LONG], target="long")
    camera = CameraConfig()
    out = []
    for theta in scenario.approach_angles:
        X_SC = camera_pose(scenario.shelf, camera, float(theta))
        depth, label = raycast(scenario_prisms(scenario), camera, X_SC)
        out.append((depth, label, X_SC))
    return out, camera.intrinsics()


def _height_image(depth: np.ndarray, intrinsics: np.ndarray, X_SC: np.ndarray) -> np.ndarray:
    """Height in S of each pixel's reading (nan where none)."""
    z = np.full(depth.shape, np.nan)
    valid = np.isfinite(depth) & (depth > 0)
    z[valid] = depth_to_cloud(depth, intrinsics, X_SC).points[:, 2]  # row-major, as nonzero
    return z


def test_far_side_filter_keeps_a_grazing_top_and_drops_a_flying_pixel(views):
    (depth, label, X_SC), intrinsics = views[0][len(views[0]) // 2], views[1]
    height = _height_image(depth, intrinsics, X_SC)
    top = (label == 0) & (height > LONG.size[2] - 0.002)
    top_pixels = int(np.count_nonzero(top))
    kept = drop_far_side_of_edges(depth, 0.012, slope_tolerance=0.5)
    kept_top = int(np.count_nonzero(top & np.isfinite(kept)))
    plain = drop_far_side_of_edges(depth, 0.012, slope_tolerance=0.0)  # no slope allowance
    plain_top = int(np.count_nonzero(top & np.isfinite(plain)))
    assert top_pixels >= 20 and kept_top >= 0.8 * top_pixels and plain_top <= 0.3 * top_pixels
    # the top steps by more than the 12 mm jump from row to row (the camera sees it at a grazing
    # angle), so a plain "farther than a neighbour" rule would drop all but its nearest row
    rows, cols = np.nonzero(top)
    assert np.abs(np.diff(depth, axis=0))[top[1:] & top[:-1]].max() > 0.012
    # a flying pixel: the background pixel just right of the box's silhouette reads 5 cm
    # behind the box's face
    r, c = rows[len(rows) // 2], cols.max()
    while label[r, c] == 0:
        c += 1
    planted = depth.copy()
    planted[r, c] = depth[r, c - 1] + 0.05
    assert np.isinf(drop_far_side_of_edges(planted, 0.012, slope_tolerance=0.5)[r, c])


def _box_points(views) -> np.ndarray:
    rendered, intrinsics = views
    clouds = [depth_to_cloud(d, intrinsics, X, lab) for d, lab, X in rendered]
    return np.concatenate([c.points[c.labels == 0] for c in clouds])


def test_hidden_box_end_grows_into_space_no_camera_saw(views):
    """Only the front half of the box is given (its back as if hidden); with the views' free
    space the back end grows to the true length (the cameras saw the back half, so nothing
    there is free), without it the box stays as short as what was given."""
    points = _box_points(views)
    front = points[points[:, 0] < LONG.x]
    free = FreeSpace([d for d, _, _ in views[0]], [X for _, _, X in views[0]], views[1])
    config = FootprintConfig(fitted=True, grow_hidden=True, max_face_gap=0.6)
    _, short, _ = fit_box(front, 0.0, PoseConfig(), config)
    centre, grown, _ = fit_box(front, 0.0, PoseConfig(), config, free)
    assert short[0] < LONG.size[0] - 0.04
    assert LONG.size[0] - 0.006 <= grown[0] <= config.max_length
    assert abs(grown[1] - LONG.size[1]) < 0.004
    assert centre[0] - grown[0] / 2 == pytest.approx(LONG.x - LONG.size[0] / 2, abs=0.004)


def test_free_space_is_what_rays_passed(views):
    free = FreeSpace([d for d, _, _ in views[0]], [X for _, _, X in views[0]], views[1])
    in_front = [LONG.x - 0.1, 0.0, 0.07]  # between the cameras and the box
    inside = [LONG.x + 0.03, 0.0, 0.07]
    above_behind = [LONG.x + LONG.size[0] / 2 + 0.05, 0.0, LONG.size[2] + 0.03]
    assert free.seen_free(np.array([in_front, inside, above_behind])).tolist() == [
        True, False, True]


def _flat_row(x: float, z: float, y0: float = -0.02, y1: float = 0.02) -> np.ndarray:
    y = np.linspace(y0, y1, 12)
    return np.c_[np.full_like(y, x), y, np.full_like(y, z)]


def test_rows_of_a_top_join_their_object_but_not_another_height():
    """A box's front (a face and the near rows of its top) and two far rows of its top 3 and 6 cm
    behind (flat parts: the rows between were never sampled) become one part; a flat row at
    another height, or one that would make the part longer than any object, stays apart."""
    face = np.array([[0.15, y, z] for y in np.linspace(-0.02, 0.02, 9)
                     for z in np.linspace(0.01, 0.15, 15)])
    near_top = np.concatenate([_flat_row(x, 0.15) for x in (0.155, 0.16, 0.165)])
    body = np.concatenate([face, near_top])
    rows = [_flat_row(0.195, 0.15), _flat_row(0.225, 0.15), _flat_row(0.20, 0.165, 0.03, 0.06),
            _flat_row(0.33, 0.15)]
    points = np.concatenate([body] + rows)
    bounds = np.cumsum([len(body)] + [len(r) for r in rows])
    parts = [np.arange(0, bounds[0])] + [np.arange(a, b) for a, b in zip(bounds, bounds[1:])]
    config = ClusterConfig(max_object_length=0.135, max_object_width=0.08, top_join_gap=0.06)
    joined = join_tops(points, parts, config)
    sizes = sorted(len(p) for p in joined)
    assert len(joined) == 3
    assert sizes[-1] == len(body) + 24  # the body with both far rows of its own top
    assert len(join_tops(points, parts, dc.replace(config, top_join_gap=0.0))) == len(parts)
