"""`tsad bench`: many episodes of one planner on one scenario, resumable and parallel.

A scenario is a built-in name (a scene generated per seed), one scenario YAML file (the same scene
every seed) or a folder of scene files (one episode per file, each with its own seed).

Rows stream to `<out>.rows.jsonl` as episodes finish; a rerun with the same settings skips the
episodes (scene, seed) already there, so an interrupted bench resumes where it stopped. An episode
that raises is recorded as a failure with its reason. The final `<out>` JSON (rows + summary +
machine) is written atomically once every episode is in.

Backends: `process` (a local process pool) or `ray` (Ray tasks on a local Ray or on the cluster at
RAY_ADDRESS). Either way one row per (settings, scene, seed): a resumed or split run never loses or
doubles an episode, and the same seeds give the same rows on both.

Workers: each pins its CPU threads and asks the kernel to kill it when the bench's main process
dies (Linux `PR_SET_PDEATHSIG`), so a killed bench leaves no worker behind; workers ignore SIGINT,
and the main process answers Ctrl-C by killing them at once: finished rows stay in the rows file,
the episodes that were running are run again on resume.
"""

from __future__ import annotations

import concurrent.futures as cf
import ctypes
import dataclasses as dc
import datetime as _dt
import json
import multiprocessing as mp
import os
import pickle
import platform
import signal
import sys
import time
import traceback
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from tsad_drake.bench.metrics import summarise
from tsad_drake.errors import InputFileError, RunFailure, UsageError
from tsad_drake.outputs import OutputDir, atomic_write_text, prepare_out_file
from tsad_drake.pipeline import EpisodeSettings, run_settings
from tsad_drake.plugins import load_plugin
from tsad_drake.prehensile.weights import shipped_weights, weights_digest
from tsad_drake.run_config import RunConfig, config_digest, run_config_record
from tsad_drake.runtime import THREAD_ENV_VARS, VERBOSITY_ENV, debug, pin_threads, verbosity
from tsad_drake.scenario import Scenario, load_scenario, scene_digest
from tsad_drake.scenes import BUILTIN_SCENARIOS, generate_scenario

#: keys that identify a bench run; rows from another run are never mixed in on resume
SPEC_KEYS = ("scenario", "planner", "feasibility", "ablation", "observer", "occluded",
             "closed_loop", "motion", "world", "variant", "sensor", "segmentation", "max_actions",
             "config_digest")
#: the keys every episode of one bench shares (a folder bench's episodes differ in `scenario`)
SETTINGS_KEYS = tuple(k for k in SPEC_KEYS if k != "scenario")
#: each key's value in a row written before the key was recorded
KEY_DEFAULTS = {**{f.name: f.default for f in dc.fields(EpisodeSettings)}, "occluded": False}


@dc.dataclass(frozen=True)
class EpisodeSpec:
    """One episode to run: a scenario reference, a seed and the settings."""

    scenario: str  #: built-in name, YAML path, or one scene file of a folder bench
    seed: int
    settings: EpisodeSettings = EpisodeSettings()
    #: a built-in scenario's occluded variant (the target hidden in every view)
    occluded: bool = False
    #: plugins a worker imports before the episode (`tsad --plugin`: a planner of your own)
    plugins: tuple[str, ...] = ()
    #: a folder bench's folder (resolved path), `scenario` one scene file in it; None otherwise
    scenes: str | None = None

    def identity(self) -> dict:
        """The values of `SPEC_KEYS`: what a row records of the run it belongs to."""
        values = {f.name: getattr(self.settings, f.name) for f in dc.fields(EpisodeSettings)}
        values.update(scenario=self.scenario, occluded=self.occluded,
                      config_digest=self.config_digest)
        return {k: values[k] for k in SPEC_KEYS}

    def key(self) -> tuple:
        return tuple(self.identity().values())

    @property
    def episode(self) -> tuple[str, int]:
        """(scenario, seed): what tells the episodes of one bench apart (a row per episode)."""
        return self.scenario, self.seed

    @property
    def scene_file(self) -> str | None:
        """A folder bench's scene file, relative to its folder (`a.yaml`); None otherwise."""
        if self.scenes is None:
            return None
        return str(Path(self.scenario).relative_to(self.scenes))

    def run_config(self) -> RunConfig | None:
        """The effective config; None when the names make none (the episode's row says why)."""
        try:
            return self.settings.run_config()
        except ValueError:
            return None

    @property
    def config_digest(self) -> str | None:
        """Fingerprint of the effective config (`run_config.config_digest`): rows of different
        configs are never mixed, and `tsad report` keeps them apart."""
        config = self.run_config()
        return None if config is None else config_digest(config)


