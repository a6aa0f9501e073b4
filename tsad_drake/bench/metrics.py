"""Episode rows -> the paper's table figures (success rate, actions and falls over successes / all)."""

from __future__ import annotations

import math
import statistics

#: z of a two-sided 95% interval
Z95 = 1.959963984540054


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a success rate (95% by default); (0, 1) when n is 0."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    return low, 1.0 if successes == n else min(1.0, centre + half)


def intervals_overlap(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether two intervals share a point (then the two rates are not told apart)."""
    return a[0] <= b[1] and b[0] <= a[1]


def _mean(values: list[float]) -> float | None:
    return float(statistics.fmean(values)) if values else None


def summarise(rows: list[dict]) -> dict:
    """Summary of a bench run in the paper's format plus timing and difficulty figures."""
    succ = [r for r in rows if r["success"]]
    times = [r.get("planning_time_s", 0.0) for r in rows]
    summary = {
        "episodes": len(rows),
        "success_rate": len(succ) / len(rows) if rows else 0.0,
        "success_interval_95": list(wilson_interval(len(succ), len(rows))),
        "actions_success": _mean([r["num_actions"] for r in succ]),
        "actions_all": _mean([r["num_actions"] for r in rows]),
        "falls_success": _mean([r["falls"] for r in succ]),
        "falls_all": _mean([r["falls"] for r in rows]),
        "planning_time_median_s": float(statistics.median(times)) if times else None,
        "planning_time_mean_s": _mean(times),
        "errors": sum(str(r.get("failure_reason", "")).startswith("error:") for r in rows),
    }
    for key in ("random_actions", "initial_rearrangement_set_size", "motion_feasible_share"):
        values = [r[key] for r in rows if r.get(key) is not None]
        if values:
            summary[f"mean_{key}"] = _mean(values)
    evaluations = sum(r.get("network_evaluations", 0) for r in rows)
    if evaluations:
        seconds = sum(r.get("network_seconds", 0.0) for r in rows)
        summary["network_evaluations_mean"] = evaluations / len(rows)
        summary["network_queries_per_s"] = evaluations / seconds if seconds else None
    reasons: dict[str, int] = {}
    for r in rows:
        if not r["success"]:
            reason = str(r.get("failure_reason") or "unknown").split(":")[0]
            reasons[reason] = reasons.get(reason, 0) + 1
    summary["failure_reasons"] = reasons
    return summary


def _fmt(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def paper_table(columns: dict[str, dict]) -> str:
    """Markdown table like the paper's Table I: one column per planner (summaries as values)."""
    names = list(columns)
    lines = ["| Algorithm | " + " | ".join(names) + " |",
             "|---|" + "---|" * len(names)]

    def row(label: str, cell) -> None:
        lines.append(f"| {label} | " + " | ".join(cell(columns[n]) for n in names) + " |")

    row("Success Rate", lambda s: _fmt(s["success_rate"]))
    row("95% interval (Wilson)", lambda s: "{:.2f}-{:.2f}".format(
        *s.get("success_interval_95") or wilson_interval(
            round(s["success_rate"] * s["episodes"]), s["episodes"])))
    row("Avg. of Actions", lambda s: f"{_fmt(s['actions_success'])} / {_fmt(s['actions_all'])}")
    row("Avg. of Falls", lambda s: f"{_fmt(s['falls_success'])} / {_fmt(s['falls_all'])}")
    row("Planning time median [s]", lambda s: _fmt(s["planning_time_median_s"]))
    if any("mean_motion_feasible_share" in s for s in columns.values()):
        row("Motion-feasible share of checked actions",
            lambda s: _fmt(s.get("mean_motion_feasible_share")))
    if any("network_queries_per_s" in s for s in columns.values()):
        row("Network queries per episode", lambda s: _fmt(s.get("network_evaluations_mean"), 0))
        row("Network queries per second", lambda s: _fmt(s.get("network_queries_per_s"), 0))
    row("Episodes", lambda s: str(s["episodes"]))
    return "\n".join(lines)
