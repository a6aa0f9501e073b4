"""Prehensile dataset: a tiny dataset generated end to end, checked against the oracle."""

import numpy as np
import pytest

from tsad_drake.prehensile import dataset as pdata
from tsad_drake.prehensile import encoding

SEED = 3  # scenario "real" (5 objects): the quickest scene


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("prehensile_data")
    summary = pdata.generate_dataset(out, scenes=1, seed_start=SEED, progress=False)
    return out, summary, pdata.load_dataset(out)


def test_generation_writes_a_shard_and_resumes(dataset):
    out, summary, data = dataset
    shards = list(out.glob("shard_*.npz"))
    assert len(shards) == 1
    assert summary["scenes"] == 1 and summary["samples"] == len(data) > 10
    mtime = shards[0].stat().st_mtime_ns
    pdata.generate_dataset(out, scenes=1, seed_start=SEED, progress=False)  # resume: nothing to do
    assert shards[0].stat().st_mtime_ns == mtime
    assert data.xy.shape == (len(data), encoding.NUM_POINTS, 2)
    assert data.feats.shape == (len(data), encoding.NUM_POINTS, encoding.NUM_FEATURES)
    assert set(np.unique(data.kind)) >= {"observed", "relocated", "reobserved"}
    assert set(np.unique(data.scenario)) == {"real"}


def test_labels_agree_with_the_oracle(dataset):
    _, _, data = dataset
    states = pdata.scene_states(SEED)
    thetas = states[0][2].workspace.approach_angles
    # rows are written state by state, in scene_states order
    order = [(kind, pdata.oracle_labels(oracle, state)) for kind, state, oracle in states]
    rows = np.arange(len(data))
    kinds = data.kind
    checked = 0
    row = 0
    for kind, lab in order:
        n_pos = int(lab.pickable.sum())
        n_neg = min(int((~lab.pickable).sum()), max(n_pos, 3))
        for r in rows[row:row + n_pos + n_neg]:
            assert kinds[r] == kind
            query = data.feats[r, :, 1] > 0.5
            i = int(np.unique(data.ids[r][query])[0])
            k = int(np.argmin(np.abs(thetas - data.theta[r])))
            assert data.pickable[r] == lab.pickable[i, k]
            assert data.reach[r] == lab.reach[i, k]
            blockers = set(np.unique(data.ids[r][data.point_label[r] == 1]).tolist())
            sampled = set(np.unique(data.ids[r][data.ids[r] >= 0]).tolist())
            assert blockers == set(lab.blockers[i][k]) & sampled
            if data.pickable[r]:
                assert not blockers
            checked += 1
        # balanced: every positive and as many negatives (at least 3)
        assert data.pickable[row:row + n_pos + n_neg].sum() == n_pos
        row += n_pos + n_neg
    assert checked == len(data)


def test_input_is_centred_on_the_query_and_rotated_to_the_approach(dataset):
    _, _, data = dataset
    scale = encoding.COORD_SCALE
    for r in range(len(data)):
        query = data.feats[r, :, 1] > 0.5
        centre = data.xy[r][query].astype(float).mean(axis=0) * scale
        assert np.linalg.norm(centre) < 0.06  # the visible side of an object near its centre
        blocking = data.point_label[r] == 1
        if blocking.any():  # blockers lie between the opening (-x) and the object
            for j in np.unique(data.ids[r][blocking]):
                xs = data.xy[r][data.ids[r] == j, 0].astype(float) * scale
                assert xs.min() < 0.015 + 0.01
    walls = data.feats[:, :, 2] > 0.5
    assert walls.any()


def test_encoding_is_deterministic():
    states = pdata.scene_states(SEED, relocations=0, reobserve=False)
    _, state, oracle = states[0]
    cloud = encoding.state_cloud(state, oracle.workspace)
    a = encoding.encode_query(cloud, 1, 0.2, 5)
    b = encoding.encode_query(encoding.state_cloud(state, oracle.workspace), 1, 0.2, 5)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_splits_are_by_scene_and_hold_every_scenario_type():
    assert [pdata.split_of(s) for s in (0, 31, 32, 35, 36, 39, 72, 79)] == [
        "train", "train", "val", "val", "test", "test", "val", "test"]
    for split in ("val", "test"):
        types = {pdata.scenario_type(s) for s in range(400) if pdata.split_of(s) == split}
        assert types == set(pdata.SCENARIO_TYPES)


@pytest.mark.slow
def test_drake_rendered_scene_gives_labelled_samples():
    pytest.importorskip("tsad_drake.station")
    samples = pdata.scene_samples(SEED, pdata.Sensing(observer="drake"))
    assert samples is not None and len(samples) > 10
    assert samples.pickable.any() and (~samples.pickable).any()


