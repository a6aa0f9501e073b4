"""Issue 18's probes as a table: hostile or careless command lines over all 9 commands.

Every probe must end with its expected exit status, never a traceback, bad input (2) as one line
on stderr that says what is wrong (`needle`), and nothing written outside the probe's --out. The
probes are chosen so that each stops before any long work (or finishes quickly).
"""

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from cli_harness import assert_clean, bench_document, changed_outside, invoke, snapshot

from tsad_drake.bench.runner import EpisodeSpec, spec_scenario
from tsad_drake.pipeline import EpisodeSettings
from tsad_drake.prehensile.checkpoint import save_checkpoint
from tsad_drake.prehensile.dataset import Samples
from tsad_drake.prehensile.encoding import NUM_FEATURES
from tsad_drake.prehensile.network import PrehensileNet
from tsad_drake.scenario import save_scenario, scene_digest
from tsad_drake.scenes import generate_scenario

COMMANDS = ("scene", "render", "plan", "bench", "report", "config", "sweep", "dataset", "train",
            "net-calibrate", "net-eval")


class Evil:
    """A pickle that would run a command when loaded (torch's weights_only must refuse it)."""

    def __reduce__(self):
        return os.system, ("echo pwned > pwned.txt",)


def _samples(n: int = 2, points: int = 8) -> Samples:
    rng = np.random.default_rng(0)
    return Samples(rng.random((n, points, 2)).astype(np.float16),
                   rng.random((n, points, NUM_FEATURES)).astype(np.float16),
                   np.zeros((n, points), np.int8), np.zeros((n, points), np.int8),
                   np.ones(n, bool), np.ones(n, bool), np.arange(n, dtype=np.int64),
                   np.full(n, "1"), np.full(n, "observed"), np.zeros(n, np.float32))


def _shard_dir(root: Path, name: str, write) -> Path:
    folder = root / name
    folder.mkdir()
    write(folder / "shard_raycast_0000000_0002.npz")
    return folder


def _save_fields(path: Path, samples: Samples, **replace) -> None:
    fields = {f: getattr(samples, f) for f in Samples.FIELDS}
    fields.update(replace)
    np.savez_compressed(path, **{k: v for k, v in fields.items() if v is not None})


def _weights(root: Path, name: str, edit) -> Path:
    """A small real checkpoint, then `edit(document)` applied to its saved dictionary."""
    path = root / name
    torch.manual_seed(0)
    save_checkpoint(PrehensileNet(), path, {})
    document = torch.load(path, weights_only=True)
    edit(document)
    torch.save(document, path)
    return path


def _nan_weights(document: dict) -> None:
    first = next(iter(document["state_dict"]))
    document["state_dict"][first] = torch.full_like(document["state_dict"][first], float("nan"))


