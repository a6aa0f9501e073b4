"""`tsad bench`: many episodes of one planner on one scenario, resumable and parallel.

Rows stream to `<out>.rows.jsonl` as episodes finish; a rerun with the same settings skips the
seeds already there, so an interrupted bench resumes where it stopped. An episode that raises is
recorded as a failure with its reason. The final `<out>` JSON (rows + summary + machine) is
written atomically once every episode is in.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses as dc
import datetime as _dt
import json
import multiprocessing as mp
import os
import platform
import time
import traceback
from pathlib import Path

from tsad_drake.bench.metrics import summarise
from tsad_drake.pipeline import EpisodeSettings, run_settings
from tsad_drake.prehensile.checkpoint import weights_digest
from tsad_drake.scenario import Scenario, scene_digest
from tsad_drake.scenes import generate_scenario

#: keys that identify a bench run; rows from another run are never mixed in on resume
SPEC_KEYS = ("scenario", "planner", "feasibility", "ablation", "observer", "occluded",
             "closed_loop", "motion", "world")


@dc.dataclass(frozen=True)
class EpisodeSpec:
    """One episode to run."""

    scenario: str  #: built-in name or YAML path
    seed: int
    planner: str
    feasibility: str
    ablation: str = "none"  #: none | no-ro | no-re (TSAD reward ablations)
    observer: str = "raycast"  #: raycast (NumPy) | drake (VTK station renders)
    occluded: bool = False
    closed_loop: bool = True
    motion: bool = False  #: verify each action at the motion level before executing it
    world: str = "geometric"  #: geometric | physics (Drake contact simulation of every action)

    def key(self) -> tuple:
        return tuple(getattr(self, k) for k in SPEC_KEYS)


def run_named_episode(spec: EpisodeSpec) -> dict:
    """Bench entry point: an `EpisodeSpec` (built-in scenario name + seed) -> JSON row."""
    scenario = spec_scenario(spec)
    settings = EpisodeSettings(planner=spec.planner, feasibility=spec.feasibility,
                               ablation=spec.ablation, observer=spec.observer,
                               closed_loop=spec.closed_loop, motion=spec.motion,
                               world=spec.world)
    row = run_settings(scenario, spec.seed, settings)
    row["scene_digest"] = scene_digest(scenario)
    if spec.feasibility == "net":
        row["weights_digest"] = weights_digest()
    return row


def spec_scenario(spec: EpisodeSpec) -> Scenario:
    """The scene an `EpisodeSpec` names (generated from its scenario name and seed)."""
    return generate_scenario(spec.scenario, spec.seed, occluded=spec.occluded)


def run_spec(spec: EpisodeSpec) -> dict:
    """Run one episode; never raises (an exception becomes a failure row)."""
    t0 = time.perf_counter()
    try:
        row = run_named_episode(spec)
    except Exception as err:  # recorded, never fatal to the bench
        row = {"success": False, "failure_reason": f"error: {type(err).__name__}: {err}",
               "num_actions": 0, "falls": 0, "planning_time_s": 0.0,
               "traceback": traceback.format_exc(limit=6)}
    row.update({k: getattr(spec, k) for k in SPEC_KEYS})
    row["seed"] = spec.seed
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def machine_info() -> dict:
    return {"host_cpus": os.cpu_count(), "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "python": platform.python_version(),
            "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")}


def _load_rows(path: Path, specs: list[EpisodeSpec]) -> dict[int, dict]:
    """Rows of `path` that belong to this run: same settings and the same scene (the row's recorded
    scene digest; a row from before a generator change, or from before rows recorded the digest,
    is run again); a network row must record the shipped weights' digest (a row of other weights,
    or from before rows recorded it, is run again)."""
    if not path.exists():
        return {}

    by_seed = {s.seed: s for s in specs}
    wanted = specs[0].key()
    defaults = {f.name: f.default for f in dc.fields(EpisodeSpec)}  # keys added since a row
    done, current = {}, ""  # current: the shipped weights' digest, read when a row has one
    for line in path.read_text().splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue  # a line cut off by an interruption
        if (tuple(row.get(k, defaults.get(k)) for k in SPEC_KEYS) != wanted
                or row.get("seed") not in by_seed):
            continue
        digest, weights = row.get("scene_digest"), row.get("weights_digest")
        if weights is not None or row.get("feasibility") == "net":
            current = current or weights_digest()
            if weights != current:
                continue
        if digest is not None and digest == scene_digest(spec_scenario(by_seed[row["seed"]])):
            done[row["seed"]] = row
    return done


def _init_worker() -> None:
    os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:
        pass


def run_bench(specs: list[EpisodeSpec], out: Path, workers: int = 1,
              progress: bool = True) -> dict:
    """Run `specs` (same settings, different seeds), streaming rows; return the result document."""
    from tqdm import tqdm

    rows_path = out.with_name(out.name + ".rows.jsonl")
    done = _load_rows(rows_path, specs)
    if rows_path.exists() and rows_path.stat().st_size:
        with rows_path.open("rb+") as f:  # end a line cut off by an interruption before appending
            f.seek(-1, os.SEEK_END)
            if f.read(1) != b"\n":
                f.write(b"\n")
    todo = [s for s in specs if s.seed not in done]
    bar = tqdm(total=len(specs), initial=len(specs) - len(todo), disable=not progress,
               desc=f"{specs[0].planner} s{specs[0].scenario}", unit="ep")

    def record(row: dict) -> None:
        done[row["seed"]] = row
        with rows_path.open("a") as f:
            f.write(json.dumps(row) + "\n")
        ok = sum(r["success"] for r in done.values())
        bar.set_postfix(success=f"{ok}/{len(done)}")
        bar.update(1)

    if workers <= 1:
        _init_worker()
        for spec in todo:
            record(run_spec(spec))
    else:
        ctx = mp.get_context("spawn")
        with cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx,
                                    initializer=_init_worker) as pool:
            futures = [pool.submit(run_spec, s) for s in todo]
            for fut in cf.as_completed(futures):
                record(fut.result())
    bar.close()
    rows = [done[s.seed] for s in specs]
    document = {"spec": {k: getattr(specs[0], k) for k in SPEC_KEYS},
                "seeds": [s.seed for s in specs], "machine": machine_info(),
                "summary": summarise(rows), "rows": rows}
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(json.dumps(document, indent=1))
    tmp.replace(out)
    return document
