"""Training and evaluation of the prehensile network (CPU, seeded).

`net-eval` scores a FeasibilityModel against the oracle on fresh scenes: every (object, angle) of
every state (no class balancing: the planners' distribution) for pickable (the decision the
planners use), collide (some object in the corridor), blockers (the predicted set equals the
oracle's R_{theta,s} exactly) and reach (fits the stroke, misses the walls); a majority-class
classifier's pickable accuracy is the trivial baseline.

"""

from __future__ import annotations

import dataclasses as dc
import math
import time
from pathlib import Path

import numpy as np
import torch
from torch import nn

from tsad_drake.prehensile import dataset as pdata
from tsad_drake.prehensile import encoding
from tsad_drake.prehensile.checkpoint import load_checkpoint, save_checkpoint
from tsad_drake.prehensile.network import (
    NetConfig,
    PrehensileNet,
    object_presence,
    query_scores,
)
from tsad_drake.prehensile.weights import weights_digest
from tsad_drake.runtime import show_progress

BLOCK_LOSS_WEIGHT = 1.0  #: weight of the per-object blocker loss against the reach loss


# -- training ------------------------------------------------------------------------------------
def to_tensors(data: pdata.Samples, rows: np.ndarray) -> tuple[torch.Tensor, ...]:
    """(xy, feats, ids, object labels, object present, reach) of dataset rows. ids are -1 for
    points that belong to no candidate blocker (walls, the queried object); an object's label is
    1 when its points are labelled as blocker points."""
    plabel = torch.from_numpy(data.point_label[rows].astype(np.int64))
    ids = torch.from_numpy(data.ids[rows].astype(np.int64))
    ids = torch.where(plabel < 0, torch.full_like(ids, -1), ids)
    num = int(ids.max()) + 1 if ids.numel() and int(ids.max()) >= 0 else 1
    slot = torch.where(ids >= 0, ids, torch.full_like(ids, num))
    positive = torch.zeros(len(rows), num + 1).scatter_add_(1, slot, (plabel == 1).float())
    return (torch.from_numpy(data.xy[rows].astype(np.float32)),
            torch.from_numpy(data.feats[rows].astype(np.float32)),
            ids, (positive[:, :num] > 0).float(), object_presence(ids, num),
            torch.from_numpy(data.reach[rows].astype(np.float32)))


