"""Bench results -> a markdown page with the paper's tables, a JSON digest and a plot."""

from __future__ import annotations

import json
import math
from pathlib import Path

from tsad_drake.bench.metrics import intervals_overlap, paper_table, summarise, wilson_interval
from tsad_drake.errors import InputFileError
from tsad_drake.outputs import atomic_write, atomic_write_text

#: the paper's Table I (success rate; actions success/all; falls success/all)
PAPER_TABLE_I = {
    "1": {"tsad": (0.97, 3.72, 3.67, 0.17, 0.23), "gp3": (0.33, 2.90, 3.07, 0.10, 0.13),
          "rots": (0.87, 3.96, 4.07, 0.31, 0.30), "rots-star": (0.87, 4.12, 4.33, 0.19, 0.33)},
    "2": {"tsad": (0.93, 3.96, 4.23, 0.21, 0.27), "gp3": (0.17, 3.20, 3.47, 0.20, 0.27),
          "rots": (0.63, 4.42, 4.70, 0.74, 0.90), "rots-star": (0.70, 4.95, 5.10, 0.24, 0.23)},
    "3": {"tsad": (0.93, 4.71, 5.00, 0.29, 0.33), "gp3": (0.20, 3.17, 3.83, 0.17, 0.23),
          "rots": (0.67, 5.40, 5.73, 0.80, 1.10), "rots-star": (0.70, 5.81, 6.07, 0.33, 0.37)},
}
#: the paper's Table II (scenario 1, TSAD and its reward ablations), Table III (occluded targets,
#: TSAD, by scenario) and Table IV (the real robot: 5 objects in a 0.40 x 0.28 m shelf, 15
#: episodes); same fields as Table I
PAPER_TABLE_II = {"none": (0.97, 3.72, 3.67, 0.17, 0.23), "no-ro": (0.93, 4.04, 4.07, 0.21, 0.27),
                  "no-re": (0.90, 4.30, 4.33, 0.22, 0.23)}
PAPER_TABLE_III = {"1": (0.93, 4.21, 4.13, 0.14, 0.27), "2": (0.93, 4.43, 4.47, 0.21, 0.27)}
PAPER_TABLE_IV = {"tsad": (0.87, 3.69, 3.47, 0.31, 0.40), "gp3": (0.13, 3.00, 1.93, 0.00, 0.13),
                  "rots-star": (0.60, 4.22, 3.93, 0.33, 0.33)}
PLANNER_ORDER = ("tsad", "gp3", "rots", "rots-star", "rots-star-search", "optimal")
#: the issues' targets: TSAD (geometric) success per scenario (the paper's), its median planning
#: time, its action excess over `optimal`; TSAD on the network against TSAD on the oracle
TARGET_SUCCESS = {"1": 0.97, "2": 0.93, "3": 0.93}
TARGET_MEDIAN_S = 5.0
TARGET_OVER_OPTIMAL = 0.20
TARGET_NET_GAP = 0.03
TARGET_NET_MEDIAN_S = 10.0


#: a bench row's fields the report reads, and their types
ROW_FIELDS = {"seed": int, "success": bool, "num_actions": int, "falls": int}
#: summary fields the report reads: required ones are numbers, the rest numbers or null
SUMMARY_NUMBERS = ("success_rate",)
SUMMARY_OPTIONAL_NUMBERS = ("actions_success", "actions_all", "falls_success", "falls_all",
                            "planning_time_median_s", "mean_initial_rearrangement_set_size",
                            "mean_motion_feasible_share", "network_evaluations_mean",
                            "network_queries_per_s")