def _finished_row(seed: int) -> dict:
    spec = EpisodeSpec("3", seed, EpisodeSettings(planner="gp3", feasibility="geometric"))
    row = spec.identity() | {"seed": seed}  # as `run_spec` writes it
    row.update(success=True, num_actions=2, falls=0, planning_time_s=0.5, failure_reason="",
               scene_digest=scene_digest(spec_scenario(spec)))
    return row


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """Input files of every kind, good and corrupt (built once; probes must not change them)."""
    root = tmp_path_factory.mktemp("inputs")
    f: dict[str, Path] = {"root": root}
    scenario = generate_scenario("3", 0)  # under a second to generate
    f["yaml"] = root / "scene.yaml"
    save_scenario(scenario, f["yaml"])
    overlap = generate_scenario("3", 0)
    overlap.objects[1].x, overlap.objects[1].y = overlap.objects[0].x, overlap.objects[0].y
    f["overlap"] = root / "overlap.yaml"
    save_scenario(overlap, f["overlap"])
    texts = {"malformed.yaml": "objects: [{name: a, size: [0.1\n", "empty.yaml": "",
             "list.yaml": "- 1\n- 2\n", "notes.txt": "my notes\n", "not-json.json": "{nope",
             "list.json": "[1, 2]", "empty-object.json": "{}",
             "plan-like.json": json.dumps({"success": True, "actions": []})}
    for name, text in texts.items():
        f[name] = root / name
        f[name].write_text(text)
    f["binary.yaml"] = root / "binary.yaml"
    f["binary.yaml"].write_bytes(bytes(range(256)) * 4)
    f["binary.json"] = root / "binary.json"
    f["binary.json"].write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(200))
    f["folder"] = root / "folder"
    f["folder"].mkdir()
    bench = bench_document()
    f["bench.json"] = root / "bench.json"
    f["bench.json"].write_text(json.dumps(bench))
    broken = {"string-seed": lambda d: d["rows"][0].update(seed="0"),
              "nan-rate": lambda d: d["summary"].update(success_rate=float("nan")),
              "no-rows": lambda d: d.update(rows=[]),
              "no-failure-reason": lambda d: d["rows"][1].pop("failure_reason"),
              "spec-list": lambda d: d.update(spec=["gp3"])}
    for name, edit in broken.items():
        document = bench_document()
        edit(document)
        f[name] = root / f"{name}.json"
        f[name].write_text(json.dumps(document))
    # weights: unreadable, foreign, malformed and non-finite
    for name, content in {"empty.pt": b"", "garbage.pt": b"not a torch file",
                          "zip.pt": b"PK\x03\x04" + bytes(64)}.items():
        f[name] = root / name
        f[name].write_bytes(content)
    f["evil.pt"] = root / "evil.pt"
    torch.save({"format": "tsad-prehensile-net-v5", "payload": Evil()}, f["evil.pt"])
    edits = {
        "format.pt": lambda d: d.update(format="another-net"),
        "encoding.pt": lambda d: d["encoding"].update(NUM_POINTS=3),
        "config-list.pt": lambda d: d.update(config=[1, 2]),
        "config-string.pt": lambda d: d["config"].update(num_points="many"),
        "config-huge.pt": lambda d: d["config"].update(sa1_mlp=[10**9, 10**9]),
        "config-key.pt": lambda d: d["config"].update(extra_layers=3),
        "meta-list.pt": lambda d: d.update(meta=["a"]),
        "seed-range-text.pt": lambda d: d["meta"].update(seed_range="0..10"),
        "seed-range-reversed.pt": lambda d: d["meta"].update(seed_range=[9, 1]),
        "calibration-text.pt": lambda d: d["meta"].update(calibration="yes"),
        "threshold-nan.pt": lambda d: d["meta"].update(reach_threshold=float("nan")),
        "nan.pt": _nan_weights,
        "state-list.pt": lambda d: d.update(state_dict=[1, 2]),
        "state-shape.pt": lambda d: d.update(state_dict={k: v[..., :1] for k, v in
                                                         d["state_dict"].items()}),
    }
    for name, edit in edits.items():
        f[name] = _weights(root, name, edit)
    # dataset shards
    good = _samples()
    full = root / "shard-full.npz"
    good.save(full)
    f["shards-empty-file"] = _shard_dir(root, "shards-empty-file", lambda p: p.write_bytes(b""))
    f["shards-truncated"] = _shard_dir(root, "shards-truncated",
                                       lambda p: p.write_bytes(full.read_bytes()[:60]))
    f["shards-missing-field"] = _shard_dir(root, "shards-missing-field",
                                           lambda p: _save_fields(p, good, theta=None))
    f["shards-shape"] = _shard_dir(root, "shards-shape",
                                   lambda p: _save_fields(p, good, ids=np.zeros((2, 5), np.int8)))
    f["shards-nan"] = _shard_dir(root, "shards-nan", lambda p: _save_fields(
        p, good, xy=np.full((2, 8, 2), np.nan, np.float16)))
    f["shards-text"] = _shard_dir(root, "shards-text", lambda p: p.write_text("hello"))
    f["no-shards"] = root / "no-shards"
    f["no-shards"].mkdir()
    f["rows"] = root / "resume.rows.jsonl"  # a finished row among lines that are not rows
    lines = ["null", "[]", '"text"', '{"seed": "0"}', json.dumps(_finished_row(0)),
             '{"seed": 0, "succ']
    f["rows"].write_text("\n".join(lines))
    return f


