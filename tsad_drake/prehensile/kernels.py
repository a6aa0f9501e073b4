"""Compiled steps (numba): the network's (FPS, ball query, groups, nearest centres,
interpolation, pools, per-query layers) and the encoding's (crop and corridor split, corridor
order, hull test, features).

In torch the neighbourhood steps were about half of a forward pass at the planners' batch sizes
(1-8 queries): FPS is `count` sequential steps, the ball query a cumulative count and a scatter
over an (M, N) matrix, the nearest three three min passes; each a few operations whose per-call
overhead dwarfs the arithmetic. Here each is one pass over the points. Interpolation, groups and
the max pools run here only without a gradient (planning: `network.predict`); training keeps
their torch forms. The per-query layers (`dense`, `layer_norm`: the global MLP and the heads, a
few hundred multiply-adds a row) run row by row, so that a query's answer does not depend on its
batch. The encoding's steps were about two thirds of an encoded query's 290 us (NumPy masks and
gathers over the whole cloud); its random sampling stays NumPy's (`encoding.query_rng`).

Squared distances are rounded exactly as the torch form rounded them on CPU (|a|^2 + |b|^2 -
2 a.b in float32 by one `baddbmm`, the dot product a fused multiply-add; checked bit for bit in
tests/prehensile/test_kernels.py), so the indices and distances are those of the torch steps:
same sampled centroids, same balls, same ties (the lowest index wins).
"""

from __future__ import annotations

import numba
import numpy as np

_JIT = {"cache": True, "nogil": True}


@numba.njit(**_JIT)
def _norms(p: np.ndarray) -> np.ndarray:
    """|p|^2 per row of p (N, 2) float32, summed as torch sums the two squares."""
    out = np.empty(p.shape[0], dtype=np.float32)
    for i in range(p.shape[0]):
        out[i] = np.float32(p[i, 0] * p[i, 0]) + np.float32(p[i, 1] * p[i, 1])
    return out


@numba.njit(**_JIT)
def _d2(ax: np.float32, ay: np.float32, aa: np.float32, bx: np.float32, by: np.float32,
        bb: np.float32) -> np.float32:
    """One squared distance as the torch form rounds it: dot = fma(ay, by, ax * bx),
    (aa - 2 dot) + bb, clamped at 0. The float64 sum of the float32 product and the exact
    float64 product, rounded once to float32, is the fused multiply-add."""
    p = np.float32(ax * bx)
    dot = np.float32(np.float64(p) + np.float64(ay) * np.float64(by))
    d = np.float32(np.float32(aa + np.float32(-2.0) * dot) + bb)
    return d if d > np.float32(0.0) else np.float32(0.0)


@numba.njit(**_JIT)
def farthest_point_sampling(xy: np.ndarray, count: int) -> np.ndarray:
    """(B, count) farthest point sampling indices of xy (B, N, 2) float32, starting at point 0;
    the first of equally far points wins."""
    b, n = xy.shape[0], xy.shape[1]
    idx = np.zeros((b, count), dtype=np.int64)
    dist = np.empty(n, dtype=np.float32)
    bits = dist.view(np.int32)
    px = np.empty(n, dtype=np.float32)
    py = np.empty(n, dtype=np.float32)
    for s in range(b):
        p = xy[s]
        norms = _norms(p)
        px[:] = p[:, 0]
        py[:] = p[:, 1]
        dist[:] = np.inf
        far = 0
        for k in range(count):
            idx[s, k] = far
            fx, fy, ff = px[far], py[far], norms[far]
            for j in range(n):  # the distances first (a loop the compiler vectorises)
                d = _d2(fx, fy, ff, px[j], py[j], norms[j])
                dist[j] = min(d, dist[j])
            # the farthest: distances are >= 0, so their bits order as integers, and an
            # integer maximum vectorises; then the first point at it
            most = bits[0]
            for j in range(1, n):
                most = max(most, bits[j])
            far = 0
            while bits[far] != most:
                far += 1
    return idx