def _is_number(value) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def _bench_problem(document) -> str:
    """What makes `document` not a `tsad bench` result the report can read ("" when it is one)."""
    if not isinstance(document, dict):
        return "the JSON is not an object"
    spec, summary, rows = document.get("spec"), document.get("summary"), document.get("rows")
    if not isinstance(spec, dict) or not isinstance(spec.get("planner"), str) or not isinstance(
            spec.get("scenario"), (str, int)) or isinstance(spec.get("scenario"), bool):
        return "spec must name a planner and a scenario"
    if not isinstance(rows, list) or not rows:
        return "rows must be a non-empty list"
    for k, row in enumerate(rows):
        if not isinstance(row, dict):
            return f"rows[{k}] is not an object"
        for field, kind in ROW_FIELDS.items():
            value = row.get(field)
            if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
                return f"rows[{k}].{field} must be of type {kind.__name__}"
        if not row["success"] and not isinstance(row.get("failure_reason"), str):
            return f"rows[{k}].failure_reason must be a string"
    if not isinstance(summary, dict):
        return "summary must be an object"
    for field in SUMMARY_NUMBERS:
        if not _is_number(summary.get(field)):
            return f"summary.{field} must be a finite number"
    for field in SUMMARY_OPTIONAL_NUMBERS:
        if summary.get(field) is not None and not _is_number(summary[field]):
            return f"summary.{field} must be a finite number or null"
    if not isinstance(summary.get("episodes"), int) or summary["planning_time_median_s"] is None:
        return "summary.episodes and summary.planning_time_median_s are missing"
    reasons = summary.get("failure_reasons")
    if not isinstance(reasons, dict) or not all(isinstance(v, int) for v in reasons.values()):
        return "summary.failure_reasons must map reasons to counts"
    if not isinstance(document.get("machine", {}), dict):
        return "machine must be an object"
    return ""


def _read_json(path: str | Path, what: str):
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        why = err.strerror if isinstance(err, OSError) and err.strerror else str(err).splitlines()[0]
        raise InputFileError(f"cannot read {what} {path}: {why}") from None


def load_report_input(path: str | Path) -> tuple[str, dict]:
    """("bench", document) for a `tsad bench` result, ("agreement", document) for the physics
    agreement study's output (`studies/physics_agreement.py`), ("footprints", document) for
    the footprint error study's (`studies/hull_errors.py --json`); InputFileError
    otherwise."""
    from tsad_drake.bench.study_pages import is_agreement_document, is_footprint_document

    document = _read_json(path, "report input")
    if is_agreement_document(document):
        return "agreement", document
    if is_footprint_document(document):
        return "footprints", document
    problem = _bench_problem(document)
    if problem:
        raise InputFileError(f"{path} is neither a `tsad bench` result ({problem}) nor a physics "
                             "agreement or footprint error study")
    return "bench", document


def report_outputs(out: Path) -> tuple[Path, Path, Path]:
    """The files `write_report(documents, out)` writes: the page, its JSON digest and its plot."""
    out = Path(out)
    return out, out.with_suffix(".json"), out.with_suffix(".png")


def _label(spec: dict, config: dict | None = None) -> str:
    """A column's name: the planner and every setting that differs from the paper's tables
    (`config`: the document's run config, for the depth frames a realistic sensor fused)."""
    if spec.get("label"):  # named by whoever made the document (`tsad sweep`: the grid point)
        return spec["label"]
    label = spec["planner"]
    if spec.get("variant", "full") != "full":
        label += f"-{spec['variant']}"
    if spec.get("sensor", "ideal") != "ideal":
        label += f" {spec['sensor']} sensor"
        sensor = (config or {}).get("sensor")
        if sensor:  # configs from before `frames` was a setting took one frame
            frames = sensor.get("frames", 1)
            label += f" x{frames} frame{'s' if frames > 1 else ''}"
    if spec.get("segmentation", "label") != "label":
        label += f" {spec['segmentation']}"
    if spec.get("ablation", "none") != "none":
        label += f" ({spec['ablation']})"
    if spec.get("feasibility") not in (None, "geometric"):
        label += f" [{spec['feasibility']}]"
    if spec.get("occluded"):
        label += " occluded"
    if spec.get("motion"):
        label += " +motion"
    if spec.get("world", "geometric") != "geometric":
        label += f" {spec['world']} world"
    if spec.get("observer", "raycast") != "raycast":
        label += f" {spec['observer']} observer"
    if spec.get("closed_loop") is False:
        label += " open loop"
    return label


def _planner_of(label: str) -> str:
    """The planner a column label names (its first word, without the variant suffix)."""
    return label.split(" ")[0].removesuffix("-paper")


def _order(label: str) -> tuple:
    base = _planner_of(label)
    return (PLANNER_ORDER.index(base) if base in PLANNER_ORDER else 99, label)


#: row fields that make two rows of the same (settings, seed) the same episode's result
RESULT_FIELDS = ("success", "num_actions", "falls", "failure_reason")


def _spec_key(spec: dict) -> str:
    return json.dumps(spec, sort_keys=True)


