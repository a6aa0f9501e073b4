"""The prehensile decision network: a small PointNet++ in PyTorch, its weightless steps in numba.

Input: one query (see `encoding.encode_query`): NUM_POINTS points with scaled xy in the
approach frame (approach along +x, queried object at the origin) and per-point features (height,
is-queried-object, is-wall, in-corridor). Two set-abstraction modules (farthest point sampling +
ball query + shared MLP + max pool: 256 -> 64 centroids x 16 neighbours -> 16 centroids x 16
neighbours), then

- per-point embeddings: every input point gets an embedding from its own coordinates and
  features, the SA2 and SA1 features interpolated back to it (PointNet++'s feature propagation)
  and the global feature; they are max-pooled over each object's points (the object ids are part
  of the input: segmentation is known), over the queried object's points and over the wall points;
- `reach` head (MLP on the global feature, the queried object's and the walls' pooled
  embeddings, and the same two pools of a second, raw-point embedding that sees only each
  point's own xy and features): the queried object fits the stroke at this angle and its
  corridor misses the side walls. The pools carry the object's extent across the approach and
  the walls' corridor flags at the points' own precision (v3 read the global feature only: 16
  coarse centroids, reach accuracy 0.94 on boxes; the raw pools are the v4 addition that makes a
  sharp width threshold easy to learn);
- `block` head (per object, on its pooled embedding and the queried object's): whether that object
  lies in the approach corridor. Pooling per object lets the head judge an object by its whole
  visible extent (one point inside the corridor is enough), which a per-point vote averaged over
  the object did not.

Pickable at theta = reach and no blocking object, so the planners' R_{theta,s} and their
pickability answers come from one forward pass per (object, angle) and never disagree.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from tsad_drake.prehensile import kernels


@dc.dataclass
class NetConfig:
    """Sizes of the network (radii are in scaled units: metres / COORD_SCALE)."""

    num_points: int = 256
    in_features: int = 6  #: encoding.NUM_FEATURES
    sa1_centroids: int = 64
    sa1_neighbours: int = 16
    sa1_radius: float = 0.3  #: 0.06 m
    sa1_mlp: tuple[int, ...] = (16, 32)
    sa2_centroids: int = 16
    sa2_neighbours: int = 16
    sa2_radius: float = 0.75  #: 0.15 m
    sa2_mlp: tuple[int, ...] = (32, 64)
    global_mlp: tuple[int, ...] = (64, 128)
    head_mlp: tuple[int, ...] = (64,)
    point_mlp: tuple[int, ...] = (32, 32)  #: per-point embedding before the per-object pooling
    object_mlp: tuple[int, ...] = (16,)  #: per-object head after the pooling
    #: per-point embedding of the raw point alone (xy, features), pooled over the queried object's
    #: and the walls' points for the reach head
    raw_mlp: tuple[int, ...] = (32, 32)


def _points(x: torch.Tensor) -> np.ndarray:
    """x as the contiguous float32 array the kernels take (the coordinates carry no gradient)."""
    return np.ascontiguousarray(x.detach().cpu().numpy(), dtype=np.float32)


def farthest_point_sampling(xy: torch.Tensor, count: int) -> torch.Tensor:
    """(B, count) indices of farthest point sampling of `xy` (B, N, 2), starting at point 0; ties
    go to the lowest index. A compiled loop (`kernels.farthest_point_sampling`): FPS is `count`
    sequential steps, where torch's per-operation overhead made it a fifth of a forward pass."""
    idx = kernels.farthest_point_sampling(_points(xy), count)
    return torch.from_numpy(idx).to(xy.device)


def ball_query(xy: torch.Tensor, centres: torch.Tensor, radius: float, count: int) -> torch.Tensor:
    """(B, M, count) indices of the first `count` points (in input order) within `radius` of each
    centre, as in PointNet++; unused slots repeat the first one (a centre is one of the points, so
    every ball holds at least one). One compiled pass per centre (`kernels.ball_query`)."""
    idx = kernels.ball_query(_points(xy), _points(centres), np.float32(radius * radius), count)
    return torch.from_numpy(idx).to(xy.device)