@numba.njit(**_JIT)
def ball_query(xy: np.ndarray, centres: np.ndarray, radius2: np.float32,
               count: int) -> np.ndarray:
    """(B, M, count) indices of the first `count` points of xy (B, N, 2) (input order) whose
    squared distance to each centre (B, M, 2) is at most `radius2`; unused slots repeat the
    first one."""
    b, m, n = xy.shape[0], centres.shape[1], xy.shape[1]
    out = np.zeros((b, m, count), dtype=np.int64)
    dist = np.empty(n, dtype=np.float32)
    px = np.empty(n, dtype=np.float32)
    py = np.empty(n, dtype=np.float32)
    slots = np.empty(count + 1, dtype=np.int64)
    for s in range(b):
        pn = _norms(xy[s])
        cn = _norms(centres[s])
        px[:] = xy[s, :, 0]
        py[:] = xy[s, :, 1]
        for c in range(m):
            cx, cy, cc = centres[s, c, 0], centres[s, c, 1], cn[c]
            for j in range(n):  # the distances first (a loop the compiler vectorises)
                dist[j] = _d2(cx, cy, cc, px[j], py[j], pn[j])
            filled = 0
            for j in range(n):  # every point written, the count moved only by one inside
                slots[filled] = j
                filled += dist[j] <= radius2
                if filled == count:
                    break
            for k in range(filled):
                out[s, c, k] = slots[k]
            # a centre is one of the points, so filled >= 1 for the network's own centres
            for k in range(filled, count):
                out[s, c, k] = out[s, c, 0]
    return out