def run_named_episode(spec: EpisodeSpec) -> dict:
    """Bench entry point: an `EpisodeSpec` (built-in scenario name + seed) -> JSON row."""
    scenario = spec_scenario(spec)
    row = run_settings(scenario, spec.seed, spec.settings)
    row["scene_digest"] = scene_digest(scenario)
    if spec.settings.feasibility == "net":
        row["weights_digest"] = weights_digest(shipped_weights(spec.settings.sensor))
    return row


def spec_scenario(spec: EpisodeSpec) -> Scenario:
    """The scene an `EpisodeSpec` names: generated from a built-in scenario name and the seed, or
    the scenario YAML file it names (the same scene for every seed; the seed then varies the
    planner's randomness and the sensor's noise)."""
    if spec.scenario in BUILTIN_SCENARIOS:
        return generate_scenario(spec.scenario, spec.seed, occluded=spec.occluded)
    return load_scenario(spec.scenario)


def run_spec(spec: EpisodeSpec) -> dict:
    """Run one episode; never raises (an exception becomes a failure row)."""
    t0 = time.perf_counter()
    try:
        for plugin in spec.plugins:
            load_plugin(plugin)
        row = run_named_episode(spec)
    except Exception as err:  # recorded, never fatal to the bench
        row = {"success": False, "failure_reason": f"error: {type(err).__name__}: {err}",
               "num_actions": 0, "falls": 0, "planning_time_s": 0.0,
               "traceback": traceback.format_exc(limit=6)}
    row.update(spec.identity())
    row["seed"] = spec.seed
    if spec.scenes is not None:
        row["scene_file"] = spec.scene_file
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def machine_info() -> dict:
    return {"host_cpus": os.cpu_count(), "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "python": platform.python_version(),
            "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")}


def rows_path_of(out: Path) -> Path:
    """The rows file that streams beside bench result `out`."""
    return out.with_name(out.name + ".rows.jsonl")


def is_bench_result(path: Path) -> bool:
    """Whether `path` holds a `tsad bench` result (so a rerun may replace it)."""
    try:
        document = json.loads(path.read_text(encoding="utf-8", errors="replace"))
    except (OSError, ValueError):
        return False
    return isinstance(document, dict) and {"spec", "rows", "summary"} <= set(document)


def check_bench_out(path: str | Path) -> Path:
    """Check `--out` and its rows file before any episode runs: a file path in a writable folder,
    and an existing file only replaced when it is a bench result."""
    out = prepare_out_file(path, may_replace=is_bench_result, kind="a `tsad bench` result")
    rows = rows_path_of(out)
    if rows.exists() and not rows.is_file():
        raise UsageError(f"{rows} (the rows file of --out) exists and is not a regular file")
    return out


def _valid_row(row) -> bool:
    """A row as `run_spec` writes it (anything else in the rows file is skipped and run again)."""
    return (isinstance(row, dict) and isinstance(row.get("seed"), int)
            and isinstance(row.get("scenario"), str)
            and isinstance(row.get("success"), bool) and isinstance(row.get("num_actions"), int)
            and isinstance(row.get("falls"), int)
            and isinstance(row.get("planning_time_s"), (int, float)))


