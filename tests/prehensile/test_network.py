"""PrehensileNet: sampling and grouping primitives, shapes, a forward/backward pass."""

import numpy as np
import pytest
import torch

from tsad_drake.prehensile.network import (
    NetConfig,
    PrehensileNet,
    ball_query,
    farthest_point_sampling,
    gather,
    segment_max,
)


@pytest.fixture(autouse=True)
def _seed():
    torch.manual_seed(0)
    torch.set_num_threads(2)


def test_farthest_point_sampling_spreads_points():
    xy = torch.rand(2, 200, 2)
    idx = farthest_point_sampling(xy, 16)
    assert idx.shape == (2, 16)
    assert (idx[:, 0] == 0).all()
    for b in range(2):
        assert len(set(idx[b].tolist())) == 16  # distinct
        chosen = xy[b, idx[b]]
        # greedy FPS: every later point is no closer to the chosen set than the covering radius
        d = torch.cdist(xy[b], chosen).min(dim=1).values
        gaps = torch.cdist(chosen, chosen) + torch.eye(16) * 10
        assert gaps.min() >= d.max() - 1e-6


def test_ball_query_stays_in_radius_and_pads_with_first():
    xy = torch.tensor([[[0.0, 0.0], [0.1, 0.0], [0.2, 0.0], [5.0, 5.0]]])
    centres = xy[:, :1]
    idx = ball_query(xy, centres, radius=0.15, count=6)
    assert idx.shape == (1, 1, 6)
    assert set(idx[0, 0].tolist()) == {0, 1}
    assert idx[0, 0, 0] == 0


def test_ball_query_takes_the_first_points_in_input_order():
    # five points inside the ball, room for three: the first three in input order, none outside
    xy = torch.tensor([[[0.0, 0.0], [9.0, 9.0], [0.05, 0.0], [0.0, 0.08], [0.02, 0.02], [0.0, 0.01]]])
    idx = ball_query(xy, xy[:, :1], radius=0.1, count=3)
    assert idx[0, 0].tolist() == [0, 2, 3]


def _ids(batch: int, points: int, objects: int) -> torch.Tensor:
    ids = torch.randint(-2, objects, (batch, points))
    return torch.where(ids == -1, torch.full_like(ids, -2), ids)


def test_forward_shapes_and_backward():
    cfg = NetConfig()
    net = PrehensileNet(cfg)
    xy = torch.randn(3, cfg.num_points, 2)
    feats = torch.rand(3, cfg.num_points, cfg.in_features)
    reach, block = net(xy, feats, _ids(3, cfg.num_points, 5), 5)
    assert reach.shape == (3,) and block.shape == (3, 5)
    (reach.sum() + block.mean()).backward()
    grads = [p.grad for p in net.parameters()]
    assert all(g is not None and torch.isfinite(g).all() for g in grads)
    assert sum(float(g.abs().sum()) for g in grads) > 0


def test_point_order_does_not_matter_when_every_ball_holds_its_centre_only():
    """Ball query takes the first K points in input order, so the input order matters only where
    a ball holds more than K points; with points further apart than both radii (each ball holds
    its centre alone) any order after the start point gives the same answers."""
    cfg = NetConfig()
    net = PrehensileNet(cfg).eval()
    side = int(cfg.num_points ** 0.5)
    grid = torch.stack(torch.meshgrid(torch.arange(side), torch.arange(side), indexing="ij"), -1)
    xy = (grid.reshape(1, -1, 2).float() * 1.01 * cfg.sa2_radius * 1.5
          + torch.rand(1, side * side, 2) * 0.01)
    n = xy.shape[1]
    feats = torch.rand(1, n, cfg.in_features)
    ids = _ids(1, n, 6)
    perm = torch.cat([torch.tensor([0]), torch.randperm(n - 1) + 1])
    with torch.no_grad():
        r1, b1 = net(xy, feats, ids, 6)
        r2, b2 = net(xy[:, perm], feats[:, perm], ids[:, perm], 6)
    assert torch.allclose(r1, r2, atol=1e-4)
    assert torch.allclose(b1, b2, atol=1e-4)


def test_an_object_answer_depends_on_its_own_points():
    """Moving one object's points changes its block logit; relabelling which points belong to
    which object moves the answers with them."""
    cfg = NetConfig()
    net = PrehensileNet(cfg).eval()
    xy = torch.randn(1, cfg.num_points, 2)
    feats = torch.rand(1, cfg.num_points, cfg.in_features)
    ids = torch.arange(cfg.num_points).remainder(4).unsqueeze(0)  # objects 0..3
    swapped = torch.where(ids == 1, 2, torch.where(ids == 2, 1, ids))
    with torch.no_grad():
        _, b = net(xy, feats, ids, 4)
        _, b_swapped = net(xy, feats, swapped, 4)
    assert torch.allclose(b[0, [1, 2]], b_swapped[0, [2, 1]], atol=1e-5)
    assert not torch.allclose(b[0, 1], b[0, 2])


def test_segment_max_pools_per_object_and_ignores_negative_ids():
    values = torch.tensor([[[1.0], [5.0], [2.0], [9.0], [-3.0]]])
    ids = torch.tensor([[0, 0, 1, -2, 2]])
    out = segment_max(values, ids, 4)
    np.testing.assert_allclose(out.numpy()[0, :, 0], [5.0, 2.0, -3.0, 0.0])


def test_gather_matches_torch_gather():
    """The fast form gives torch.gather's values on batched inputs."""
    gen = torch.Generator().manual_seed(3)
    values = torch.randn(4, 50, 7, generator=gen)
    idx = torch.randint(0, 50, (4, 9, 5), generator=gen)
    flat = idx.reshape(4, -1)
    expected = torch.gather(values, 1, flat.unsqueeze(-1).expand(-1, -1, 7)).reshape(4, 9, 5, 7)
    assert torch.equal(gather(values, idx), expected)