def augment(xy: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
    """Small random jitter of every point (sensor noise), 1 mm in scaled units."""
    return xy + torch.randn(xy.shape, generator=generator) * (0.001 / encoding.COORD_SCALE)


def losses(net: PrehensileNet, xy, feats, ids, labels, present, reach, pos_weight: float):
    reach_logit, block_logit = net(xy, feats, ids, labels.shape[1])
    reach_loss = nn.functional.binary_cross_entropy_with_logits(reach_logit, reach)
    block_loss = nn.functional.binary_cross_entropy_with_logits(
        block_logit[present], labels[present], pos_weight=torch.tensor(pos_weight))
    return reach_loss + BLOCK_LOSS_WEIGHT * block_loss, reach_logit, block_logit


def predict_samples(net: PrehensileNet, data: pdata.Samples, rows: np.ndarray,
                    batch: int = 128) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(reach prediction, collide prediction, blocker set exact) per dataset row; a query
    collides when some object other than the queried one has a block probability above 0.5."""
    reach, collide, exact = [], [], []
    with torch.no_grad():
        for start in range(0, len(rows), batch):
            xy, feats, ids, labels, present, _ = to_tensors(data, rows[start:start + batch])
            r, b = net(xy, feats, ids, labels.shape[1])
            blocks = (torch.sigmoid(b) > 0.5) & present
            reach.append((r > 0).numpy())
            collide.append(blocks.any(dim=1).numpy())
            exact.append((blocks == (labels > 0)).all(dim=1).numpy())
    return np.concatenate(reach), np.concatenate(collide), np.concatenate(exact)


def binary_metrics(pred: np.ndarray, truth: np.ndarray) -> dict:
    pred, truth = pred.astype(bool), truth.astype(bool)
    tp = int((pred & truth).sum())
    fp = int((pred & ~truth).sum())
    fn = int((~pred & truth).sum())
    n = len(truth)
    return {"n": n, "accuracy": round(float((pred == truth).mean()), 4) if n else math.nan,
            "precision": round(tp / (tp + fp), 4) if tp + fp else math.nan,
            "recall": round(tp / (tp + fn), 4) if tp + fn else math.nan,
            "positives": int(truth.sum())}


def _split_rows(data: pdata.Samples, data_dir: Path, rng: np.random.Generator,
                max_val_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """(train rows, validation rows): the scene-level split, validation a fixed random subset of
    at most `max_val_samples` (quick on 2 cores). ValueError when either split is empty."""
    splits = np.array([pdata.split_of(int(s)) for s in data.scene])
    train_rows = np.nonzero(splits == "train")[0]
    val_rows = np.nonzero(splits == "val")[0]
    if len(val_rows) > max_val_samples:
        val_rows = np.sort(rng.choice(val_rows, max_val_samples, replace=False))
    if len(train_rows) == 0 or len(val_rows) == 0:
        raise ValueError(f"dataset {data_dir} needs scenes in the train and validation splits "
                         "(seeds with (seed // 4) % 10 == 8 are validation): generate more scenes")
    return train_rows, val_rows


def _train_epoch(net: PrehensileNet, opt, sched, data: pdata.Samples, order: np.ndarray,
                 batch: int, pos_weight: float, gen: torch.Generator, deadline: float,
                 bar) -> tuple[list[float], bool]:
    """One pass over `order` in batches; (losses, whether the deadline cut it short)."""
    running = []
    for step in bar:
        xy, feats, ids, labels, present, reach = to_tensors(
            data, order[step * batch:(step + 1) * batch])
        loss, _, _ = losses(net, augment(xy, gen), feats, ids, labels, present, reach, pos_weight)
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        running.append(loss.item())
        bar.set_postfix(loss=f"{np.mean(running[-50:]):.4f}")
        if time.perf_counter() > deadline:
            return running, True
    return running, False


def _epoch_entry(epoch: int, running: list[float], val: dict, start: float, progress: bool) -> dict:
    """The history record of one epoch (printed with `progress`)."""
    entry = {"epoch": epoch + 1, "train_loss": round(float(np.mean(running)), 5),
             "val_pickable_accuracy": val["pickable"]["accuracy"],
             "val_blockers_exact": val["blockers_exact"],
             "val_reach_accuracy": val["reach"]["accuracy"],
             "val_collide_accuracy": val["collide"]["accuracy"],
             "minutes": round((time.perf_counter() - start) / 60, 2)}
    if show_progress(progress):
        print(f"epoch {epoch + 1}: loss {entry['train_loss']:.4f} val pickable acc "
              f"{entry['val_pickable_accuracy']:.4f} R exact {entry['val_blockers_exact']:.4f} "
              f"reach {entry['val_reach_accuracy']:.4f} collide {entry['val_collide_accuracy']:.4f}"
              f" ({entry['minutes']:.1f} min)", flush=True)
    return entry


def train(data_dir: Path, out: Path, epochs: int = 30, batch: int = 32, lr: float = 2e-3,
          seed: int = 0, max_minutes: float = 30.0, threads: int = 2,
          progress: bool = True, max_val_samples: int = 3000, calibrate_scenes: int = 16,
          samples: pdata.Samples | None = None, init: Path | None = None,
          sensing: pdata.Sensing = pdata.DEFAULT_SENSING) -> dict:
    """Train on the shards in `data_dir`, validate each epoch, keep the best checkpoint at `out`.

    Stops after `epochs` or once `max_minutes` of wall clock have passed (checked per step); the
    learning rate follows a cosine schedule over the planned steps or the time budget, whichever
    runs out first. Validation uses a fixed subset of at most `max_val_samples` validation queries.
    Finally the decision thresholds are calibrated on `calibrate_scenes` fresh scenes
    (`calibrate_thresholds`). `samples`: the dataset when the caller has loaded (and so checked)
    it already. `init`: a weights file to start from (fine-tuning) instead of a random
    initialisation. `sensing`: how the data was observed, so the calibration scenes are observed
    alike. Returns a summary.
    """
    from tqdm import tqdm

    torch.set_num_threads(threads)
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    gen = torch.Generator().manual_seed(seed)
    data = samples if samples is not None else pdata.load_dataset(data_dir)  # loaded by the caller
    train_rows, val_rows = _split_rows(data, data_dir, rng, max_val_samples)
    _, _, _, labels, present, _ = to_tensors(data, train_rows[:4000])
    positive = float(labels[present].mean()) if bool(present.any()) else 0.5
    pos_weight = float(np.clip((1 - positive) / max(positive, 1e-6), 1.0, 10.0) ** 0.5)
    if init is not None:
        net = load_checkpoint(init)[0]
    else:
        net = PrehensileNet(NetConfig(num_points=encoding.NUM_POINTS,
                                      in_features=encoding.NUM_FEATURES))
    opt = torch.optim.AdamW(net.parameters(), lr=lr, weight_decay=1e-4)
    steps_per_epoch = math.ceil(len(train_rows) / batch)
    total_steps = epochs * steps_per_epoch
    start = time.perf_counter()
    deadline = start + max_minutes * 60

    def progress_fraction(k: int) -> float:  # of the planned steps or of the time budget
        return min(1.0, max(k / total_steps, (time.perf_counter() - start) / (max_minutes * 60)))

    sched = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda k: 0.02 + 0.98 * 0.5 * (1 + math.cos(math.pi * progress_fraction(k))))
    best, history = -1.0, []
    out = Path(out)
    for epoch in range(epochs):
        if time.perf_counter() > deadline:
            break
        net.train()
        order = rng.permutation(train_rows)
        bar = tqdm(range(steps_per_epoch), desc=f"epoch {epoch + 1}/{epochs}", unit="step",
                   disable=not show_progress(progress), leave=False)
        running, timed_out = _train_epoch(net, opt, sched, data, order, batch, pos_weight, gen,
                                          deadline, bar)
        bar.close()
        net.eval()
        val = evaluate_rows(net, data, val_rows)
        # the planners read both the pickable decision and the blocker sets R_{theta,s}
        score = 0.5 * (val["pickable"]["accuracy"] + val["blockers_exact"])
        history.append(_epoch_entry(epoch, running, val, start, progress))
        if score > best:
            best = score
            save_checkpoint(net, out, {
                "epoch": epoch + 1, "val": val, "seed": seed, "batch": batch, "lr": lr,
                "train_samples": int(len(train_rows)), "val_samples": int(len(val_rows)),
                "scenes": int(len(np.unique(data.scene))),
                "dataset": pdata.dataset_fingerprint(data_dir), "pos_weight": pos_weight,
                "seed_range": [int(data.scene.min()), int(data.scene.max())],
                "init": None if init is None else weights_digest(init),
                "sensing": dc.asdict(sensing),
                "minutes": round((time.perf_counter() - start) / 60, 2)})
        if timed_out:
            break
    if calibrate_scenes > 0:
        calibrate_thresholds(out, calibrate_scenes, progress=progress, sensing=sensing)
    return {"best_val_score": best, "epochs_run": len(history), "history": history,
            "minutes": round((time.perf_counter() - start) / 60, 2), "weights": str(out)}


def evaluate_rows(net: PrehensileNet, data: pdata.Samples, rows: np.ndarray) -> dict:
    """Sample-level metrics (reach, collide, pickable) on dataset rows."""
    reach, collide, exact = predict_samples(net, data, rows)
    true_collide = (data.point_label[rows] == 1).any(axis=1)
    return {"reach": binary_metrics(reach, data.reach[rows]),
            "collide": binary_metrics(collide, true_collide),
            "pickable": binary_metrics(reach & ~collide, data.pickable[rows]),
            "blockers_exact": round(float(exact.mean()), 4)}


# -- evaluation on fresh scenes (`tsad net-eval`) ---------------------------------------------
def evaluate_scenes(model_factory, scenes: int, seed_start: int,
                    sensing: pdata.Sensing = pdata.DEFAULT_SENSING, progress: bool = True) -> dict:
    """Score `model_factory(workspace)` (a FeasibilityModel) against the oracle on scenes
    seed_start..seed_start+scenes-1 (type SCENARIO_TYPES[seed % 4]); per type and "all"."""
    from tqdm import tqdm

    rows: dict[str, list] = {}
    models: dict[tuple, object] = {}
    evaluations, seconds = 0, 0.0
    for seed in tqdm(range(seed_start, seed_start + scenes), desc="net-eval scenes", unit="scene",
                     disable=not show_progress(progress)):
        for _, state, oracle in pdata.scene_states(seed, sensing):
            ws = oracle.workspace
            key = (ws.depth, ws.width)
            model = models.get(key)
            if model is None:
                model = models[key] = model_factory(ws)
            labels = pdata.oracle_labels(oracle, state)
            start = time.perf_counter()
            model.evaluate_all(state)
            pred = [(model.pickable(state, i), model.blockers(state, i), model.reachable(state, i))
                    for i in range(len(state.objects))]
            seconds += time.perf_counter() - start
            evaluations += len(state.objects) * len(ws.approach_angles)
            out = rows.setdefault(pdata.scenario_type(seed), [])
            for i, (pick, blockers, reach) in enumerate(pred):
                for a in range(len(ws.approach_angles)):
                    out.append((pick[a], labels.pickable[i, a], bool(blockers[a]),
                                bool(labels.blockers[i][a]), blockers[a] == labels.blockers[i][a],
                                reach[a], labels.reach[i, a]))
    result = {name: _metrics(np.array(r, dtype=bool)) for name, r in sorted(rows.items())}
    if rows:
        result["all"] = _metrics(np.array([x for r in rows.values() for x in r], dtype=bool))
    result["queries_per_second"] = round(evaluations / seconds, 1) if seconds else 0.0
    return result


def _metrics(r: np.ndarray) -> dict:
    majority = max(r[:, 1].mean(), 1 - r[:, 1].mean())
    return {"pickable": binary_metrics(r[:, 0], r[:, 1]),
            "collide": binary_metrics(r[:, 2], r[:, 3]),
            "blockers_exact": round(float(r[:, 4].mean()), 4),
            "reach": binary_metrics(r[:, 5], r[:, 6]),
            "majority_pickable_accuracy": round(float(majority), 4)}


def format_table(result: dict) -> str:
    """Fixed-width table: per scenario type, pickable accuracy/precision/recall and the rest."""
    head = (f"{'scenario':<9} {'queries':>7} {'pick acc':>8} {'prec':>6} {'recall':>6} "
            f"{'majority':>8} {'collide acc':>11} {'R exact':>7} {'reach acc':>9}")
    lines = [head, "-" * len(head)]
    for name, m in result.items():
        if not isinstance(m, dict) or "pickable" not in m:
            continue
        p = m["pickable"]
        lines.append(f"{name:<9} {p['n']:>7d} {p['accuracy']:>8.4f} {p['precision']:>6.3f} "
                     f"{p['recall']:>6.3f} {m['majority_pickable_accuracy']:>8.4f} "
                     f"{m['collide']['accuracy']:>11.4f} {m['blockers_exact']:>7.4f} "
                     f"{m['reach']['accuracy']:>9.4f}")
    lines.append(f"network queries per second (batched, incl. encoding): {result['queries_per_second']}")
    return "\n".join(lines)


CALIBRATION_SEED_START = 200_000  #: fresh scenes for threshold calibration (not train, not eval)


def calibrate_thresholds(weights: Path, scenes: int = 16, seed_start: int = CALIBRATION_SEED_START,
                         progress: bool = True, sensing: pdata.Sensing = pdata.DEFAULT_SENSING
                         ) -> dict:
    """Pick the reach logit threshold that maximises reach accuracy and then the block
    probability threshold that maximises pickable accuracy on fresh scenes (every (object,
    angle): the planners' distribution, not the balanced training one; ties go to the lower
    reach threshold), then the set threshold that makes R_{theta,s} exact most often
    (`prehensile.feasibility.blocker_set`), and store them in the checkpoint's meta. The scenes
    are observed as `sensing` says (the sensing the network will plan on)."""
    from tqdm import tqdm

    net, meta = load_checkpoint(weights)
    reach_logits, block_probs, true_pick, true_reach = [], [], [], []
    pair_probs, true_sets = [], []  # per query: block probabilities and the oracle's R
    for seed in tqdm(range(seed_start, seed_start + scenes), desc="calibration scenes",
                     disable=not show_progress(progress)):
        for _, state, oracle in pdata.scene_states(seed, sensing):
            thetas = oracle.workspace.approach_angles
            labels = pdata.oracle_labels(oracle, state)
            cloud = encoding.state_cloud(state, oracle.workspace)
            pairs = [(i, k) for i in range(len(state.objects)) for k in range(len(thetas))]
            xy, feats, ids = encoding.encode_batch(cloud, pairs, thetas)
            reach, prob = query_scores(net, xy, feats, ids, [i for i, _ in pairs],
                                       len(state.objects))
            prob = prob.numpy()
            reach_logits.append(reach.numpy())
            block_probs.append(prob.max(axis=1))  # the most likely blocker decides
            true_pick.append(np.array([labels.pickable[p] for p in pairs]))
            true_reach.append(np.array([labels.reach[p] for p in pairs]))
            pair_probs += [(prob[r], i) for r, (i, _) in enumerate(pairs)]
            true_sets += [labels.blockers[i][k] for i, k in pairs]
    reach_logits, block_probs = np.concatenate(reach_logits), np.concatenate(block_probs)
    true_pick, true_reach = np.concatenate(true_pick), np.concatenate(true_reach)
    # the reach threshold on the reach label itself: tuned for pickable accuracy it went to a
    # strict 4.5 (pickable hardly notices, most of those objects are blocked anyway), which
    # called 174 fitting (object, angle) pairs of 48 fresh scenes "does not fit" (logit 1: 3),
    # once every angle of a target (an episode over at once); then the block threshold
    reach_acc, rt = -1.0, 0.0
    for threshold in np.linspace(-2.0, 6.0, 33):  # ascending: ties keep the lower threshold
        acc = float(((reach_logits > threshold) == true_reach).mean())
        if acc > reach_acc + 1e-9:
            reach_acc, rt = acc, float(threshold)
    best = (-1.0, rt, 0.5)
    for bt in np.linspace(0.05, 0.8, 16):
        acc = float((((reach_logits > rt) & (block_probs <= bt)) == true_pick).mean())
        if acc > best[0] + 1e-9:
            best = (acc, rt, float(bt))
    default = float((((reach_logits > 0) & (block_probs <= 0.5)) == true_pick).mean())
    # the set threshold: the most exact R_{theta,s} given the collision threshold just chosen
    from tsad_drake.prehensile.feasibility import blocker_set

    def exactness(set_threshold: float) -> float:
        return float(np.mean([blocker_set(p, i, best[2], set_threshold) == truth
                              for (p, i), truth in zip(pair_probs, true_sets)]))

    best_set = (-1.0, best[2])
    for st in np.linspace(best[2], 0.95, 15):
        exact = exactness(float(st))
        if exact > best_set[0] + 1e-9:
            best_set = (exact, float(st))
    exact_single = exactness(best[2])
    meta.update(reach_threshold=best[1], block_threshold=best[2], set_threshold=best_set[1],
                calibration={"seeds": [seed_start, seed_start + scenes - 1],
                             "sensing": dc.asdict(sensing),
                             "queries": int(len(true_pick)), "accuracy": round(best[0], 4),
                             "reach_accuracy": round(reach_acc, 4),
                             "accuracy_default_thresholds": round(default, 4),
                             "blockers_exact": round(best_set[0], 4),
                             "blockers_exact_one_threshold": round(exact_single, 4)})
    save_checkpoint(net, Path(weights), meta)
    return meta["calibration"] | {"reach_threshold": best[1], "block_threshold": best[2],
                                  "set_threshold": best_set[1]}
