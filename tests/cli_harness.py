"""Test helpers: the command line run in-process (exit status, stdout, stderr) and what it wrote
where. Imported by the tests beside it."""

import os
from pathlib import Path

from tsad_drake.cli import main


def invoke(capsys, args: list[str]) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of `tsad ARGS`, run in this process."""
    try:
        code = main([str(a) for a in args])
    except SystemExit as exit_:
        code = exit_.code
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_clean(result: tuple[int, str, str], codes=(0, 1, 2)) -> None:
    """Exit status in `codes`, never a traceback; bad input (2) is exactly one line on stderr."""
    code, out, err = result
    assert code in codes, (code, out[-2000:], err[-2000:])
    assert "Traceback" not in err and "Traceback" not in out, err
    if code == 2:
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("tsad: error: "), err


def snapshot(root: Path) -> dict[Path, tuple[int, int]]:
    """Every file under `root` with its size and modification time."""
    found = {}
    for folder, _, names in os.walk(root):
        for name in names:
            path = Path(folder, name)
            try:
                stat = path.lstat()
            except OSError:
                continue
            found[path] = (stat.st_size, stat.st_mtime_ns)
    return found


def changed_outside(before: dict, after: dict, allowed: list[Path]) -> list[Path]:
    """Files created or modified between two snapshots that lie outside every `allowed` path."""
    changed = [p for p, v in after.items() if before.get(p) != v]
    return [p for p in changed
            if not any(p == a or a in p.parents for a in allowed)]



def bench_document(seeds: int = 3) -> dict:
    """A small `tsad bench` result (seed 1 failed) as `tsad report` reads it."""
    from tsad_drake.bench.metrics import summarise

    rows = [{"seed": s, "success": s != 1, "num_actions": 3, "falls": 0, "planning_time_s": 1.0,
             "failure_reason": "" if s != 1 else "planning failed: sub-search 0"}
            for s in range(seeds)]
    return {"spec": {"scenario": "3", "planner": "gp3", "feasibility": "geometric"},
            "rows": rows, "summary": summarise(rows), "machine": {"platform": "test"}}