def _load_rows(path: Path, specs: list[EpisodeSpec]) -> dict[tuple[str, int], dict]:
    """Rows of `path` that belong to this run, by episode ((scenario, seed), `EpisodeSpec.episode`):
    the settings of `specs[0]`, one of the episodes of `specs` and the same scene (the row's
    recorded scene digest; a row from before a generator change, from before rows recorded the
    digest, or of a scene file changed since, is run again); a network row must record the
    shipped weights' digest (a row of other weights, or from before rows recorded it, is run
    again); a row without a config digest (from before configs were recorded) counts as the
    defaults of its settings, so it serves a run with the default config and no other. Lines that
    are not rows (cut off by an interruption, `null`, edited by hand) are skipped: those episodes
    run again."""
    if not path.exists():
        return {}
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as err:
        raise InputFileError(f"cannot read bench rows {path}: {err.strerror}") from None
    by_episode = {s.episode: s for s in specs}
    identity = specs[0].identity()
    wanted = tuple(identity[k] for k in SETTINGS_KEYS)
    defaults = dict(KEY_DEFAULTS)  # keys added since a row was written
    # a row from before rows recorded their config ran with the defaults of its selectors
    defaults["config_digest"] = dc.replace(
        specs[0], settings=dc.replace(specs[0].settings, config=None)).config_digest
    done, current = {}, ""  # current: the shipped weights' digest, read when a row has one
    for line in text.splitlines():
        try:
            row = json.loads(line)
        except ValueError:
            continue  # a line cut off by an interruption
        if not _valid_row(row):
            continue
        episode = (row.get("scenario"), row["seed"])
        if (tuple(row.get(k, defaults.get(k)) for k in SETTINGS_KEYS) != wanted
                or episode not in by_episode):
            continue
        digest, weights = row.get("scene_digest"), row.get("weights_digest")
        if weights is not None or row.get("feasibility") == "net":
            current = current or weights_digest(shipped_weights(specs[0].settings.sensor))
            if weights != current:
                continue
        if digest is not None and digest == scene_digest(spec_scenario(by_episode[episode])):
            done[episode] = row
    return done


#: Linux prctl option: the signal a process gets when the thread that started it exits
PR_SET_PDEATHSIG = 1


def _init_worker(threads: int = 1, parent_pid: int | None = None,
                 plugins: tuple[str, ...] = ()) -> None:
    """Worker start: pinned threads, the run's plugins imported (their config types travel in
    the specs), dies with the bench's main process, leaves SIGINT to it."""
    os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")
    pin_threads(threads)
    for plugin in plugins:
        load_plugin(plugin)
    if parent_pid is None:
        return
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C: the main process stops the workers
    if sys.platform.startswith("linux"):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if os.getppid() != parent_pid:  # the main process died before the line above
        os._exit(1)