def merge_documents(documents: list[tuple[str, dict]]) -> list[dict]:
    """Bench results of the same settings (a run split by seed ranges, or run twice) merged into
    one document per settings: rows by seed, summary recomputed. The same seed with a different
    result in two files is a conflict (InputFileError naming both files)."""
    merged: dict[str, dict] = {}
    sources: dict[str, dict[int, str]] = {}
    for name, doc in documents:
        key = _spec_key(doc["spec"])
        target = merged.setdefault(key, {**doc, "rows": [], "sources": []})
        target["sources"].append(name)
        seen = sources.setdefault(key, {})
        by_seed = {r["seed"]: r for r in target["rows"]}
        for row in doc["rows"]:
            old = by_seed.get(row["seed"])
            if old is None:
                target["rows"].append(row)
                by_seed[row["seed"]] = row
                seen[row["seed"]] = name
            elif any(old.get(f) != row.get(f) for f in RESULT_FIELDS):
                raise InputFileError(
                    f"{seen[row['seed']]} and {name} disagree on seed {row['seed']} of "
                    f"{_label(doc['spec'], doc.get('config'))} scenario {doc['spec']['scenario']} "
                    f"(success {old['success']} vs {row['success']}, actions "
                    f"{old['num_actions']} vs {row['num_actions']}): not the same run")
    for doc in merged.values():
        doc["rows"].sort(key=lambda r: r["seed"])
        doc["seeds"] = [r["seed"] for r in doc["rows"]]
        if len(doc["sources"]) > 1:
            doc["summary"] = summarise(doc["rows"])
    return list(merged.values())


def group_by_scenario(documents: list[dict]) -> dict[str, dict[str, dict]]:
    """{scenario: {label: document}}; documents of different settings never share a label: a
    config that differs (`spec.config_digest`: `--config`/`--set`) adds its digest to the label,
    any other difference a number."""
    groups: dict[str, dict[str, dict]] = {}
    for doc in documents:
        column = groups.setdefault(str(doc["spec"]["scenario"]), {})
        label, digest = _label(doc["spec"], doc.get("config")), doc["spec"].get("config_digest")
        if label in column and digest and column[label]["spec"].get("config_digest") != digest:
            label += f" config {digest}"
        if label in column:
            label += f" #{sum(k == label or k.startswith(label + ' #') for k in column) + 1}"
        column[label] = doc
    return {k: dict(sorted(v.items(), key=lambda kv: _order(kv[0])))
            for k, v in sorted(groups.items())}


def _difficulty_lines(columns: dict[str, dict]) -> list[str]:
    lines = []
    for label, doc in columns.items():
        s = doc["summary"]
        if "mean_initial_rearrangement_set_size" in s and label.startswith("tsad"):
            lines.append(f"- mean |R_theta*| at the start ({label}): "
                         f"{s['mean_initial_rearrangement_set_size']:.2f}")
        if label.startswith("optimal"):
            finished = [r for r in doc["rows"] if r.get("optimal_finished")]
            if finished:
                mean = sum(r["num_actions"] for r in finished) / len(finished)
                lines.append(f"- optimal finished on {len(finished)}/{len(doc['rows'])} scenes; "
                             f"mean optimal number of actions there: {mean:.2f}")
    return lines + _optimality_lines(columns) + _network_lines(columns)


def _network_lines(columns: dict[str, dict]) -> list[str]:
    """TSAD on the prehensile network against TSAD on the oracle model (the issue's target)."""
    net, oracle = columns.get("tsad [net]"), columns.get("tsad [oracle]")
    if net is None or oracle is None:
        return []
    a, b = net["summary"], oracle["summary"]
    return [f"- tsad [net] vs tsad [oracle]: success {a['success_rate']:.2f} vs "
            f"{b['success_rate']:.2f} ({a['success_rate'] - b['success_rate']:+.2f}), median "
            f"planning {a['planning_time_median_s']:.1f} vs {b['planning_time_median_s']:.1f} s, "
            f"{a.get('network_queries_per_s') or 0:.0f} network queries/s"]


