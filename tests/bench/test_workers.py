"""Bench worker lifecycle, with a real `tsad bench` in a subprocess: workers die with a killed
main process, and Ctrl-C stops the run at once, keeps the finished rows and leaves no worker."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tsad_drake.bench.runner import EpisodeSpec, spec_scenario
from tsad_drake.pipeline import EpisodeSettings
from tsad_drake.scenario import scene_digest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")

#: s; generous bounds on waiting for processes (the machine may be loaded), not timings under test
PATIENCE_S = 120.0


def _state(pid: int) -> str | None:
    """The process state letter ("R", "S", "Z", ...), None when there is no such process."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return text.rsplit(")", 1)[1].split()[0]


def _children(pid: int) -> set[int]:
    found = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.add(int(entry.name))
    return found


def _wait_for(predicate, what: str):
    deadline = time.monotonic() + PATIENCE_S
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"gave up waiting for {what}")


def _alive(pids: set[int]) -> set[int]:
    return {p for p in pids if _state(p) not in (None, "Z")}  # a zombie has finished


def _start_bench(tmp_path: Path, episodes: int) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    return subprocess.Popen(
        [sys.executable, "-m", "tsad_drake", "bench", "--scenario", "3", "--planner", "gp3",
         "--feasibility", "geometric", "--episodes", str(episodes), "--workers", "2",
         "--out", str(tmp_path / "bench.json")],
        cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_killed_bench_leaves_no_worker(tmp_path):
    bench = _start_bench(tmp_path, episodes=4)
    try:
        workers = _wait_for(lambda: len(_children(bench.pid)) >= 2 and _children(bench.pid),
                            "two worker processes")
        bench.kill()  # SIGKILL: no Python code of the main process runs
        bench.wait()
        _wait_for(lambda: not _alive(workers) or None, "the workers to die with their parent")
    finally:
        for pid in _alive(_children(bench.pid)):
            os.kill(pid, signal.SIGKILL)
        bench.communicate()


@pytest.mark.slow  # 30-70 s on a loaded 2-core machine: scenes generated in two processes
def test_ctrl_c_keeps_finished_rows_and_stops_workers(tmp_path):
    # two finished rows from before (seeds 0 and 1); the bench then runs seeds 2 and 3
    rows_path = tmp_path / "bench.json.rows.jsonl"
    rows = []
    for seed in (0, 1):
        spec = EpisodeSpec("3", seed, EpisodeSettings(planner="gp3", feasibility="geometric"))
        row = {"success": seed == 0, "num_actions": 3, "falls": 0, "planning_time_s": 0.1,
               "failure_reason": "" if seed == 0 else "planning failed", "seed": seed,
               "scene_digest": scene_digest(spec_scenario(spec)),
               **{k: getattr(spec, k) for k in EpisodeSpec.__dataclass_fields__ if k != "seed"}}
        rows.append(row)
    rows_path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    bench = _start_bench(tmp_path, episodes=4)
    try:
        workers = _wait_for(lambda: len(_children(bench.pid)) >= 2 and _children(bench.pid),
                            "two worker processes")
        bench.send_signal(signal.SIGINT)
        _, stderr = bench.communicate(timeout=PATIENCE_S)
    finally:
        if bench.poll() is None:
            bench.kill()
    assert bench.returncode == 130, stderr
    lines = [line for line in stderr.splitlines() if line.strip() and "%|" not in line]
    assert lines[-1].startswith("tsad: interrupted: 2 of 4 episodes kept in"), stderr
    assert "Traceback" not in stderr
    _wait_for(lambda: not _alive(workers) or None, "the workers to end")  # and the resource tracker
    kept = [json.loads(line) for line in rows_path.read_text().splitlines()]
    assert kept == rows  # nothing lost, nothing added half-way
    assert not (tmp_path / "bench.json").exists()  # no result that looks complete

