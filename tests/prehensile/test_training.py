"""Training lowers the loss; checkpoints round-trip; bad weights are bad input (exit 2);
the shipped weights beat a majority-class classifier on fresh scenes."""


import numpy as np
import pytest
import torch

from tsad_drake.errors import EXIT_BAD_INPUT, UsageError, WeightsError
from tsad_drake.prehensile import dataset as pdata
from tsad_drake.prehensile.checkpoint import load_checkpoint, save_checkpoint
from tsad_drake.prehensile.network import PrehensileNet
from tsad_drake.prehensile.training import evaluate_scenes, losses, to_tensors
from tsad_drake.prehensile.weights import DEFAULT_WEIGHTS


@pytest.fixture(scope="module")
def samples():
    return pdata.scene_samples(3)  # scenario "real", seed 3


def test_a_few_training_steps_lower_the_loss(samples):
    torch.manual_seed(0)
    torch.set_num_threads(2)
    net = PrehensileNet()
    opt = torch.optim.Adam(net.parameters(), lr=3e-3)
    rows = np.arange(min(len(samples), 24))
    batch = to_tensors(samples, rows)
    with torch.no_grad():
        before = float(losses(net, *batch, pos_weight=2.0)[0])
    for _ in range(12):
        loss = losses(net, *batch, pos_weight=2.0)[0]
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        after = float(losses(net, *batch, pos_weight=2.0)[0])
    assert after < 0.8 * before


def test_checkpoint_round_trip(tmp_path):
    torch.manual_seed(1)
    net = PrehensileNet()
    path = tmp_path / "w.pt"
    save_checkpoint(net, path, {"note": "test"})
    loaded, meta = load_checkpoint(path)
    assert meta == {"note": "test"}
    for a, b in zip(net.state_dict().values(), loaded.state_dict().values()):
        assert torch.equal(a, b)


@pytest.mark.parametrize("content", [b"", b"not a torch file at all", b"PK\x03\x04garbage"])
def test_corrupted_weights_raise_usage_error(tmp_path, content):
    path = tmp_path / "bad.pt"
    path.write_bytes(content)
    with pytest.raises(UsageError):
        load_checkpoint(path)


def test_mismatched_weights_raise_usage_error(tmp_path):
    path = tmp_path / "other.pt"
    torch.save({"format": "something-else", "state_dict": {}}, path)
    with pytest.raises(WeightsError, match="not a prehensile network checkpoint"):
        load_checkpoint(path)
    net = PrehensileNet()
    save_checkpoint(net, path, {})
    ckpt = torch.load(path, weights_only=True)
    ckpt["state_dict"] = {k: v[..., :1] for k, v in ckpt["state_dict"].items()}
    torch.save(ckpt, path)
    with pytest.raises(WeightsError, match="does not match"):
        load_checkpoint(path)
    with pytest.raises(WeightsError, match="not found"):
        load_checkpoint(tmp_path / "missing.pt")


def _run_cli(argv):
    """`tsad <argv>` through the real entry point."""
    from tsad_drake.cli import main

    return main(argv)


def test_corrupted_weights_exit_2_through_the_cli(tmp_path, capsys):
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"corrupted")
    assert _run_cli(["net-eval", "--weights", str(bad), "--scenes", "1"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot read prehensile network weights" in err[0]
    assert _run_cli(["train", "--data", str(tmp_path / "nowhere"), "--out", str(bad)]) == 2


@pytest.mark.skipif(not DEFAULT_WEIGHTS.is_file(), reason="shipped weights not built yet")
def test_shipped_weights_beat_a_majority_classifier_on_fresh_scenes():
    from tsad_drake.prehensile.feasibility import NetFeasibility

    _, meta = load_checkpoint()
    seed_start = 900_000  # never used for training
    assert meta["seed_range"][1] < seed_start
    result = evaluate_scenes(lambda ws: NetFeasibility(ws), scenes=4, seed_start=seed_start,
                             progress=False)
    overall = result["all"]
    assert overall["pickable"]["accuracy"] > overall["majority_pickable_accuracy"]
    assert overall["pickable"]["accuracy"] >= 0.93
    assert overall["pickable"]["recall"] > 0.5


def test_realistic_weights_hold_on_fresh_scenes_under_realistic_sensing():
    """The weights shipped for `--sensor realistic` (fine-tuned on realistic depth with cluster
    segmentation) answer that sensing's fresh scenes better than a majority classifier, and they
    are the ones the pipeline picks for it."""
    from tsad_drake.pipeline import make_feasibility
    from tsad_drake.planning.state import make_workspace
    from tsad_drake.prehensile.feasibility import NetFeasibility
    from tsad_drake.prehensile.weights import REALISTIC_WEIGHTS, shipped_weights
    from tsad_drake.scenes import generate_scenario

    assert shipped_weights("realistic") == REALISTIC_WEIGHTS
    assert shipped_weights("ideal") == DEFAULT_WEIGHTS
    _, meta = load_checkpoint(REALISTIC_WEIGHTS)
    scenario = generate_scenario("real", 0)
    model = make_feasibility("net", scenario, make_workspace(scenario), "realistic")
    assert model.meta == meta and model.meta != load_checkpoint()[1]
    sensing = pdata.Sensing(sensor="realistic", segmentation="cluster")
    assert meta["sensing"] == {"observer": "raycast", "sensor": "realistic",
                               "segmentation": "cluster"}
    seed_start = 900_000  # never used for training
    assert meta["seed_range"][1] < seed_start
    result = evaluate_scenes(lambda ws: NetFeasibility(ws, REALISTIC_WEIGHTS), scenes=4,
                             seed_start=seed_start, sensing=sensing, progress=False)
    overall = result["all"]
    assert overall["pickable"]["accuracy"] > overall["majority_pickable_accuracy"]
    assert overall["pickable"]["accuracy"] >= 0.93
    assert overall["pickable"]["recall"] > 0.5


def test_fine_tuning_starts_from_the_given_weights(tmp_path):
    """`train(init=...)` starts from those weights: with a learning rate of 0 the kept checkpoint
    is the initial network itself, and its meta names the weights it started from."""
    from tsad_drake.prehensile.training import train
    from tsad_drake.prehensile.weights import weights_digest

    data = tmp_path / "data"
    for seed in (3, 35):  # scenario "real" in the train split and in the validation split
        pdata.generate_dataset(data, scenes=1, seed_start=seed, progress=False)
    out = tmp_path / "tuned.pt"
    train(data, out, epochs=1, lr=0.0, threads=1, progress=False, calibrate_scenes=0,
          init=DEFAULT_WEIGHTS)
    tuned, meta = load_checkpoint(out)
    shipped, _ = load_checkpoint(DEFAULT_WEIGHTS)
    for a, b in zip(shipped.state_dict().values(), tuned.state_dict().values(), strict=True):
        assert torch.equal(a, b)
    assert meta["init"] == weights_digest(DEFAULT_WEIGHTS)
    assert meta["sensing"] == {"observer": "raycast", "sensor": "ideal", "segmentation": "label",
                               "frames": 1}