def _optimality_lines(columns: dict[str, dict]) -> list[str]:
    """Each planner's actions against `optimal` on the scenes where both succeeded."""
    reference = [label for label, doc in columns.items() if doc["spec"]["planner"] == "optimal"]
    if not reference:
        return []
    rows = columns[reference[0]]["rows"]
    floor = {r["seed"]: r["num_actions"] for r in rows
             if r.get("optimal_finished") and r.get("success")}
    solved = {r["seed"] for r in rows if r.get("success")}
    lines = []
    for label, doc in columns.items():
        if label in reference or doc["spec"].get("occluded"):
            continue
        on_solved = [r["success"] for r in doc["rows"] if r["seed"] in solved]
        if on_solved:
            lines.append(f"- {label} success on the {len(on_solved)} scenes `optimal` solved "
                         f"(known solvable): {sum(on_solved) / len(on_solved):.2f}")
        pairs = [(r["num_actions"], floor[r["seed"]]) for r in doc["rows"]
                 if r.get("success") and r["seed"] in floor]
        if pairs:
            mine, best = (sum(p[i] for p in pairs) / len(pairs) for i in (0, 1))
            lines.append(f"- {label} vs optimal on the {len(pairs)} scenes both solved: "
                         f"{mine:.2f} vs {best:.2f} actions ({100 * (mine / best - 1):+.0f}%)")
    return lines


def paper_counterpart(scenario: str, spec: dict) -> tuple[str, tuple] | None:
    """The paper's row for a bench run's settings ("Table I", figures), None when it has none:
    Table I for a planner with the default settings, II for TSAD's reward ablations on scenario 1,
    III for TSAD on occluded targets, IV for the `real` shelf."""
    if spec.get("world", "geometric") != "geometric" or spec.get("closed_loop") is False or (
            spec.get("sensor", "ideal") != "ideal" or spec.get("motion")):
        return None
    planner, ablation = spec["planner"], spec.get("ablation", "none")
    if scenario == "real":
        row = PAPER_TABLE_IV.get(planner)
        return None if row is None or ablation != "none" else ("Table IV", row)
    if spec.get("occluded"):
        row = PAPER_TABLE_III.get(scenario) if planner == "tsad" and ablation == "none" else None
        return None if row is None else ("Table III", row)
    if ablation != "none":
        return ("Table II", PAPER_TABLE_II[ablation]) if scenario == "1" else None
    row = PAPER_TABLE_I.get(scenario, {}).get(planner)
    return None if row is None else ("Table I", row)


def _paper_lines(scenario: str, columns: dict[str, dict]) -> list[str]:
    """Each column with a counterpart in the paper: our success with its 95% interval, and
    whether the paper's figure lies inside it (then 30 episodes cannot tell the two apart)."""
    lines = []
    for label, doc in columns.items():
        found = paper_counterpart(scenario, doc["spec"])
        if found is None:
            continue
        table, row = found
        s = doc["summary"]
        low, high = _interval(s)
        inside = low <= row[0] <= high
        lines.append(f"- {label}: success {s['success_rate']:.2f} (95% {low:.2f}-{high:.2f}, "
                     f"{s['episodes']} episodes); the paper's {row[0]:.2f} ({table}) lies "
                     + ("inside: not told apart" if inside else
                        f"outside: {'above' if row[0] > high else 'below'} ours"))
    return ["Against the paper:", "", *lines, ""] + _overlap_lines(scenario, columns) if lines else []


def _overlap_lines(scenario: str, columns: dict[str, dict]) -> list[str]:
    """Pairs of the paper's planners (Table I settings, geometric model) whose 95% success
    intervals overlap: rates these episodes cannot order."""
    labels = [label for label, doc in columns.items()
              if doc["spec"].get("feasibility") in (None, "geometric")
              and (paper_counterpart(scenario, doc["spec"]) or ("",))[0] in ("Table I", "Table IV")]
    pairs = [f"{a} / {b}" for i, a in enumerate(labels) for b in labels[i + 1:]
             if intervals_overlap(_interval(columns[a]["summary"]), _interval(columns[b]["summary"]))]
    if len(labels) < 2:
        return []
    if not pairs:
        return [f"The success intervals of {', '.join(labels)} are pairwise disjoint.", ""]
    return [f"Success intervals that overlap (not told apart by these episodes): "
            f"{'; '.join(pairs)}.", ""]


def _verdict(ok: bool, by: str) -> str:
    return "met" if ok else f"**missed** by {by}"