#: (id, command line with {placeholders}, expected exit status, text the error line must hold)
PROBES = [
    # -- the command line itself
    ("no-command", [], 2, "required"),
    ("unknown-command", ["frobnicate"], 2, "invalid choice"),
    ("missing-required", ["scene"], 2, "required"),
    ("unknown-flag", ["scene", "--scenario", "3", "--out", "{out}/s.yaml", "--bogus"], 2, "bogus"),
    ("unknown-planner", ["plan", "--scenario", "3", "--planner", "astar"], 2, "astar"),
    ("unknown-segmentation", ["render", "--scenario", "3", "--segmentation", "magic",
                              "--out", "{out}"], 2, "magic"),
    ("seed-not-int", ["scene", "--scenario", "3", "--seed", "abc", "--out", "{out}/s.yaml"], 2,
     "abc"),
    ("episodes-float", ["bench", "--scenario", "3", "--planner", "gp3", "--episodes", "1.5",
                        "--out", "{out}/b.json"], 2, "1.5"),
    ("lr-text", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt", "--lr", "fast"], 2, "fast"),
    ("report-no-inputs", ["report", "--out", "{out}/r.md"], 2, "inputs"),
    ("scenes-hex", ["net-eval", "--scenes", "0x10"], 2, "0x10"),
    # -- scenarios
    ("scenario-unknown", ["scene", "--scenario", "7", "--out", "{out}/s.yaml"], 2, "unknown scenario"),
    ("scenario-empty", ["scene", "--scenario", "", "--out", "{out}/s.yaml"], 2, "unknown scenario"),
    ("scenario-missing", ["render", "--scenario", "{root}/missing.yaml", "--out", "{out}"], 2,
     "not found"),
    ("scenario-folder", ["plan", "--scenario", "{folder}", "--planner", "gp3", "--out", "{out}"], 2,
     "not found"),
    ("scenario-malformed", ["scene", "--scenario", "{malformed.yaml}", "--out", "{out}/s.yaml"], 2,
     "malformed"),
    ("scenario-empty-file", ["scene", "--scenario", "{empty.yaml}", "--out", "{out}/s.yaml"], 2,
     "malformed"),
    ("scenario-binary", ["scene", "--scenario", "{binary.yaml}", "--out", "{out}/s.yaml"], 2,
     "malformed"),
    ("scenario-list", ["plan", "--scenario", "{list.yaml}", "--planner", "gp3", "--out", "{out}"], 2,
     "malformed"),
    ("scenario-overlap", ["render", "--scenario", "{overlap}", "--out", "{out}"], 2, "overlap"),
    ("bench-yaml-overlap", ["bench", "--scenario", "{overlap}", "--planner", "gp3", "--out",
                            "{out}/b.json"], 2, "overlap"),
    ("sweep-missing", ["sweep", "{out}/missing.yaml", "--out", "{out}/sw"], 2, "cannot read"),
    ("sweep-scene-file", ["sweep", "{yaml}", "--out", "{out}/sw"], 2, "unknown to the schema"),
    # -- seeds
    ("seed-negative", ["scene", "--scenario", "3", "--seed", "-1", "--out", "{out}/s.yaml"], 2, "--seed"),
    ("seed-negative-yaml", ["scene", "--scenario", "{yaml}", "--seed", "-1", "--out", "{out}/s.yaml"],
     2, "--seed"),
    ("seed-negative-plan-yaml", ["plan", "--scenario", "{yaml}", "--seed", "-1", "--planner", "gp3",
                                 "--out", "{out}"], 2, "--seed"),
    ("seed-huge", ["render", "--scenario", "3", "--seed", str(2**40), "--out", "{out}"], 2, "--seed"),
    ("seed-enormous", ["plan", "--scenario", "3", "--seed", "9" * 30, "--planner", "gp3"], 2, "--seed"),
    ("seed-start-negative", ["bench", "--scenario", "3", "--planner", "gp3", "--seed-start", "-1",
                             "--out", "{out}/b.json"], 2, "--seed-start"),
    ("seed-start-overflow", ["bench", "--scenario", "3", "--planner", "gp3", "--seed-start",
                             str(2**31 - 1), "--episodes", "2", "--out", "{out}/b.json"], 2,
     "largest seed"),
    ("dataset-seed-negative", ["dataset", "--scenes", "1", "--seed-start", "-5", "--out", "{out}"],
     2, "--seed-start"),
    ("net-eval-seed-negative", ["net-eval", "--seed-start", "-1"], 2, "--seed-start"),
    ("train-seed-negative", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt", "--seed", "-1"],
     2, "--seed"),
    # -- --occluded
    ("occluded-yaml-scene", ["scene", "--scenario", "{yaml}", "--occluded", "--out", "{out}/s.yaml"],
     2, "--occluded"),
    ("occluded-yaml-render", ["render", "--scenario", "{yaml}", "--occluded", "--out", "{out}"], 2,
     "--occluded"),
    ("occluded-yaml-plan", ["plan", "--scenario", "{yaml}", "--occluded", "--planner", "gp3",
                            "--out", "{out}"], 2, "--occluded"),
    ("occluded-real-scene", ["scene", "--scenario", "real", "--occluded", "--out", "{out}/s.yaml"],
     2, "--occluded"),
    ("occluded-real-plan", ["plan", "--scenario", "real", "--occluded", "--planner", "gp3",
                            "--out", "{out}"], 2, "--occluded"),
    ("occluded-real-bench", ["bench", "--scenario", "real", "--occluded", "--planner", "gp3",
                             "--out", "{out}/b.json"], 2, "--occluded"),
    # -- --ablation with a planner that has none
    *[(f"ablation-{cmd}-{planner}", [cmd, "--scenario", "3", "--planner", planner, "--ablation",
                                     ablation, "--out", "{out}" + ("/b.json" if cmd == "bench" else "")],
       2, "--ablation")
      for cmd in ("plan", "bench")
      for planner, ablation in (("gp3", "no-ro"), ("rots", "no-re"), ("rots-star", "no-ro"),
                                ("rots-star-search", "no-re"), ("optimal", "no-ro"))],
    # -- --variant paper with a planner that has no variants
    *[(f"variant-{cmd}-{planner}", [cmd, "--scenario", "3", "--planner", planner, "--variant",
                                    "paper", "--out", "{out}" + ("/b.json" if cmd == "bench" else "")],
       2, "--variant")
      for cmd in ("plan", "bench") for planner in ("gp3", "rots-star")],
    ("variant-unknown", ["plan", "--scenario", "3", "--planner", "tsad", "--variant", "best",
                         "--out", "{out}"], 2, "--variant"),
    # -- numbers out of range
    ("max-actions-zero", ["plan", "--scenario", "3", "--planner", "gp3", "--max-actions", "0"], 2,
     "--max-actions"),
    ("max-actions-negative", ["plan", "--scenario", "3", "--planner", "gp3", "--max-actions", "-3"],
     2, "--max-actions"),
    ("max-actions-huge", ["plan", "--scenario", "3", "--planner", "gp3", "--max-actions", "1000000"],
     2, "--max-actions"),
    ("episodes-zero", ["bench", "--scenario", "3", "--planner", "gp3", "--episodes", "0",
                       "--out", "{out}/b.json"], 2, "--episodes"),
    ("episodes-huge", ["bench", "--scenario", "3", "--planner", "gp3", "--episodes", "1000000000",
                       "--out", "{out}/b.json"], 2, "--episodes"),
    ("workers-zero", ["bench", "--scenario", "3", "--planner", "gp3", "--workers", "0",
                      "--out", "{out}/b.json"], 2, "--workers"),
    ("workers-huge", ["bench", "--scenario", "3", "--planner", "gp3", "--workers", "100000",
                      "--out", "{out}/b.json"], 2, "--workers"),
    ("threads-zero-plan", ["plan", "--scenario", "3", "--planner", "gp3", "--threads", "0"], 2,
     "--threads"),
    ("threads-huge-bench", ["bench", "--scenario", "3", "--planner", "gp3", "--threads", "1000",
                            "--out", "{out}/b.json"], 2, "--threads"),
    ("dataset-scenes-zero", ["dataset", "--scenes", "0", "--out", "{out}"], 2, "--scenes"),
    ("dataset-scenes-huge", ["dataset", "--scenes", "1000000000", "--out", "{out}"], 2, "--scenes"),
    ("dataset-shard-size-zero", ["dataset", "--scenes", "1", "--shard-size", "0", "--out", "{out}"],
     2, "--shard-size"),
    ("dataset-threads-zero", ["dataset", "--scenes", "1", "--threads", "0", "--out", "{out}"], 2,
     "--threads"),
    ("train-epochs-zero", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt", "--epochs", "0"],
     2, "--epochs"),
    ("train-batch-zero", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt", "--batch", "0"],
     2, "--batch"),
    ("train-batch-huge", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt", "--batch",
                          "10000000"], 2, "--batch"),
    ("train-lr-nan", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt", "--lr", "nan"], 2,
     "--lr"),
    ("train-lr-inf", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt", "--lr", "inf"], 2,
     "--lr"),
    ("train-lr-negative", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt", "--lr", "-1"], 2,
     "--lr"),
    ("train-minutes-nan", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt",
                           "--max-minutes", "nan"], 2, "--max-minutes"),
    ("train-minutes-zero", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt",
                            "--max-minutes", "0"], 2, "--max-minutes"),
    ("train-threads-zero", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt",
                            "--threads", "0"], 2, "--threads"),
    ("net-eval-scenes-zero", ["net-eval", "--scenes", "0"], 2, "--scenes"),
    ("net-eval-threads-negative", ["net-eval", "--threads", "-1"], 2, "--threads"),
    ("net-calibrate-scenes-negative", ["net-calibrate", "--weights", "{nan.pt}", "--scenes", "-1"],
     2, "--scenes"),
    # -- output paths, checked before any work
    ("scene-out-folder", ["scene", "--scenario", "3", "--out", "{out}"], 2, "is a directory"),
    ("scene-out-dev-full", ["scene", "--scenario", "3", "--out", "/dev/full"], 2, "regular file"),
    ("report-out-dev-full", ["report", "{bench.json}", "--out", "/dev/full"], 2, "regular file"),
    ("bench-out-dev-full", ["bench", "--scenario", "3", "--planner", "gp3", "--out", "/dev/full"],
     2, "regular file"),
    ("net-eval-out-dev-full", ["net-eval", "--out", "/dev/full"], 2, "regular file"),
    ("bench-out-folder", ["bench", "--scenario", "3", "--planner", "gp3", "--out", "{out}"], 2,
     "is a directory"),
    ("train-out-folder", ["train", "--data", "{no-shards}", "--out", "{out}"], 2, "is a directory"),
    ("net-eval-out-folder", ["net-eval", "--out", "{out}"], 2, "is a directory"),
    ("report-out-folder", ["report", "{bench.json}", "--out", "{out}"], 2, "is a directory"),
    ("bench-out-unrelated-file", ["bench", "--scenario", "3", "--planner", "gp3",
                                  "--out", "{out}/notes.txt"], 2, "not a `tsad bench` result"),
    ("bench-rows-folder", ["bench", "--scenario", "3", "--planner", "gp3",
                           "--out", "{out}/rowsdir.json"], 2, "rows file"),
    ("report-overwrites-input", ["report", "{out}/in.json", "--out", "{out}/in.md"], 2,
     "overwrite the input"),
    ("report-out-is-input", ["report", "{out}/in.json", "--out", "{out}/in.json"], 2,
     "overwrite the input"),
    ("render-out-file", ["render", "--scenario", "3", "--out", "{out}/notes.txt"], 2,
     "not a directory"),
    ("plan-out-file", ["plan", "--scenario", "3", "--planner", "gp3", "--out", "{out}/notes.txt"],
     2, "not a directory"),
    ("dataset-out-file", ["dataset", "--scenes", "1", "--out", "{out}/notes.txt"], 2,
     "not a directory"),
    ("scene-out-under-file", ["scene", "--scenario", "3", "--out", "{out}/notes.txt/x/s.yaml"], 2,
     "cannot write"),
    ("plan-out-under-dev-null", ["plan", "--scenario", "3", "--planner", "gp3",
                                 "--out", "/dev/null/x"], 2, "cannot write"),
    ("scene-out-empty", ["scene", "--scenario", "3", "--out", ""], 2, "not a file name"),
    ("scene-out-dotdot", ["scene", "--scenario", "3", "--out", "{out}/.."], 2, "not a file name"),
    # -- weights files (net-eval and net-calibrate load them before any work)
    *[(f"weights-{name[:-3]}", ["net-eval", "--weights", "{" + name + "}"], 2, needle)
      for name, needle in (("empty.pt", "cannot read"), ("garbage.pt", "cannot read"),
                           ("zip.pt", "cannot read"), ("evil.pt", "cannot read"),
                           ("format.pt", "not a prehensile"), ("encoding.pt", "encoding"),
                           ("config-list.pt", "config"), ("config-string.pt", "config.num_points"),
                           ("config-huge.pt", "config.sa1_mlp"), ("config-key.pt", "config"),
                           ("meta-list.pt", "meta"), ("seed-range-text.pt", "seed_range"),
                           ("seed-range-reversed.pt", "seed_range"),
                           ("calibration-text.pt", "calibration"),
                           ("threshold-nan.pt", "reach_threshold"), ("nan.pt", "not finite"),
                           ("state-list.pt", "does not match"),
                           ("state-shape.pt", "does not match"))],
    ("weights-missing", ["net-eval", "--weights", "{root}/none.pt"], 2, "not found"),
    ("calibrate-nan-weights", ["net-calibrate", "--weights", "{nan.pt}"], 2, "not finite"),
    ("calibrate-evil-weights", ["net-calibrate", "--weights", "{evil.pt}"], 2, "cannot read"),
    # -- dataset shards
    ("train-data-missing", ["train", "--data", "{root}/nothing", "--out", "{out}/w.pt"], 2,
     "not a directory"),
    ("train-no-shards", ["train", "--data", "{no-shards}", "--out", "{out}/w.pt"], 2,
     "no dataset shards"),
    *[(f"train-{name}", ["train", "--data", "{" + name + "}", "--out", "{out}/w.pt"], 2, needle)
      for name, needle in (("shards-empty-file", "cannot read"), ("shards-truncated", "cannot read"),
                           ("shards-missing-field", "lacks theta"),
                           ("shards-shape", "wrong shape"), ("shards-nan", "not finite"),
                           ("shards-text", "cannot read"))],
    ("dataset-resume-corrupt-shard", ["dataset", "--scenes", "1", "--out", "{out}/corrupt"], 2,
     "dataset shard"),
    # -- report inputs
    *[(f"report-{name.split('.')[0]}", ["report", "{" + name + "}", "--out", "{out}/r.md"], 2, needle)
      for name, needle in (("not-json.json", "cannot read"), ("list.json", "not an object"),
                           ("empty-object.json", "spec"), ("plan-like.json", "spec"),
                           ("binary.json", "cannot read"), ("string-seed", "rows[0].seed"),
                           ("nan-rate", "success_rate"), ("no-rows", "rows"),
                           ("no-failure-reason", "failure_reason"), ("spec-list", "spec"))],
    ("report-missing-input", ["report", "{root}/none.json", "--out", "{out}/r.md"], 2, "cannot read"),
    ("report-folder-input", ["report", "{folder}", "--out", "{out}/r.md"], 2, "cannot read"),
    # -- tsad config (and --config/--set on plan and bench)
    ("config-no-dump", ["config", "--planner", "tsad"], 2, "--dump"),
    ("config-unknown-field", ["config", "--planner", "tsad", "--dump", "--set", "planner.nope=1"],
     2, "nope"),
    ("config-unknown-section", ["config", "--planner", "gp3", "--set", "brain.x=1"], 2, "brain"),
    ("config-wrong-type", ["config", "--planner", "tsad", "--set", "planner.iterations=many"], 2,
     "iterations"),
    ("config-missing-file", ["config", "--planner", "tsad", "--config", "{out}/none.yaml"], 2,
     "cannot read"),
    ("config-malformed-file", ["config", "--planner", "tsad", "--config", "{malformed.yaml}"], 2,
     "not valid YAML"),
    ("config-scenario-file", ["config", "--planner", "tsad", "--config", "{yaml}"], 2,
     "unknown section"),
    ("plan-config-bad-set", ["plan", "--scenario", "3", "--planner", "gp3", "--set",
                             "motion.clearance=[1]", "--out", "{out}/p"], 2, "clearance"),
    ("bench-config-missing", ["bench", "--scenario", "3", "--planner", "gp3", "--config",
                              "{out}/none.yaml", "--out", "{out}/b.json"], 2, "cannot read"),
    # -- things that work
    ("config-dump", ["config", "--planner", "rots", "--dump", "--set", "station.camera.width=64"],
     0, ""),
    ("report-valid", ["report", "{bench.json}", "--out", "{out}/r.md"], 0, ""),
    ("scene-valid", ["scene", "--scenario", "3", "--out", "{out}/s.yaml"], 0, ""),
    ("scene-from-yaml", ["scene", "--scenario", "{yaml}", "--out", "{out}/s.yaml"], 0, ""),
    ("bench-resume-past-bad-rows", ["bench", "--scenario", "3", "--planner", "gp3",
                                    "--feasibility", "geometric", "--episodes", "1",
                                    "--out", "{out}/resume.json"], 0, ""),
    *[(f"help-{command}", [command, "--help"], 0, "") for command in COMMANDS],
]