@numba.njit(**_JIT)
def nearest3(xy: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(squared distances (B, N, k), indices (B, N, k)) of the k = min(3, M) nearest centres
    (B, M, 2) to each point of xy (B, N, 2), ascending; ties go to the lowest index. Per point, k
    first-minimum passes, each taking its centre out of the next: the distances are >= 0, so
    their float32 bits order as integers, and an integer minimum is a loop the compiler
    vectorises (a float one it may not reorder), where keeping the best three in one pass
    mispredicted a branch at every new best."""
    b, n, m = xy.shape[0], xy.shape[1], centres.shape[1]
    k = min(3, m)
    values = np.empty((b, n, k), dtype=np.float32)
    indices = np.empty((b, n, k), dtype=np.int64)
    table = np.empty((n, m), dtype=np.float32)
    bits = table.view(np.int32)
    taken = np.int32(0x7FFFFFFF)  # above every distance's bits, +inf's included
    for s in range(b):
        pn = _norms(xy[s])
        cn = _norms(centres[s])
        cx, cy = centres[s, :, 0].copy(), centres[s, :, 1].copy()
        for i in range(n):  # every distance first (a loop the compiler vectorises)
            px, py, pp = xy[s, i, 0], xy[s, i, 1], pn[i]
            row = table[i]
            for c in range(m):
                row[c] = _d2(px, py, pp, cx[c], cy[c], cn[c])
        for i in range(n):
            row = bits[i]
            for r in range(k):
                least = taken
                for c in range(m):
                    least = min(least, row[c])
                for c in range(m):
                    if row[c] == least:
                        values[s, i, r] = table[i, c]
                        indices[s, i, r] = c
                        row[c] = taken
                        break
    return values, indices


@numba.njit(**_JIT)
def interpolate(values: np.ndarray, near_d2: np.ndarray, near: np.ndarray) -> np.ndarray:
    """(B, N, C) inverse-distance interpolation of values (B, M, C) at the nearest centres
    `near` (B, N, k) with squared distances `near_d2`, rounded as the torch form rounds it:
    w = 1 / (d2 + 1e-8) normalised by its sum (summed in order), then sum_r values * w_r in
    order r = 0, 1, 2 (float32 throughout)."""
    b, n, k = near.shape
    c = values.shape[2]
    out = np.empty((b, n, c), dtype=np.float32)
    w = np.empty(k, dtype=np.float32)
    eps = np.float32(1e-8)
    for s in range(b):
        for i in range(n):
            total = np.float32(0.0)
            for r in range(k):
                w[r] = np.float32(1.0) / np.float32(near_d2[s, i, r] + eps)
                total = np.float32(total + w[r])
            for r in range(k):
                w[r] = np.float32(w[r] / total)
            # per channel the sum runs r = 0, 1, 2 from 0 as before; channels innermost
            # (contiguous, vectorised)
            row = out[s, i]
            row[:] = np.float32(0.0)
            for r in range(k):
                src = values[s, near[s, i, r]]
                wr = w[r]
                for ch in range(c):
                    row[ch] = np.float32(row[ch] + np.float32(src[ch] * wr))
    return out


@numba.njit(**_JIT)
def segment_max(values: np.ndarray, ids: np.ndarray, num_segments: int) -> np.ndarray:
    """(B, S, C) max of values (B, N, C) over the points of each id in [0, S); negative ids (and
    ids >= S) are ignored, a segment with no point gets zeros (a max rounds nothing)."""
    b, n, c = values.shape
    out = np.zeros((b, num_segments, c), dtype=np.float32)
    seen = np.zeros(num_segments, dtype=np.bool_)
    for s in range(b):
        seen[:] = False
        for i in range(n):
            g = ids[s, i]
            if g < 0 or g >= num_segments:
                continue
            if not seen[g]:
                seen[g] = True
                for ch in range(c):
                    out[s, g, ch] = values[s, i, ch]
            else:
                for ch in range(c):
                    if values[s, i, ch] > out[s, g, ch]:
                        out[s, g, ch] = values[s, i, ch]
    return out


@numba.njit(**_JIT)
def dense(x: np.ndarray, weight_t: np.ndarray, bias: np.ndarray, relu: bool) -> np.ndarray:
    """(M, N) x (M, K) times weight_t (K, N) plus bias (N,) (then ReLU), every row summed alone
    over k in order in float64 and rounded once: a row's result does not depend on the other
    rows nor on the machine's matrix-product kernels. For the network's per-query layers (the
    heads, the global MLP), whose products are too small for a matrix-product call to pay its
    overhead."""
    m, k = x.shape
    n = weight_t.shape[1]
    out = np.empty((m, n), dtype=np.float32)
    acc = np.empty(n, dtype=np.float64)
    for r in range(m):
        for j in range(n):
            acc[j] = bias[j]
        for q in range(k):
            xv = np.float64(x[r, q])
            row = weight_t[q]
            for j in range(n):  # outputs innermost: independent sums, vectorised
                acc[j] += xv * np.float64(row[j])
        for j in range(n):
            v = np.float32(acc[j])
            out[r, j] = v if not relu or v > np.float32(0.0) else np.float32(0.0)
    return out


@numba.njit(**_JIT)
def layer_norm(x: np.ndarray, weight: np.ndarray, bias: np.ndarray, eps: float,
               relu: bool) -> np.ndarray:
    """(M, N) LayerNorm of each row of x (M, N) (mean and biased variance in float64) with
    weight and bias (N,) (then ReLU); rows alone, as `dense`."""
    m, n = x.shape
    out = np.empty((m, n), dtype=np.float32)
    for r in range(m):
        mean = 0.0
        for j in range(n):
            mean += np.float64(x[r, j])
        mean /= n
        var = 0.0
        for j in range(n):
            d = np.float64(x[r, j]) - mean
            var += d * d
        scale = 1.0 / np.sqrt(var / n + eps)
        for j in range(n):
            v = np.float32((np.float64(x[r, j]) - mean) * scale * np.float64(weight[j])
                           + np.float64(bias[j]))
            out[r, j] = v if not relu or v > np.float32(0.0) else np.float32(0.0)
    return out


@numba.njit(**_JIT)
def present_sigmoid(logits: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """(B, S) sigmoid of logits (B, S) (in float64, rounded once) where object s has a point
    among ids (B, N) of that query, else 0; element by element, so the same bits wherever an
    element sits in the array (torch's vectorised sigmoid rounds its tail elements another way,
    and where the tail falls moved with the batch)."""
    b, num = logits.shape
    out = np.zeros((b, num), dtype=np.float32)
    present = np.zeros(num, dtype=np.bool_)
    for q in range(b):
        present[:] = False
        for p in range(ids.shape[1]):
            j = ids[q, p]
            if j >= 0 and j < num:
                present[j] = True
        for j in range(num):
            if present[j]:
                out[q, j] = np.float32(1.0 / (1.0 + np.exp(-np.float64(logits[q, j]))))
    return out


@numba.njit(**_JIT)
def take(xy: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """(B, M, 2) the points of xy (B, N, 2) at idx (B, M)."""
    b, m = idx.shape
    out = np.empty((b, m, xy.shape[2]), dtype=xy.dtype)
    for s in range(b):
        for c in range(m):
            out[s, c] = xy[s, idx[s, c]]
    return out


@numba.njit(**_JIT)
def group(xy: np.ndarray, feats: np.ndarray, centres: np.ndarray, groups: np.ndarray,
          radius: np.float32) -> np.ndarray:
    """(B, M, K, 2 + C) a set abstraction's groups: per centre (B, M, 2) and neighbour groups
    (B, M, K) of xy (B, N, 2), the neighbour's offset from the centre / radius, then its
    features (B, N, C) (float32, as the torch form rounds it: a subtraction, then a division)."""
    b, m, k = groups.shape
    c = feats.shape[2]
    out = np.empty((b, m, k, 2 + c), dtype=np.float32)
    for s in range(b):
        for g in range(m):
            cx, cy = centres[s, g, 0], centres[s, g, 1]
            for j in range(k):
                p = groups[s, g, j]
                out[s, g, j, 0] = np.float32(xy[s, p, 0] - cx) / radius
                out[s, g, j, 1] = np.float32(xy[s, p, 1] - cy) / radius
                for ch in range(c):
                    out[s, g, j, 2 + ch] = feats[s, p, ch]
    return out


# -- the encoding's per-point steps (`encoding.encode_query`) ----------------------------------
# float64 throughout, each operation in the order the NumPy form of the encoding ran it (no fused
# multiply-add: numba does not contract without fastmath), so every value and flag is the same.


@numba.njit(**_JIT)
def window_split(xy: np.ndarray, ids: np.ndarray, cx: float, cy: float, c: float, s: float,
                 index: int, crop: tuple[float, float, float], half_width: float,
                 finger_reach: float) -> tuple[np.ndarray, ...]:
    """One query's view of a state cloud: points xy (M, 2) moved so (cx, cy) is the origin and
    rotated by -theta (c, s = cos, sin theta) -> rot (M, 2); in_corridor (M,) (|y| <= half_width
    and x <= finger_reach); and, in point order, the indices of the queried object's points (id
    `index`, wherever they are), of the other points in the crop window (x in [crop[0],
    crop[1]], |y| <= crop[2]) inside the corridor, and of those outside it."""
    m = xy.shape[0]
    rot = np.empty((m, 2))
    in_corridor = np.empty(m, dtype=np.bool_)
    query = np.empty(m, dtype=np.int64)
    corridor = np.empty(m, dtype=np.int64)
    others = np.empty(m, dtype=np.int64)
    nq = nc = no = 0
    for p in range(m):
        rx, ry = xy[p, 0] - cx, xy[p, 1] - cy
        x = c * rx + s * ry
        y = -s * rx + c * ry
        rot[p, 0], rot[p, 1] = x, y
        inside = abs(y) <= half_width and x <= finger_reach
        in_corridor[p] = inside
        if ids[p] == index:
            query[nq] = p
            nq += 1
        elif x >= crop[0] and x <= crop[1] and abs(y) <= crop[2]:
            if inside:
                corridor[nc] = p
                nc += 1
            else:
                others[no] = p
                no += 1
    return rot, in_corridor, query[:nq], corridor[:nc], others[:no]


@numba.njit(**_JIT)
def firsts_first(points: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """`points` reordered: the first point of each object id (ids[points]), ascending by id, then
    the rest in their order (the order np.unique(ids[points], return_index=True) gives)."""
    n = points.shape[0]
    if n == 0:
        return points.copy()
    lo, hi = ids[points[0]], ids[points[0]]
    for j in range(n):
        g = ids[points[j]]
        lo, hi = min(lo, g), max(hi, g)
    first = np.full(hi - lo + 1, -1, dtype=np.int64)
    for j in range(n):
        g = ids[points[j]] - lo
        if first[g] < 0:
            first[g] = j
    out = np.empty(n, dtype=np.int64)
    taken = np.zeros(n, dtype=np.bool_)
    k = 0
    for g in range(first.shape[0]):
        if first[g] >= 0:
            out[k] = points[first[g]]
            taken[first[g]] = True
            k += 1
    for j in range(n):
        if not taken[j]:
            out[k] = points[j]
            k += 1
    return out


@numba.njit(**_JIT)
def hull_hits(centres: np.ndarray, hulls: np.ndarray, normals: np.ndarray, low: np.ndarray,
              high: np.ndarray, edges: np.ndarray, index: int, ux: float, uy: float,
              outside: float, front: float, half: float) -> np.ndarray:
    """(N,) whether each object's padded hull (N, K, 2) meets the approach corridor to object
    `index` along u = (ux, uy) (False for `index`; touching counts as meeting): a separating-axis
    test of the corridor box (from `outside` behind the shelf front to `front` past the object's
    centre, `half` either side) against each hull, the box's own two axes first, then the hull's
    edge normals with its precomputed extents `low` / `high` (N, K); `edges` (N, K) marks the
    real edges (the padding's are zero-length)."""
    n, k = hulls.shape[0], hulls.shape[1]
    vx, vy = -uy, ux
    back = (centres[index, 0] + outside) / max(ux, 1e-6)
    step = (front - back) / 2
    mx, my = centres[index, 0] + step * ux, centres[index, 1] + step * uy
    length = (front + back) / 2
    hits = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        if i == index:
            continue
        a_lo = a_hi = c_lo = c_hi = 0.0
        for j in range(k):
            dx, dy = hulls[i, j, 0] - mx, hulls[i, j, 1] - my
            along = dx * ux + dy * uy
            across = dx * vx + dy * vy
            if j == 0 or along < a_lo:
                a_lo = along
            if j == 0 or along > a_hi:
                a_hi = along
            if j == 0 or across < c_lo:
                c_lo = across
            if j == 0 or across > c_hi:
                c_hi = across
        if not (a_lo <= length and a_hi >= -length and c_lo <= half and c_hi >= -half):
            continue
        hit = True
        for j in range(k):
            if not edges[i, j]:
                continue
            nx, ny = normals[i, j, 0], normals[i, j, 1]
            centre = nx * mx + ny * my
            extent = length * abs(nx * ux + ny * uy) + half * abs(nx * vx + ny * vy)
            if centre - extent > high[i, j] or centre + extent < low[i, j]:
                hit = False
                break
        hits[i] = hit
    return hits


@numba.njit(**_JIT)
def query_features(rot: np.ndarray, z: np.ndarray, ids: np.ndarray, in_corridor: np.ndarray,
                   chosen: np.ndarray, hits: np.ndarray, index: int, fits: bool, wall_id: int,
                   coord_scale: float, height_scale: float) -> tuple[np.ndarray, ...]:
    """The chosen points' network input: xy (P, 2) = rot / coord_scale, feats (P, 6) (height /
    height_scale, is-query, is-wall, in-corridor, its object's hull hits the corridor (`hits`),
    is-query and the query fits the stroke), both float32, and their ids (P,)."""
    p = chosen.shape[0]
    xy = np.empty((p, 2), dtype=np.float32)
    feats = np.zeros((p, 6), dtype=np.float32)
    out_ids = np.empty(p, dtype=np.int64)
    for r in range(p):
        q = chosen[r]
        g = ids[q]
        out_ids[r] = g
        xy[r, 0] = rot[q, 0] / coord_scale
        xy[r, 1] = rot[q, 1] / coord_scale
        feats[r, 0] = z[q] / height_scale
        if g == index:
            feats[r, 1] = 1.0
            if fits:
                feats[r, 5] = 1.0
        if g == wall_id:
            feats[r, 2] = 1.0
        if in_corridor[q]:
            feats[r, 3] = 1.0
        if g >= 0 and hits[g]:
            feats[r, 4] = 1.0
    return xy, feats, out_ids