def _target_lines(scenario: str, columns: dict[str, dict]) -> list[str]:
    """Each target of the issues for this scenario: measured, met or missed by how much, and what
    the rows say about why (solvable scenes, the `optimal` floor, failure reasons)."""
    tsad, opt = columns.get("tsad"), columns.get("optimal [oracle]")
    if tsad is None or scenario not in TARGET_SUCCESS:
        return []
    s, goal = tsad["summary"], TARGET_SUCCESS[scenario]
    lines = ["Targets (TSAD with `--feasibility geometric`):", ""]
    why = ""
    if round(s["success_rate"], 2) < goal:
        reasons = ", ".join(f"{n} {r}" for r, n in sorted(s["failure_reasons"].items()))
        why = f"; failures: {reasons}"
        if opt is not None:
            solved = {r["seed"] for r in opt["rows"] if r["success"]}
            mine = [r["success"] for r in tsad["rows"] if r["seed"] in solved]
            unsolved = [r["success"] for r in tsad["rows"] if r["seed"] not in solved]
            why += (f"; `optimal` solves {len(solved)}/{len(opt['rows'])} of these scenes, TSAD "
                    f"{sum(mine)}/{len(mine)} of those")
            if unsolved:
                why += f" and {sum(unsolved)}/{len(unsolved)} of the rest"
    rate = round(s["success_rate"], 2)  # at the precision the paper reports (29/30 is 0.97)
    lines.append(f"- success {rate:.2f} (target {goal:.2f}): "
                 f"{_verdict(rate >= goal, f'{goal - rate:.2f}')}{why}")
    paper = PAPER_TABLE_I[scenario]["tsad"][1]
    acts = s["actions_success"]
    if acts is not None:
        why = ""
        if acts > paper and opt is not None:
            floor = {r["seed"]: r["num_actions"] for r in opt["rows"]
                     if r.get("optimal_finished") and r["success"]}
            if floor and sum(floor.values()) / len(floor) > paper:
                why = (f"; `optimal` itself needs {sum(floor.values()) / len(floor):.2f} on the "
                       "scenes it solves: these scenes need more actions than the paper's")
            elif floor:
                excess = sorted(((r["num_actions"] - floor[r["seed"]], r["seed"])
                                 for r in tsad["rows"] if r["success"] and r["seed"] in floor),
                                reverse=True)
                worst = ", ".join(f"seed {seed} {extra:+d}" for extra, seed in excess[:3] if extra > 0)
                why = (f"; `optimal` needs {sum(floor.values()) / len(floor):.2f} on these scenes, "
                       f"so the excess is TSAD's own: most of it on {worst or 'no scene'}")
            # the paper does not say whether its count includes taking the target out
            why += (f" (without the final retrieval {acts - 1:.2f}; the paper does not say "
                    "whether its count includes it)")
        lines.append(f"- actions over successful episodes {acts:.2f} (paper {paper:.2f}): "
                     f"{_verdict(acts <= paper, f'{acts - paper:.2f}')}{why}")
    if opt is not None:
        floor = {r["seed"]: r["num_actions"] for r in opt["rows"]
                 if r.get("optimal_finished") and r["success"]}
        pairs = [(r["num_actions"], floor[r["seed"]]) for r in tsad["rows"]
                 if r["success"] and r["seed"] in floor]
        if pairs:
            excess = sum(p[0] for p in pairs) / sum(p[1] for p in pairs) - 1
            over = f"{100 * (excess - TARGET_OVER_OPTIMAL):.0f} points"
            lines.append(f"- actions over `optimal` on the {len(pairs)} scenes both solved "
                         f"{100 * excess:+.0f}% (target at most +{100 * TARGET_OVER_OPTIMAL:.0f}%): "
                         f"{_verdict(excess <= TARGET_OVER_OPTIMAL, over)}")
    median = s["planning_time_median_s"]
    lines.append(f"- median planning time {median:.2f} s (target under {TARGET_MEDIAN_S:.0f} s): "
                 f"{_verdict(median < TARGET_MEDIAN_S, f'{median - TARGET_MEDIAN_S:.2f} s')}")
    ranked = [p for p in ("gp3", "rots", "rots-star", "tsad") if p in columns]
    if len(ranked) == 4:
        lines.append(_order_line(scenario, [(p, columns[p]["summary"]["success_rate"])
                                            for p in ranked]))
    net, oracle = columns.get("tsad [net]"), columns.get("tsad [oracle]")
    if net is not None and oracle is not None:
        gap = round(oracle["summary"]["success_rate"] - net["summary"]["success_rate"], 2)
        median = net["summary"]["planning_time_median_s"]
        late = f"{median - TARGET_NET_MEDIAN_S:.2f} s"
        lines.append(f"- network: success {gap:.2f} below TSAD on the oracle model (target at "
                     f"most {TARGET_NET_GAP:.2f}): "
                     f"{_verdict(gap <= TARGET_NET_GAP, f'{gap - TARGET_NET_GAP:.2f}')}"
                     f"{_net_failures(net) if gap > TARGET_NET_GAP else ''}; median "
                     f"planning {median:.2f} s (target under {TARGET_NET_MEDIAN_S:.0f} s): "
                     f"{_verdict(median < TARGET_NET_MEDIAN_S, late)}")
    return lines + [""]


