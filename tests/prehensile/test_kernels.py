"""The compiled steps (prehensile/kernels.py) against plain torch and NumPy references.

The references are the forms the network and the encoding used before the kernels (one batched
matrix product for the squared distances, argmax FPS, first points inside each ball, three min
passes for the nearest centres; the encoding's NumPy masks, sampling and features; the network's
modules): the kernels must give their indices, distances and inputs bit for bit, so the trained
network sees what it was trained on. The planners' pass (`network.predict`) runs the per-query
layers row by row in float64 sums: within 1e-5 of the modules, and the same bits for a query in
any batch."""

import types

import numpy as np
import pytest
import torch

from tsad_drake.planning.feasibility import CORRIDOR_OUTSIDE, polygon_widths
from tsad_drake.prehensile import dataset as pdata
from tsad_drake.prehensile import encoding, kernels, network
from tsad_drake.prehensile.network import NetConfig, PrehensileNet


def ref_squared_distances(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """(B, M, N) |a|^2 + |b|^2 - 2 a.b in float32, clamped at 0."""
    cross = torch.baddbmm((a * a).sum(-1, keepdim=True), a, b.transpose(1, 2), alpha=-2.0)
    return (cross + (b * b).sum(-1).unsqueeze(1)).clamp_(min=0.0)


def ref_fps(xy: torch.Tensor, count: int) -> torch.Tensor:
    """Greedy farthest point sampling from point 0 by argmax (first maximum wins)."""
    pair = ref_squared_distances(xy, xy)
    b, n, _ = pair.shape
    dist = torch.full((b, n), float("inf"))
    far = torch.zeros(b, dtype=torch.long)
    out = []
    for _ in range(count):
        out.append(far)
        dist = torch.minimum(dist, pair[torch.arange(b), far])
        far = dist.argmax(dim=1)
    return torch.stack(out, 1)


def ref_ball(xy: torch.Tensor, centres: torch.Tensor, radius2: float, count: int) -> torch.Tensor:
    """First `count` points in input order within squared radius `radius2` of each centre,
    padded with the first."""
    inside = ref_squared_distances(centres, xy) <= radius2
    b, m, n = inside.shape
    out = torch.empty((b, m, count), dtype=torch.long)
    for s in range(b):
        for c in range(m):
            hits = torch.nonzero(inside[s, c]).flatten()[:count]
            out[s, c] = torch.cat([hits, hits[:1].expand(count - len(hits))])
    return out


def ref_nearest3(xy: torch.Tensor, centres: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The three nearest centres by three min passes (ties to the lowest index; topk orders
    equal distances differently, and the encoded queries have many)."""
    work = ref_squared_distances(xy, centres)
    values, indices = [], []
    for _ in range(min(3, work.shape[-1])):
        v, i = work.min(dim=-1)
        values.append(v)
        indices.append(i)
        work.scatter_(-1, i.unsqueeze(-1), float("inf"))
    return torch.stack(values, -1), torch.stack(indices, -1)


def ref_encode_query(cloud, index: int, theta: float, angle_index: int):
    """The encoding's NumPy form (before `kernels.window_split`, `hull_hits`, `query_features`
    and the restored sampling streams)."""
    c, s = np.cos(theta), np.sin(theta)
    rel = cloud.xy - cloud.centres[index]
    rot = np.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], axis=1)
    keep = ((rot[:, 0] >= encoding.CROP_BACK) & (rot[:, 0] <= encoding.CROP_FRONT)
            & (np.abs(rot[:, 1]) <= encoding.CROP_HALF_WIDTH))
    is_query = cloud.ids == index
    in_corridor = (np.abs(rot[:, 1]) <= cloud.half_width) & (rot[:, 0] <= cloud.finger_reach)
    rng = np.random.default_rng([encoding.SAMPLE_SEED, index, angle_index])
    query = np.nonzero(is_query)[0]
    if len(query) > encoding.MAX_QUERY_POINTS:
        order = np.argsort(rot[query, 1])
        edges = np.concatenate([order[:encoding.QUERY_EDGE_POINTS],
                                order[-encoding.QUERY_EDGE_POINTS:]])
        rest = rng.choice(np.delete(np.arange(len(query)), edges),
                          encoding.MAX_QUERY_POINTS - len(edges), replace=False)
        query = query[np.concatenate([edges, rest])]
    room = encoding.NUM_POINTS - len(query)
    corridor = rng.permutation(np.nonzero(keep & in_corridor & ~is_query)[0])
    _, first = np.unique(cloud.ids[corridor], return_index=True)
    corridor = np.concatenate([corridor[first], np.delete(corridor, first)])[:room]
    others = np.nonzero(keep & ~in_corridor & ~is_query)[0]
    if len(others) > room - len(corridor):
        others = rng.choice(others, room - len(corridor), replace=False)
    chosen = np.concatenate([query, corridor, others]).astype(np.int64)
    if len(chosen) < encoding.NUM_POINTS:
        chosen = np.concatenate([chosen, rng.choice(chosen, encoding.NUM_POINTS - len(chosen))])
    ids = cloud.ids[chosen]
    hits = ref_hull_hits(cloud, index, theta)
    hull_flag = np.append(hits, False)[np.where(ids >= 0, ids, -1)]
    fits = polygon_widths(cloud.hulls[index], np.array([theta]))[0] <= cloud.max_width + 1e-9
    feats = np.stack([cloud.z[chosen] / encoding.HEIGHT_SCALE, (ids == index).astype(float),
                      (ids == encoding.WALL_ID).astype(float), in_corridor[chosen].astype(float),
                      hull_flag.astype(float), ((ids == index) & fits).astype(float)], axis=1)
    return ((rot[chosen] / encoding.COORD_SCALE).astype(np.float32), feats.astype(np.float32),
            ids)


def ref_hull_hits(cloud, index: int, theta: float) -> np.ndarray:
    """The corridor-hull separating-axis test on (N, K) arrays (NumPy form)."""
    u = np.array([np.cos(theta), np.sin(theta)])
    v = np.array([-u[1], u[0]])
    back = (cloud.centres[index, 0] + CORRIDOR_OUTSIDE) / max(u[0], 1e-6)
    front, half = cloud.finger_reach, cloud.half_width
    mid = cloud.centres[index] + (front - back) / 2 * u
    along, across = (cloud.hulls - mid) @ u, (cloud.hulls - mid) @ v
    length = (front + back) / 2
    hits = ((along.min(axis=1) <= length) & (along.max(axis=1) >= -length)
            & (across.min(axis=1) <= half) & (across.max(axis=1) >= -half))
    n = cloud.hull_normals
    centre, extent = n @ mid, length * np.abs(n @ u) + half * np.abs(n @ v)
    apart = (centre - extent > cloud.hull_high) | (centre + extent < cloud.hull_low)
    hits &= ~np.any(apart & cloud.hull_edges, axis=1)
    hits[index] = False
    return hits


@pytest.fixture(scope="module")
def clouds():
    """(state cloud, workspace, object count) of three generated scenes and one relocation of
    each."""
    scenes = [pdata.scene_states(seed, relocations=1, reobserve=False) for seed in (3, 4, 5)]
    return [(encoding.state_cloud(state, oracle.workspace), oracle.workspace, len(state.objects))
            for _, state, oracle in [s for states in scenes for s in states]]


@pytest.fixture(scope="module")
def encoded(clouds):
    """Every (object, angle) query of the clouds, encoded."""
    rows = []
    for cloud, ws, count in clouds:
        queries = [(i, k) for i in range(count) for k in range(len(ws.approach_angles))]
        rows.append(encoding.encode_batch(cloud, queries, ws.approach_angles))
    return tuple(np.concatenate(p) for p in zip(*rows))


def test_encoding_matches_its_numpy_form_on_every_query(clouds):
    """Each query's input (points, features, ids) is the NumPy form's bit for bit, the sampling
    included, in any order of queries (the restored streams start where a fresh one does)."""
    checked = 0
    for cloud, ws, count in clouds:
        queries = [(i, k) for i in range(count) for k in range(len(ws.approach_angles))]
        for i, k in queries[::-1] + queries:
            theta = float(ws.approach_angles[k])
            got = encoding.encode_query(cloud, i, theta, k)
            want = ref_encode_query(cloud, i, theta, k)
            for a, b in zip(got, want, strict=True):
                assert a.dtype == b.dtype and np.array_equal(a, b)
            assert np.array_equal(encoding.hull_hits(cloud, i, theta),
                                  ref_hull_hits(cloud, i, theta))
            checked += 1
    assert checked > 500


def _centres(xy: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
    return torch.stack([xy[s, idx[s]] for s in range(xy.shape[0])])


def test_kernels_match_torch_on_every_encoded_query(encoded):
    xy_np = encoded[0]
    assert len(xy_np) > 200
    xy = torch.from_numpy(xy_np)
    cfg = NetConfig()
    fps = kernels.farthest_point_sampling(xy_np, cfg.sa1_centroids)
    assert np.array_equal(fps, ref_fps(xy, cfg.sa1_centroids).numpy())
    centres = _centres(xy, torch.from_numpy(fps))
    radius = cfg.sa1_radius
    balls = kernels.ball_query(xy_np, centres.numpy(), np.float32(radius * radius),
                               cfg.sa1_neighbours)
    assert np.array_equal(balls, ref_ball(xy, centres, radius * radius, cfg.sa1_neighbours).numpy())
    values, indices = kernels.nearest3(xy_np, centres.numpy())
    ref_values, ref_indices = ref_nearest3(xy, centres)
    assert np.array_equal(indices, ref_indices.numpy())
    assert np.array_equal(values, ref_values.numpy())  # bit for bit: the weights follow them


def test_ties_on_a_grid_go_to_the_lowest_index():
    """Points on a coarse grid with repeats: many equal distances in FPS, in the balls and among
    the nearest centres; every tie is broken as torch breaks it."""
    gen = torch.Generator().manual_seed(4)
    xy = (torch.rand(5, 120, 2, generator=gen) * 10).round() / 10
    xy_np = xy.numpy()
    fps = kernels.farthest_point_sampling(xy_np, 24)
    assert np.array_equal(fps, ref_fps(xy, 24).numpy())
    centres = _centres(xy, torch.from_numpy(fps))
    assert np.array_equal(kernels.ball_query(xy_np, centres.numpy(), np.float32(0.3 * 0.3), 8),
                          ref_ball(xy, centres, 0.3 * 0.3, 8).numpy())
    values, indices = kernels.nearest3(xy_np, centres.numpy())
    ref_values, ref_indices = ref_nearest3(xy, centres)
    assert np.array_equal(values, ref_values.numpy())
    assert np.array_equal(indices, ref_indices.numpy())
    d2 = ref_squared_distances(xy, centres).numpy()
    ties = 0
    for s in range(5):
        for i in range(120):
            expected = np.lexsort((np.arange(24), d2[s, i]))[:3]  # by distance, then index
            assert indices[s, i].tolist() == expected.tolist()
            ties += len(np.unique(d2[s, i])) < 24
    assert ties > 100  # the grid does produce equal distances
    two = kernels.nearest3(xy_np, centres.numpy()[:, :2])[1]
    assert two.shape == (5, 120, 2)  # fewer than three centres


def test_network_answers_are_those_of_the_torch_steps(encoded, monkeypatch):
    """The planners' forward pass (no gradient: every step compiled) equals the all-torch forward
    bit for bit on the encoded queries: the torch references swapped in for the neighbourhood
    steps and the gradient on, so that interpolation and the per-object max pools take their
    torch forms (untrained weights; the steps take no weights)."""
    torch.manual_seed(0)
    net = PrehensileNet().eval()
    xy, feats, ids = (torch.from_numpy(a) for a in encoded)
    objects = int(ids.max()) + 1
    with torch.inference_mode():
        reach, block = net(xy, feats, ids, objects)

    def unused(*args):
        raise AssertionError("a compiled step ran in the reference pass")

    reference = types.SimpleNamespace(
        farthest_point_sampling=lambda p, count: ref_fps(torch.from_numpy(p), count).numpy(),
        ball_query=lambda p, c, radius2, count: ref_ball(
            torch.from_numpy(p), torch.from_numpy(c), float(radius2), count).numpy(),
        nearest3=lambda p, c: tuple(t.numpy() for t in ref_nearest3(torch.from_numpy(p),
                                                                      torch.from_numpy(c))),
        interpolate=unused, segment_max=unused)
    monkeypatch.setattr(network, "kernels", reference)
    ref_reach, ref_block = net(xy, feats, ids, objects)
    assert ref_reach.requires_grad
    assert torch.equal(reach, ref_reach.detach()) and torch.equal(block, ref_block.detach())


def test_interpolation_and_max_pools_match_their_torch_forms():
    """The compiled weighted sum and per-object max equal the torch forms (gradient on) on
    random inputs, including a segment with no point and ids past the last segment."""
    gen = torch.Generator().manual_seed(6)
    xy = torch.rand(4, 90, 2, generator=gen)
    centres = xy[:, :12].contiguous()
    values = torch.randn(4, 12, 9, generator=gen)
    torch_form = network.interpolate(xy, centres, values.clone().requires_grad_())
    assert torch.equal(network.interpolate(xy, centres, values), torch_form.detach())
    points = torch.randn(4, 90, 5, generator=gen)
    ids = torch.randint(-2, 7, (4, 90), generator=gen)
    ids[ids == 3] = 4  # segment 3 empty; ids 6 lie past the 6 segments asked for
    torch_pool = network.segment_max(points.clone().requires_grad_(), ids, 6)
    got = network.segment_max(points, ids, 6)
    assert torch.equal(got, torch_pool.detach())
    assert torch.equal(got[:, 3], torch.zeros(4, 5))


@pytest.mark.parametrize("weights", ["untrained", "shipped"])
def test_the_planners_forward_pass_is_the_modules_pass(encoded, weights):
    """`predict` (compiled steps, functional per-point layers, row-by-row heads) answers what
    the modules' forward pass answers, within 1e-5, at the planners' batch sizes and at a large
    one; the probabilities as `query_scores` gives them, within 1e-6."""
    from tsad_drake.prehensile.checkpoint import load_checkpoint

    torch.manual_seed(0)
    net = PrehensileNet().eval() if weights == "untrained" else load_checkpoint(None)[0]
    xy, feats, ids = encoded
    objects = int(ids.max()) + 1
    for size in (1, 3, 7, len(xy)):
        with torch.inference_mode():
            reach, block = net(torch.from_numpy(xy[:size]), torch.from_numpy(feats[:size]),
                               torch.from_numpy(ids[:size]), objects)
            fast_reach, fast_block = network.predict(net, xy[:size], feats[:size],
                                                     ids[:size].copy(), objects)
            _, prob = network.query_scores(net, xy[:size], feats[:size], ids[:size],
                                           [-5] * size, objects)
        assert torch.allclose(reach, fast_reach, atol=1e-5)
        assert torch.allclose(block, fast_block, atol=1e-5)
        present = network.object_presence(torch.from_numpy(ids[:size]), objects)
        assert torch.allclose(prob, torch.where(present, torch.sigmoid(block), 0.0), atol=1e-6)


def test_the_planners_pass_follows_weights_changed_in_place(encoded):
    """`predict` copies the per-query layers' parameters; a change made in place (a training
    step, `load_state_dict`) must reach its answers, not the stale copies."""
    torch.manual_seed(3)
    net = PrehensileNet().eval()
    xy, feats, ids = (a[:3] for a in encoded)
    objects = int(encoded[2].max()) + 1
    with torch.inference_mode():
        before = network.predict(net, xy, feats, ids.copy(), objects)[0]
    with torch.no_grad():
        net.reach_head[-1].bias.add_(1.0)
    with torch.inference_mode():
        after = network.predict(net, xy, feats, ids.copy(), objects)[0]
        expected = net(torch.from_numpy(xy), torch.from_numpy(feats), torch.from_numpy(ids),
                       objects)[0]
    assert torch.allclose(after, before + 1.0, atol=1e-5)
    assert torch.allclose(after, expected, atol=1e-5)


def test_row_kernels_are_the_torch_layers_row_by_row():
    """`kernels.dense` and `kernels.layer_norm` (then ReLU) against torch's layers on every
    per-query layer shape of the network, within 1e-5; each row's bits the same computed alone
    or with 63 others."""
    torch.manual_seed(1)
    net = PrehensileNet()
    for name in ("global_mlp", "point_global", "reach_head", "object_head"):
        module = getattr(net, name)
        ops = network._row_ops(network._layers(module))
        x = torch.randn(64, ops[0][1].shape[0])
        with torch.inference_mode():
            expected = module(x).numpy()
        together = network._rows(ops, x.numpy())
        assert np.allclose(together, expected, atol=1e-5), name
        for row in (0, 17, 63):
            alone = network._rows(ops, x.numpy()[row:row + 1])
            assert np.array_equal(alone[0], together[row]), name


def test_a_querys_answer_does_not_depend_on_the_batch_it_runs_in(encoded):
    """The shipped network's logits for each query, run alone, in batches of 2, 3, 7 and 16 of
    shuffled companions, and all at once: the same bits (so a cached answer, a lazily asked
    angle or a merged batch gives every plan its same decisions)."""
    from tsad_drake.prehensile.checkpoint import load_checkpoint

    net = load_checkpoint(None)[0]
    xy, feats, ids = encoded
    objects = int(ids.max()) + 1
    queried = [0] * len(xy)

    def answers(rows):
        reach, prob = network.query_scores(net, xy[rows], feats[rows], ids[rows],
                                           [queried[r] for r in rows], objects)
        return reach.numpy(), prob.numpy()

    every = np.arange(len(xy))
    reach, prob = answers(every)
    order = np.random.default_rng(2).permutation(len(xy))
    for size in (1, 2, 3, 7, 16):
        for first in range(0, min(len(xy), 8 * size), size):
            rows = order[first:first + size]
            part_reach, part_prob = answers(rows)
            assert np.array_equal(part_reach, reach[rows]) and np.array_equal(part_prob, prob[rows])
