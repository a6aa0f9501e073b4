"""The Ray backend gives the same rows as the process backend on the same seeds (2 local
workers each), and records which backend ran."""

import pytest

from tsad_drake.bench.runner import EpisodeSpec, run_bench
from tsad_drake.pipeline import EpisodeSettings

ray = pytest.importorskip("ray", reason="the ray extra is not installed (make setup installs it)")


def untimed(value):
    """`value` without wall-clock fields (any key naming a time or seconds), recursively."""
    if isinstance(value, dict):
        return {k: untimed(v) for k, v in value.items() if "time" not in k and "seconds" not in k}
    if isinstance(value, list):
        return [untimed(v) for v in value]
    return value


def test_ray_and_process_backends_give_the_same_rows(tmp_path):
    # scenario 3 seeds 0-1 generate in about a second; gp3 on the oracle is a few seconds each
    specs = [EpisodeSpec("3", s, EpisodeSettings(planner="gp3", feasibility="oracle")) for s in (0, 1)]
    results = {backend: run_bench(specs, tmp_path / f"{backend}.json", workers=2, progress=False,
                                  backend=backend)
               for backend in ("process", "ray")}
    rows = {backend: untimed(document["rows"]) for backend, document in results.items()}
    assert [r["seed"] for r in rows["ray"]] == [0, 1]
    assert rows["ray"] == rows["process"]
    assert results["ray"]["backend"] == "ray" and results["ray"]["workers"] == 2
    assert not ray.is_initialized()  # the bench shut its local Ray down

    # resumed on the other backend: every seed is already there, nothing runs twice
    again = run_bench(specs, tmp_path / "ray.json", workers=2, progress=False, backend="process")
    assert untimed(again["rows"]) == rows["ray"]