def _net_failures(net: dict) -> str:
    """Which network episodes failed and why (seeds per reason)."""
    reasons: dict[str, list[int]] = {}
    for row in net["rows"]:
        if not row["success"]:
            reasons.setdefault(row["failure_reason"], []).append(row["seed"])
    return " (" + "; ".join(f"{why}: seeds {', '.join(map(str, seeds))}"
                            for why, seeds in sorted(reasons.items())) + ")"


def _order_line(scenario: str, rates: list[tuple[str, float]]) -> str:
    """Success rates against the paper's order: where the paper ranks one planner strictly
    below the next, so must ours (a tie is not the order); where the paper ties (scenario 1:
    rots = rots-star), ours may tie or rise."""
    paper = PAPER_TABLE_I[scenario]
    signs, broken = [], []
    for (a, ra), (b, rb) in zip(rates, rates[1:]):
        tie = paper[a][0] == paper[b][0]
        if not (round(ra, 2) <= round(rb, 2) if tie else round(ra, 2) < round(rb, 2)):
            broken.append(f"{a} {ra:.2f} {'above' if tie else 'not below'} {b} {rb:.2f} (paper "
                          f"{paper[a][0]:.2f} {'=' if tie else '<'} {paper[b][0]:.2f})")
        signs.append("<=" if tie else "<")
    ours = f"{rates[0][0]} {rates[0][1]:.2f}" + "".join(
        f" {sign} {p} {r:.2f}" for sign, (p, r) in zip(signs, rates[1:]))
    verdict = "met" if not broken else "**missed**: " + "; ".join(broken)
    return f"- baselines in the paper's order (success {ours}): {verdict}"


#: columns per printed table (a wider one does not fit a page)
TABLE_COLUMNS = 7


def _tables(scenario: str, columns: dict[str, dict]) -> list[str]:
    """The scenario's columns as tables of at most TABLE_COLUMNS: first the runs in the paper's
    settings (a counterpart in Tables I-IV), then the others (models, motion, physics, sensing)."""
    ours = [k for k, d in columns.items() if paper_counterpart(scenario, d["spec"])]
    groups = (("In the paper's settings", ours),
              ("Other settings", [k for k in columns if k not in ours]))
    lines = []
    for title, labels in groups:
        if not labels:
            continue
        lines += [f"{title}:", ""]
        for k in range(0, len(labels), TABLE_COLUMNS):
            chunk = labels[k:k + TABLE_COLUMNS]
            lines += [paper_table({label: columns[label]["summary"] for label in chunk}), ""]
    return lines


def write_report(documents: list[dict], out: Path, agreements: list[dict] = (),
                 footprints: list[dict] = ()) -> None:
    """Write `out` (markdown), `out` with .json (digest) and .png (plot) beside it; `agreements`
    (physics agreement studies) and `footprints` (footprint error studies) become sections of
    their own."""
    groups = group_by_scenario(documents)
    machines = {json.dumps(d.get("machine", {}).get("platform")) for d in documents}
    lines = ["# Benchmark results", "",
             "Generated by `tsad report` from `tsad bench` runs (see `make bench`). Actions "
             "count every pick-and-place including the final retrieval of the target; the first "
             "figure is over successful episodes, the second over all episodes, as in the paper.",
             "", f"Machine: {', '.join(sorted(machines))}, "
             f"{documents[0].get('machine', {}).get('host_cpus')} CPUs.", ""]
    digest = {}
    for scenario, columns in groups.items():
        lines += [f"## Scenario {scenario}", "", *_tables(scenario, columns)]
        paper = PAPER_TABLE_I.get(scenario)
        if paper:
            lines += [f"Paper (Table I, scenario {scenario}): " + "; ".join(
                f"{p} success {v[0]:.2f}, actions {v[1]:.2f} / {v[2]:.2f}, "
                f"falls {v[3]:.2f} / {v[4]:.2f}" for p, v in paper.items()), ""]
        lines += _paper_lines(scenario, columns)
        lines += _target_lines(scenario, columns) + _difficulty_lines(columns) + [""]
        digest[scenario] = {k: d["summary"] for k, d in columns.items()}
    if agreements:
        from tsad_drake.bench.study_pages import agreement_markdown

        lines += ["## Physics against the 2-D rule", ""]
        for document in agreements:
            lines += agreement_markdown(document)
    if footprints:
        from tsad_drake.bench.study_pages import footprint_markdown

        lines += ["## Perceived footprints against the truth", "", *footprint_markdown(footprints)]
    page, digest_path, plot = report_outputs(out)
    atomic_write(plot, lambda tmp: _plot(groups, tmp))
    lines += [f"![success rate and actions per planner]({plot.name})", ""]
    atomic_write_text(page, "\n".join(lines))
    atomic_write_text(digest_path, json.dumps(digest, indent=1))