def test_realistic_cluster_sensing_gives_its_own_shards_labelled_by_the_oracle(tmp_path):
    """Data observed as a robot observes (realistic depth, cluster segmentation): the noise is
    drawn from the scene seed (the same shard twice), the shard name says how it was observed,
    and every cluster is labelled with the oracle's answer for the true object it stands for.
    One frame per view (the shipped realistic weights' data) keeps the name it had before the
    preset took eight."""
    sensing = pdata.Sensing(sensor="realistic", segmentation="cluster")
    assert sensing.frames == 8 and sensing.tag == "raycast-realistic-cluster-x8"
    assert pdata.Sensing("raycast", "realistic", "cluster", 1).tag == "raycast-realistic-cluster"
    pdata.generate_dataset(tmp_path, scenes=1, seed_start=SEED, sensing=sensing, progress=False)
    (shard,) = list(tmp_path.glob("shard_*.npz"))
    assert shard.name.startswith("shard_raycast-realistic-cluster-x8_")
    data = pdata.load_dataset(tmp_path)
    again = pdata.scene_samples(SEED, sensing)
    assert np.array_equal(again.xy, data.xy) and np.array_equal(again.pickable, data.pickable)
    kind, state, oracle = pdata.scene_states(SEED, sensing, relocations=0, reobserve=False)[0]
    assert all(o.name.startswith("cluster") for o in state.objects)
    ideal = pdata.scene_states(SEED, relocations=0, reobserve=False)[0][1]
    assert not np.array_equal(np.concatenate([o.points for o in state.objects]),
                              np.concatenate([o.points for o in ideal.objects]))
    labels = pdata.oracle_labels(oracle, state)
    target = next(i for i, o in enumerate(state.objects) if o.name == state.target)
    assert oracle.true_object(state.objects[target]).name == oracle.scenario.target
    assert labels.pickable.shape == (len(state.objects), len(oracle.workspace.approach_angles))


def test_encoding_keeps_every_object_that_reaches_into_the_corridor():
    """Sampling to NUM_POINTS keeps the queried object's points (its outermost ones across the
    approach among them) and, for every object with a point inside the approach corridor, at
    least one such point, flagged in-corridor; oracle blockers are almost always among them (the
    rest are hidden from every view)."""
    kept = total = 0
    for _, state, oracle in pdata.scene_states(SEED, relocations=1, reobserve=False):
        cloud = encoding.state_cloud(state, oracle.workspace)
        labels = pdata.oracle_labels(oracle, state)
        thetas = oracle.workspace.approach_angles
        for i in range(len(state.objects)):
            for k, theta in enumerate(thetas):
                xy, feats, ids = encoding.encode_query(cloud, i, float(theta), k)
                assert xy.shape == (encoding.NUM_POINTS, 2) and set(np.unique(feats[:, 3])) <= {0, 1}
                c, s = np.cos(theta), np.sin(theta)
                rel = cloud.xy - cloud.centres[i]
                rx, ry = c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]
                inside = ((np.abs(ry) <= cloud.half_width) & (rx <= cloud.finger_reach)
                          & (rx >= encoding.CROP_BACK) & (np.abs(ry) <= encoding.CROP_HALF_WIDTH))
                reaching = set(cloud.ids[inside].tolist()) - {i}
                flagged = set(ids[feats[:, 3] > 0].tolist()) - {i}
                assert flagged == reaching
                assert (ids == i).sum() >= min((cloud.ids == i).sum(), encoding.MAX_QUERY_POINTS)
                # the queried object's extent across the approach (its fit in the stroke) is kept
                mine = xy[ids == i, 1] * encoding.COORD_SCALE
                assert np.isclose(mine.max(), ry[cloud.ids == i].max(), atol=1e-3)
                assert np.isclose(mine.min(), ry[cloud.ids == i].min(), atol=1e-3)
                kept += len(set(labels.blockers[i][k]) & flagged)
                total += len(labels.blockers[i][k])
    assert total > 0 and kept >= 0.95 * total


def test_hull_flag_marks_the_objects_whose_completed_footprint_meets_the_corridor():
    """Feature 4 is set on exactly the points of the objects the geometric model (hull of the
    centrally completed points) puts in the corridor, on none of the walls' or the query's."""
    from tsad_drake.planning.feasibility import GeometricFeasibility

    for _, state, oracle in pdata.scene_states(SEED, relocations=1, reobserve=False):
        geometric = GeometricFeasibility(oracle.workspace)
        cloud = encoding.state_cloud(state, oracle.workspace)
        for i in range(len(state.objects)):
            blockers = geometric.blockers(state, i)
            for k, theta in enumerate(oracle.workspace.approach_angles):
                _, feats, ids = encoding.encode_query(cloud, i, float(theta), k)
                flagged = feats[:, 4] > 0
                assert set(ids[flagged].tolist()) == set(blockers[k]) & set(ids.tolist())
                assert not flagged[ids < 0].any() and not flagged[ids == i].any()
                on = np.isin(ids, list(blockers[k]))
                assert flagged[on].all()
                # feature 5: the queried object's hull fits the stroke, as the geometric model's
                # reach says where its corridor also misses the walls
                fits = feats[ids == i, 5]
                assert len(set(fits.tolist())) == 1 and not feats[ids != i, 5].any()
                if geometric.reachable(state, i)[k]:
                    assert fits[0] == 1