def gather(values: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
    """values (B, N, C) at idx (B, ...) -> (B, ..., C).

    One `index_select` on the flattened (B*N, C) rows: the same values as `torch.gather` with an
    expanded index, 10-15x faster on CPU (gather was 18% of a forward pass)."""
    b, n, c = values.shape
    offset = torch.arange(b, device=idx.device).mul_(n).view(b, *([1] * (idx.dim() - 1)))
    rows = (idx + offset).reshape(-1)
    return values.reshape(b * n, c).index_select(0, rows).reshape(*idx.shape, c)


def mlp(sizes: list[int], norm: bool = True) -> nn.Sequential:
    """Linear layers, each followed by (LayerNorm and) ReLU."""
    layers: list[nn.Module] = []
    for k in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[k], sizes[k + 1]))
        layers += [nn.LayerNorm(sizes[k + 1]), nn.ReLU()] if norm else [nn.ReLU()]
    return nn.Sequential(*layers)


class SetAbstraction(nn.Module):
    """FPS centroids, ball-query groups, shared MLP on (relative xy / radius, features), max pool."""

    def __init__(self, centroids: int, neighbours: int, radius: float, in_features: int,
                 sizes: tuple[int, ...]) -> None:
        super().__init__()
        self.centroids, self.neighbours, self.radius = centroids, neighbours, radius
        self.mlp = mlp([in_features + 2, *sizes], norm=False)  # per neighbour: keep it cheap

    def forward(self, xy: torch.Tensor, feats: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        centre_idx = farthest_point_sampling(xy, self.centroids)
        centres = gather(xy, centre_idx)  # (B, M, 2)
        groups = ball_query(xy, centres, self.radius, self.neighbours)  # (B, M, K)
        rel = (gather(xy, groups) - centres.unsqueeze(2)) / self.radius
        grouped = torch.cat([rel, gather(feats, groups)], dim=-1)  # (B, M, K, 2 + C)
        return centres, self.mlp(grouped).amax(dim=2)


def interpolate(xy: torch.Tensor, centres: torch.Tensor, values: torch.Tensor) -> torch.Tensor:
    """values (B, M, C) at `centres` interpolated to `xy` (B, N, 2): inverse distance, 3 nearest
    (found by `kernels.nearest3`). Without a gradient to carry (planning) the weighted sum is the
    compiled `kernels.interpolate`, bit for bit this torch form (tests/prehensile/test_kernels.py),
    which training keeps for its gradient."""
    near_d2, near = kernels.nearest3(_points(xy), _points(centres))
    if not values.requires_grad:
        return torch.from_numpy(kernels.interpolate(_points(values), near_d2, near)).to(values.device)
    near_d2 = torch.from_numpy(near_d2).to(values.device)
    near = torch.from_numpy(near).to(values.device)
    weight = 1.0 / (near_d2 + 1e-8)
    weight = weight / weight.sum(-1, keepdim=True)
    return (gather(values, near) * weight.unsqueeze(-1)).sum(2)


def object_presence(ids: torch.Tensor, num_objects: int) -> torch.Tensor:
    """(B, S) whether object s in [0, S) has a point among `ids` (B, N); negative ids belong to
    no object."""
    slot = torch.where(ids >= 0, ids, torch.full_like(ids, num_objects))
    present = torch.zeros(ids.shape[0], num_objects + 1, dtype=torch.bool, device=ids.device)
    return present.scatter_(1, slot, True)[:, :num_objects]


def segment_max(values: torch.Tensor, ids: torch.Tensor, num_segments: int) -> torch.Tensor:
    """(B, S, C) max of `values` (B, N, C) over the points of each id in [0, S); points with a
    negative id are ignored; an id with no point gets zeros. Without a gradient to carry the
    compiled `kernels.segment_max` (a max is exact: the same values); training keeps the torch
    scatter for its gradient."""
    if not values.requires_grad:
        ids_np = np.ascontiguousarray(ids.detach().cpu().numpy(), dtype=np.int64)
        return torch.from_numpy(kernels.segment_max(_points(values), ids_np, num_segments)).to(
            values.device)
    b, _, c = values.shape
    slot = torch.where(ids >= 0, ids, torch.full_like(ids, num_segments)).clamp(max=num_segments)
    out = torch.full((b, num_segments + 1, c), float("-inf"), dtype=values.dtype)
    out = out.scatter_reduce(1, slot.unsqueeze(-1).expand(-1, -1, c), values, reduce="amax")
    out = out[:, :num_segments]
    return torch.where(torch.isfinite(out), out, torch.zeros_like(out))


class PrehensileNet(nn.Module):
    """forward(xy (B,N,2), feats (B,N,F), ids (B,N), num_objects S) ->
    (reach logit (B,), per-object block logits (B,S)); points with a negative id (walls, the
    queried object) feed the set abstractions but belong to no object."""

    def __init__(self, config: NetConfig | None = None) -> None:
        super().__init__()
        cfg = self.config = config or NetConfig()
        self.sa1 = SetAbstraction(cfg.sa1_centroids, cfg.sa1_neighbours, cfg.sa1_radius,
                                  cfg.in_features, cfg.sa1_mlp)
        self.sa2 = SetAbstraction(cfg.sa2_centroids, cfg.sa2_neighbours, cfg.sa2_radius,
                                  cfg.sa1_mlp[-1], cfg.sa2_mlp)
        self.global_mlp = mlp([cfg.sa2_mlp[-1] + 2, *cfg.global_mlp])
        g = cfg.global_mlp[-1]
        h = cfg.point_mlp[-1]
        r = cfg.raw_mlp[-1]
        self.raw_mlp = mlp([2 + cfg.in_features, *cfg.raw_mlp], norm=False)
        self.reach_head = nn.Sequential(mlp([g + 2 * h + 2 * r, *cfg.head_mlp]),
                                        nn.Linear(cfg.head_mlp[-1], 1))
        # first point layer split in a per-point part and a per-sample (global) part: the same
        # as one linear layer on the concatenation, without repeating the global product per point
        width = cfg.point_mlp[0]
        self.point_local = nn.Linear(2 + cfg.in_features + cfg.sa2_mlp[-1] + cfg.sa1_mlp[-1], width)
        self.point_global = nn.Linear(g, width, bias=False)
        self.point_mlp = nn.Sequential(nn.ReLU(), mlp(list(cfg.point_mlp), norm=False))
        self.object_head = nn.Sequential(mlp([2 * h, *cfg.object_mlp], norm=False),
                                         nn.Linear(cfg.object_mlp[-1], 1))

    def forward(self, xy: torch.Tensor, feats: torch.Tensor, ids: torch.Tensor,
                num_objects: int) -> tuple[torch.Tensor, torch.Tensor]:
        c1, f1 = self.sa1(xy, feats)
        c2, f2 = self.sa2(c1, f1)
        glob = self.global_mlp(torch.cat([c2, f2], dim=-1)).amax(dim=1)  # (B, G)
        local = torch.cat([xy, feats, interpolate(xy, c2, f2), interpolate(xy, c1, f1)], dim=-1)
        hidden = self.point_mlp(self.point_local(local) + self.point_global(glob).unsqueeze(1))
        pooled = segment_max(hidden, ids, num_objects)  # (B, S, H)
        # segment 0: the queried object's points, 1: the walls' (feature channels 1 and 2)
        role = torch.where(feats[..., 1] > 0.5, 0, torch.where(feats[..., 2] > 0.5, 1, -1))
        query, walls = segment_max(hidden, role, 2).unbind(1)  # (B, H) each
        raw = segment_max(self.raw_mlp(torch.cat([xy, feats], dim=-1)), role, 2).flatten(1)
        reach = self.reach_head(torch.cat([glob, query, walls, raw], dim=-1)).squeeze(-1)
        per_object = torch.cat([pooled, query.unsqueeze(1).expand_as(pooled)], dim=-1)
        return reach, self.object_head(per_object).squeeze(-1)


def _layers(module: nn.Module) -> list[nn.Module]:
    """The Linear, LayerNorm and ReLU layers of `module` in the order its Sequentials run them."""
    if isinstance(module, nn.Sequential):
        return [layer for child in module for layer in _layers(child)]
    return [module]


def _row_ops(layers: list[nn.Module]) -> list[tuple]:
    """`layers` as `kernels.dense` and `kernels.layer_norm` run them: ("dense", weight
    transposed, bias, relu) per Linear, ("norm", weight, bias, eps, relu) per LayerNorm, each
    ReLU folded into the layer before it (float32 NumPy copies of the parameters)."""
    ops: list[list] = []
    for layer in layers:
        if isinstance(layer, nn.Linear):
            weight = layer.weight.detach().numpy()
            bias = (layer.bias.detach().numpy() if layer.bias is not None
                    else np.zeros(weight.shape[0], dtype=np.float32))
            ops.append(["dense", np.ascontiguousarray(weight.T), bias.copy(), False])
        elif isinstance(layer, nn.LayerNorm):
            ops.append(["norm", layer.weight.detach().numpy().copy(),
                        layer.bias.detach().numpy().copy(), float(layer.eps), False])
        elif isinstance(layer, nn.ReLU) and ops:
            ops[-1][-1] = True
        else:
            raise ValueError(f"no row form for {layer!r} here")
    return [tuple(op) for op in ops]


def _rows(ops: list[tuple], x: np.ndarray) -> np.ndarray:
    """`ops` (`_row_ops`) applied to the last axis of x, every row alone (`kernels.dense`)."""
    lead = x.shape[:-1]
    x = np.ascontiguousarray(x.reshape(-1, x.shape[-1]), dtype=np.float32)
    for op in ops:
        if op[0] == "dense":
            x = kernels.dense(x, op[1], op[2], op[3])
        else:
            x = kernels.layer_norm(x, op[1], op[2], op[3], op[4])
    return x.reshape(*lead, x.shape[-1])


def _run(layers: list[nn.Module], x: torch.Tensor) -> torch.Tensor:
    """`layers` applied to x as their modules apply them (the same functional calls), ReLU in
    place: x is an intermediate of `predict`, never a caller's tensor."""
    for layer in layers:
        if isinstance(layer, nn.Linear):
            x = F.linear(x, layer.weight, layer.bias)
        elif isinstance(layer, nn.LayerNorm):
            x = F.layer_norm(x, layer.normalized_shape, layer.weight, layer.bias, layer.eps)
        else:
            x = x.relu_()
    return x


def _set_abstraction(sa: SetAbstraction, layers: list[nn.Module], xy: np.ndarray,
                     feats: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`SetAbstraction.forward` on NumPy arrays: the groups built by one compiled pass
    (`kernels.group`), the shared MLP's last ReLU after the max pool (the max of the rectified
    values is the rectified max, exactly)."""
    centres = kernels.take(xy, kernels.farthest_point_sampling(xy, sa.centroids))
    groups = kernels.ball_query(xy, centres, np.float32(sa.radius * sa.radius), sa.neighbours)
    grouped = torch.from_numpy(kernels.group(xy, feats, centres, groups, np.float32(sa.radius)))
    pooled = _run(layers[:-1], grouped).amax(dim=2).relu_()
    return centres, pooled.numpy()


#: the per-query modules `predict` runs from NumPy copies of their parameters (`_row_ops`)
_ROW_MODULES = ("global_mlp", "point_global", "reach_head", "object_head")


def _versions(params: list[torch.Tensor]) -> tuple[int, ...]:
    """The in-place versions of `params`: a training step bumps them, so a copy can tell it is
    stale (19 counters: about 1 us, where walking the whole module tree was 39 us a call)."""
    return tuple(p._version for p in params)


def predict(net: PrehensileNet, xy: np.ndarray, feats: np.ndarray, ids: np.ndarray,
            num_objects: int) -> tuple[torch.Tensor, torch.Tensor]:
    """`net.forward` without a gradient on NumPy inputs (xy (B, N, 2) and feats (B, N, F)
    float32, ids (B, N) int64): the planners' forward pass.

    The neighbourhood steps, groups, interpolation and pools are compiled (`kernels`, bit for
    bit the torch steps); the per-point layers are torch's functional calls with ReLU in place;
    the per-query layers (global MLP, heads) run row by row (`kernels.dense`, summed in float64:
    within 1e-5 of the modules, tests/prehensile/test_kernels.py). Each query's answer is the
    same in any batch: a small CPU matrix product sums in another order than a large one, and a
    query's logits moved by up to 2e-6 with its batch-mates when the heads were matrix products.
    At the planners' batch sizes (1-8 queries) the modules' call overhead was a large part of a
    pass."""
    cache = net.__dict__.get("_predict_layers")
    if cache is None or cache["versions"] != _versions(cache["copied"]):  # copies stale: rebuild
        copied = [p for name in _ROW_MODULES for p in getattr(net, name).parameters()]
        cache = net.__dict__["_predict_layers"] = {
            "copied": copied, "versions": _versions(copied),
            **{name: _layers(module) for name, module in (
                ("sa1", net.sa1.mlp), ("sa2", net.sa2.mlp), ("raw_mlp", net.raw_mlp),
                ("point_mlp", net.point_mlp))},
            **{name: _row_ops(_layers(getattr(net, name))) for name in _ROW_MODULES}}
    c1, f1 = _set_abstraction(net.sa1, cache["sa1"], xy, feats)
    c2, f2 = _set_abstraction(net.sa2, cache["sa2"], c1, f1)
    glob = _rows(cache["global_mlp"], np.concatenate([c2, f2], axis=-1)).max(axis=1)  # (B, G)
    near2, near1 = kernels.nearest3(xy, c2), kernels.nearest3(xy, c1)
    local = torch.from_numpy(np.concatenate(
        [xy, feats, kernels.interpolate(f2, *near2), kernels.interpolate(f1, *near1)], axis=-1))
    hidden = _run(cache["point_mlp"], F.linear(local, net.point_local.weight,
                                               net.point_local.bias)
                  + torch.from_numpy(_rows(cache["point_global"], glob)).unsqueeze(1))
    hidden_np = hidden.numpy()
    pooled = kernels.segment_max(hidden_np, ids, num_objects)  # (B, S, H)
    role = np.where(feats[..., 1] > 0.5, 0, np.where(feats[..., 2] > 0.5, 1, -1))
    query_walls = kernels.segment_max(hidden_np, role, 2)
    raw_points = _run(cache["raw_mlp"], torch.from_numpy(np.concatenate([xy, feats], axis=-1)))
    raw = kernels.segment_max(raw_points.numpy(), role, 2).reshape(len(xy), -1)
    reach = _rows(cache["reach_head"], np.concatenate(
        [glob, query_walls.reshape(len(xy), -1), raw], axis=-1))[:, 0]
    query = np.broadcast_to(query_walls[:, :1], pooled.shape)
    block = _rows(cache["object_head"], np.concatenate([pooled, query], axis=-1))[..., 0]
    return torch.from_numpy(reach), torch.from_numpy(np.ascontiguousarray(block))


def query_scores(net: PrehensileNet, xy, feats, ids, queried: list[int],
                 num_objects: int) -> tuple[torch.Tensor, torch.Tensor]:
    """(reach logits (B,), per-object block probabilities (B, num_objects)) of encoded queries
    (NumPy arrays from `encode_query`), by `predict`. Probability 0 for the queried object (never
    its own blocker) and for every object with no point in the query's input: it lies outside
    the window the approach can touch, and the head, trained on objects that have points, would
    only answer its bias for the empty pooled embedding."""
    with torch.inference_mode():
        ids = ids.astype(np.int64)  # a copy: the queried object's points become -1
        ids[ids == np.asarray(queried, dtype=np.int64)[:, None]] = -1
        reach, block = predict(net, np.ascontiguousarray(xy, dtype=np.float32),
                               np.ascontiguousarray(feats, dtype=np.float32), ids, num_objects)
        return reach, torch.from_numpy(kernels.present_sigmoid(block.numpy(), ids))