#: one hue per planner, so two planners never share a colour; a planner's variants (other
#: settings) are lighter shades of its hue
PLANNER_COLOURS = {"tsad": "#1f4e9c", "gp3": "#e07b00", "rots": "#2a8a2a", "rots-star": "#c0262d",
                   "rots-star-search": "#7b3fa0", "optimal": "#555555"}
#: colours of columns that are not planners (grid points of `tsad sweep`)
OTHER_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
                 "#7f7f7f", "#bcbd22", "#17becf")


def _colours(labels: list[str]) -> dict[str, tuple]:
    from matplotlib.colors import to_rgb

    colours, seen = {}, {}
    others = iter(OTHER_COLOURS * (len(labels) // len(OTHER_COLOURS) + 1))
    for label in labels:
        base = _planner_of(label)
        if base not in PLANNER_COLOURS:  # not a planner (a sweep's grid point): a colour each
            colours[label] = to_rgb(next(others))
            continue
        k = seen[base] = seen.get(base, -1) + 1
        rgb = to_rgb(PLANNER_COLOURS[base])
        mix = min(0.75, 0.22 * k)  # shade k of the planner's hue: mixed towards white
        colours[label] = tuple(c + (1 - c) * mix for c in rgb)
    return colours


def _plot(groups: dict[str, dict[str, dict]], path: Path) -> None:
    """One panel per table figure (success with its 95% Wilson interval, actions over successful
    episodes, falls per episode), scenarios along x, one bar per settings."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    scenarios = list(groups)
    labels = sorted({label for cols in groups.values() for label in cols}, key=_order)
    colours = _colours(labels)
    panels = (("success rate (95% interval)", "success_rate"),
              ("actions (successful episodes)", "actions_success"),
              ("falls per episode", "falls_all"))
    fig, axes = plt.subplots(1, len(panels), figsize=(15, 4.2))
    width = 0.8 / max(len(labels), 1)
    for k, label in enumerate(labels):
        xs = np.arange(len(scenarios)) + k * width
        summaries = [groups[s][label]["summary"] if label in groups[s] else None for s in scenarios]
        for ax, (_, field) in zip(axes, panels):
            values = [np.nan if s is None or s.get(field) is None else s[field] for s in summaries]
            errors = None
            if field == "success_rate":
                errors = np.array([[0.0, 0.0] if s is None else
                                   [s["success_rate"] - _interval(s)[0], _interval(s)[1] - s["success_rate"]]
                                   for s in summaries]).T.clip(min=0)
            ax.bar(xs, values, width, yerr=errors, capsize=2, color=colours[label], label=label,
                   error_kw={"elinewidth": 0.8, "ecolor": "#222222"})
    for ax, (title, _) in zip(axes, panels):
        ax.set_xticks(np.arange(len(scenarios)) + 0.4 - width / 2)
        ax.set_xticklabels([f"scenario {s}" for s in scenarios])
        ax.set_title(title)
    axes[0].set_ylim(0, 1.05)
    axes[-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _interval(summary: dict) -> tuple[float, float]:
    """The summary's 95% success interval (recomputed for files from before it was recorded)."""
    if summary.get("success_interval_95"):
        return tuple(summary["success_interval_95"])
    n = summary["episodes"]
    return wilson_interval(round(summary["success_rate"] * n), n)