def _kill_workers(pool: cf.ProcessPoolExecutor) -> None:
    """Kill the pool's workers now and drop the queued episodes (no public handle before 3.14)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        process.kill()
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.join(timeout=10)


def _run_pool(todo: list[EpisodeSpec], workers: int, threads: int, record) -> None:
    ctx = mp.get_context("spawn")
    plugins = todo[0].plugins if todo else ()
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                                  initargs=(threads, os.getpid(), plugins))
    try:
        futures = [pool.submit(run_spec, s) for s in todo]
        for fut in cf.as_completed(futures):
            record(fut.result())
    except BaseException:
        _kill_workers(pool)
        raise
    pool.shutdown()


def _ray_episode(spec: bytes, plugins: tuple[str, ...], threads: int) -> dict:
    """A Ray task: one episode in a Ray worker process with pinned threads (only the pickled spec
    and the JSON row cross processes; every Drake object is built and dropped inside the task).
    The spec is unpickled after the plugins are imported: their config types are in it."""
    _init_worker(threads, plugins=plugins)
    return run_spec(pickle.loads(spec))


def _run_ray(todo: list[EpisodeSpec], workers: int, threads: int, record) -> None:
    """Episodes as Ray tasks, at most `workers` at a time on a local Ray, one CPU each; with
    RAY_ADDRESS set, on that cluster (workers then caps only the tasks in flight)."""
    import ray

    env = {name: str(threads) for name in THREAD_ENV_VARS}
    env.update({VERBOSITY_ENV: str(verbosity()), "MESA_SHADER_CACHE_DISABLE": "true"})
    address = os.environ.get("RAY_ADDRESS") or None
    # a local Ray starts its workers at niceness 15 (Ray's `worker_niceness`): on a loaded machine
    # they then wait behind everything else (10x slower episodes beside a test run); 0 is what the
    # process backend's workers get
    local = {} if address else {"num_cpus": workers, "include_dashboard": False,
                                "_system_config": {"worker_niceness": 0}}
    ray.init(address=address, runtime_env={"env_vars": env}, log_to_driver=False,
             configure_logging=False, **local)
    episode = ray.remote(num_cpus=1, max_retries=0)(_ray_episode)
    queue, running = list(todo), []
    try:
        while queue or running:
            while queue and len(running) < workers:
                spec = queue.pop(0)
                running.append(episode.remote(pickle.dumps(spec), spec.plugins, threads))
            finished, running = ray.wait(running, num_returns=1)
            try:
                record(ray.get(finished[0]))
            except ray.exceptions.RayError as err:  # the worker died (killed, out of memory)
                raise RunFailure(f"a Ray worker failed: {type(err).__name__}") from None
    finally:
        for ref in running:
            ray.cancel(ref, force=True)
        ray.shutdown()


def run_bench(specs: list[EpisodeSpec], out: Path, workers: int = 1,
              progress: bool = True, threads: int = 1, backend: str = "process") -> dict:
    """Run `specs` (same settings, different seeds; a folder bench's also different scene files),
    streaming rows; return the result document (a folder bench's names the folder as its
    scenario and lists its scene files as `scenes`).

    Raises:
        KeyboardInterrupt: on Ctrl-C, once the workers are gone; its message says how many
            episodes are kept in the rows file.
        RunFailure: a worker process died (killed, out of memory); finished rows are kept.
    """
    from tqdm import tqdm

    out = Path(out)
    folder = OutputDir(out.parent)
    rows_path = rows_path_of(out)
    done = _load_rows(rows_path, specs)
    if rows_path.exists() and rows_path.stat().st_size:
        with rows_path.open("rb+") as f:  # end a line cut off by an interruption before appending
            f.seek(-1, os.SEEK_END)
            if f.read(1) != b"\n":
                f.write(b"\n")
    todo = [s for s in specs if s.episode not in done]
    scenes = specs[0].scenes
    where = f"s{specs[0].scenario}" if scenes is None else f"{Path(scenes).name}/"
    bar = tqdm(total=len(specs), initial=len(specs) - len(todo), disable=not progress,
               desc=f"{specs[0].settings.planner} {where}", unit="ep")

    def record(row: dict) -> None:
        done[(row["scenario"], row["seed"])] = row
        folder.append_line(rows_path.name, json.dumps(row))
        ok = sum(r["success"] for r in done.values())
        bar.set_postfix(success=f"{ok}/{len(done)}")
        bar.update(1)
        scene = f" ({row['scene_file']})" if "scene_file" in row else ""
        debug(f"seed {row['seed']}{scene}: "
              f"{'success' if row['success'] else row['failure_reason']}, "
              f"{row['num_actions']} actions, {row['falls']} falls, "
              f"{row.get('wall_time_s', 0.0):.1f} s")

    kept = f"of {len(specs)} episodes kept in {rows_path}; run the same command again to resume"
    try:
        if backend == "ray":
            _run_ray(todo, workers, threads, record)
        elif workers <= 1:
            _init_worker(threads)
            for spec in todo:
                record(run_spec(spec))
        else:
            _run_pool(todo, workers, threads, record)
    except KeyboardInterrupt:
        raise KeyboardInterrupt(f"{len(done)} {kept}") from None
    except BrokenProcessPool:
        raise RunFailure(f"a bench worker process died (killed or out of memory); "
                         f"{len(done)} {kept}") from None
    finally:
        bar.close()
    rows = [done[s.episode] for s in specs]
    config = specs[0].run_config()
    spec = specs[0].identity()
    if scenes is not None:  # a folder bench: `tsad report` groups its rows under the folder
        spec["scenario"] = scenes
    document = {"spec": spec,
                "config": None if config is None else run_config_record(config),
                "seeds": [s.seed for s in specs], "machine": machine_info(), "threads": threads,
                "backend": backend, "workers": workers,
                "summary": summarise(rows), "rows": rows}
    if scenes is not None:
        document["scenes"] = [s.scene_file for s in specs]
    atomic_write_text(out, json.dumps(document, indent=1))
    return document
