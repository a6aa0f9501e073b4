"""Episode rows -> the paper's table figures (success rate, actions and falls over successes / all)."""

from __future__ import annotations

import math
import statistics

from tsad_drake.motion.causes import cause_label, failure_cause

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
        "planning_time_max_s": max(times) if times else None,
        #: episodes a planner call of which reached its wall-clock safety stop (failures)
        "timed_out": sum(bool(r.get("timed_out")) for r in rows),
        "errors": sum(str(r.get("failure_reason", "")).startswith("error:") for r in rows),
    }
    for key in ("random_actions", "initial_rearrangement_set_size", "motion_feasible_share"):
        values = [r[key] for r in rows if r.get(key) is not None]
        if values:
            summary[f"mean_{key}"] = _mean(values)
    iterations = [r["search_iterations"] for r in rows if "search_iterations" in r]
    if iterations:
        summary["search_iterations_mean"] = _mean(iterations)
        summary["planning_time_per_iteration_s"] = (sum(times) / sum(iterations)
                                                    if sum(iterations) else None)
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
    causes: dict[str, int] = {}
    for r in rows:
        for check in r.get("motion_checks", []):
            if not check["verified"]:
                label = cause_label(check.get("cause") or failure_cause(check["failure"]))
                causes[label] = causes.get(label, 0) + 1
    if causes:
        summary["motion_rejections"] = dict(sorted(causes.items(), key=lambda kv: -kv[1]))
    summary.update(_physics_summary(rows))
    return summary


def _physics_summary(rows: list[dict]) -> dict:
    figures = [r["physics"] for r in rows if isinstance(r.get("physics"), dict)]
    if not figures:
        return {}

    def weighted(key: str, weight: str) -> float | None:
        pairs = [(f[key], f[weight]) for f in figures if f[key] is not None and f[weight]]
        total = sum(w for _, w in pairs)
        return sum(v * w for v, w in pairs) / total if total else None

    sim = sum((f["sim_seconds_per_action"] or 0.0) * f["simulated"] for f in figures)
    wall = sum((f["sim_seconds_per_action"] or 0.0) * f["simulated"] / f["real_time_factor"]
               for f in figures if f["real_time_factor"])
    return {"physics_disturbed_all": _mean([f["disturbed"] for f in figures]),
            "physics_moved_share": (sum(f["moved"] for f in figures)
                                    / max(sum(f["actions"] for f in figures), 1)),
            "physics_placement_error_mm": weighted("placement_error_mm", "moved"),
            "physics_slip_mm": weighted("slip_mm", "simulated"),
            "physics_sim_seconds_per_action": weighted("sim_seconds_per_action", "simulated"),
            "physics_real_time_factor": sim / wall if wall else None}


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
        row("Motion rejections by cause", lambda s: ", ".join(
            f"{n} {label}" for label, n in (s.get("motion_rejections") or {}).items()) or "none")
    if any("network_queries_per_s" in s for s in columns.values()):
        row("Network queries per episode", lambda s: _fmt(s.get("network_evaluations_mean"), 0))
        row("Network queries per second", lambda s: _fmt(s.get("network_queries_per_s"), 0))
    if any("physics_moved_share" in s for s in columns.values()):
        row("Physics: disturbed objects per episode",
            lambda s: _fmt(s.get("physics_disturbed_all")))
        row("Physics: share of actions that moved their object",
            lambda s: _fmt(s.get("physics_moved_share")))
        row("Physics: placement error [mm]", lambda s: _fmt(s.get("physics_placement_error_mm"), 1))
        row("Physics: grasp slip [mm]", lambda s: _fmt(s.get("physics_slip_mm"), 1))
        row("Physics: sim seconds per action",
            lambda s: _fmt(s.get("physics_sim_seconds_per_action")))
        row("Physics: real-time factor", lambda s: _fmt(s.get("physics_real_time_factor")))
    row("Episodes", lambda s: str(s["episodes"]))
    return "\n".join(lines)
