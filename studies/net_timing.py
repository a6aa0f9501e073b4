"""Prehensile network timing: `python -m studies.net_timing`.

Times a forward pass of the shipped network per query at several batch sizes and thread counts
(inputs encoded from a generated scene, so the sampling and grouping see real point layouts),
and the encoding of one query and of one state cloud.
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from studies.perception_timing import best_time
from tsad_drake.perception.observe import observe_raycast
from tsad_drake.planning.state import make_workspace, state_from_perception
from tsad_drake.prehensile import encoding
from tsad_drake.prehensile.checkpoint import load_checkpoint
from tsad_drake.prehensile.network import query_scores
from tsad_drake.scenes import generate_scenario


def _per_call(fn, calls: int) -> float:
    """Seconds per call of `fn` (best of 3 runs of `calls` calls, after one warm-up call)."""
    fn()
    return best_time(lambda: [fn() for _ in range(calls)], 3) / calls


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batches", default="1,7,64", help="comma-separated batch sizes")
    parser.add_argument("--threads", default="1,2", help="comma-separated torch thread counts")
    parser.add_argument("--scenario", default="1", help="built-in scenario of the scene")
    parser.add_argument("--seed", type=int, default=0, help="seed of the scene")
    args = parser.parse_args(argv)
    net, _ = load_checkpoint(None)
    scenario = generate_scenario(args.scenario, args.seed)
    workspace = make_workspace(scenario)
    state = state_from_perception(observe_raycast(scenario).scene)
    cloud = encoding.state_cloud(state, workspace)
    thetas = workspace.approach_angles
    pairs = [(i, k) for i in range(len(state.objects)) for k in range(len(thetas))]
    xy, feats, ids = encoding.encode_batch(cloud, pairs, thetas)
    print("batch  threads  ms per query")
    for threads in (int(t) for t in args.threads.split(",")):
        torch.set_num_threads(threads)
        for batch in (int(b) for b in args.batches.split(",")):
            rows = np.arange(batch) % len(pairs)
            queried = [pairs[r][0] for r in rows]
            seconds = _per_call(lambda rows=rows, queried=queried: query_scores(
                net, xy[rows], feats[rows], ids[rows], queried, len(state.objects)), 20)
            print(f"{batch:5d}  {threads:7d}  {1e3 * seconds / batch:12.2f}")
    encode = _per_call(lambda: encoding.encode_query(cloud, 1, float(thetas[2]), 2), 200)
    cloud_s = _per_call(lambda: encoding.state_cloud(state, workspace), 200)
    print(f"encoding: {1e3 * encode:.2f} ms per query, {1e3 * cloud_s:.2f} ms per state cloud "
          f"(objects' flattened points and hulls memoised)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