def _prepare_out(out: Path, files: dict[str, Path]) -> None:
    """The per-probe output folder with the few files some probes expect in it."""
    out.mkdir(parents=True)
    (out / "notes.txt").write_text("unrelated\n")
    (out / "rowsdir.json.rows.jsonl").mkdir()
    shutil.copy(files["bench.json"], out / "in.json")
    corrupt = out / "corrupt"
    corrupt.mkdir()
    (corrupt / "shard_raycast_0000000_0001.npz").write_bytes(b"PK\x03\x04 truncated")
    shutil.copy(files["rows"], out / "resume.json.rows.jsonl")


def _fill(part: str, values: dict[str, str]) -> str:
    for key, value in values.items():
        part = part.replace("{" + key + "}", value)
    return part


@pytest.mark.parametrize("probe", PROBES, ids=[p[0] for p in PROBES])
def test_probe(probe, files, tmp_path, capsys, monkeypatch):
    name, template, expected, needle = probe
    out = tmp_path / "out"
    _prepare_out(out, files)
    cwd = tmp_path / "cwd" / "a"
    cwd.mkdir(parents=True)
    monkeypatch.chdir(cwd)  # relative paths land in tmp_path
    values = {k: str(v) for k, v in files.items()} | {"out": str(out)}
    args = [_fill(part, values) for part in template]
    before = snapshot(tmp_path) | snapshot(files["root"])
    result = invoke(capsys, args)
    assert_clean(result, codes=(expected,))
    assert needle in result[2], result[2]
    after = snapshot(tmp_path) | snapshot(files["root"])
    assert changed_outside(before, after, [out]) == []
    if name == "bench-resume-past-bad-rows":
        document = json.loads((out / "resume.json").read_text())
        assert [r["seed"] for r in document["rows"]] == [0] and document["rows"][0]["success"]


def test_probe_table_covers_every_command():
    assert {p[1][0] for p in PROBES if p[1]} == set(COMMANDS) | {"frobnicate"}
    assert len(PROBES) >= 109
