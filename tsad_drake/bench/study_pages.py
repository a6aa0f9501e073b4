"""What `tsad report` shows of the study scripts' outputs (studies/ at the top of the repository,
not in the wheel): the footprint-error tables (`studies/hull_errors.py --json`) and the physics
agreement study (`studies/physics_agreement.py`)."""

from __future__ import annotations

#: display names of the planners the agreement study runs
PLANNER_NAMES = {"tsad": "TSAD", "rots": "ROTS", "rots-star": "ROTS*", "gp3": "GP3"}


#: the `study` field of the footprint study's JSON document (`studies/hull_errors.py`)
STUDY = "footprint_errors"


def is_footprint_document(document) -> bool:
    """Whether `document` is the footprint study's `--json` output."""
    return isinstance(document, dict) and document.get("study") == STUDY


def footprint_markdown(documents: list[dict]) -> list[str]:
    """One table row per document (all objects): shortfall and excess, median / p90 / worst."""
    lines = ["Perceived footprints (what the planners use: fitted outlines padded by their "
             "uncertainty, or completed point hulls) against the true ones, ray-cast views; "
             "shortfall: how far the truth reaches past the perceived footprint (what a gap or "
             "margin must absorb), excess: how far the perceived footprint reaches past the truth "
             "(space wrongly taken); mm, median / p90 / worst "
             "(`python -m studies.hull_errors --json FILE`):", "",
             "| sensing | scenarios x seeds | objects | shortfall | excess |", "|---|---|---|---|---|"]
    for doc in documents:
        st, e = doc["settings"], doc["summary"]["all"]
        noise = "" if st.get("noise_mm") is None else f" at {st['noise_mm']} mm"
        noise += f" x {st['frames']} frames" if st.get("frames", 1) > 1 else ""
        lines.append(
            f"| {st['sensor']}{noise}, {st['segmentation']}{', plain' if st.get('plain') else ''}"
            f" | {','.join(st['scenarios'])} x {st['seeds'][0]}-{st['seeds'][1]} | {e['objects']}"
            f" | {e['shortfall_median_mm']:.1f} / {e['shortfall_p90_mm']:.1f} / "
            f"{e['shortfall_max_mm']:.1f} | {e['excess_median_mm']:.1f} / {e['excess_p90_mm']:.1f}"
            f" / {e['excess_max_mm']:.1f} |")
    return lines + [""]


def confusion(actions: list[dict]) -> dict:
    """Per action, the rule's verdict against physics' as 2 x 2 counts: `moved` (the object stands
    at its place point) and `fall` (any object fell), keyed "rule yes / physics no" etc."""
    def matrix(verdict) -> dict[str, int]:
        counts = {f"rule {a} / physics {b}": 0 for a in ("yes", "no") for b in ("yes", "no")}
        for action in actions:
            rule, physics = verdict(action["rule"]), verdict(action["physics"])
            counts[f"rule {'yes' if rule else 'no'} / physics {'yes' if physics else 'no'}"] += 1
        return counts

    return {"moved": matrix(lambda v: bool(v["moved"])), "fall": matrix(lambda v: bool(v["fallen"]))}


def agreement_markdown(document: dict) -> list[str]:
    """The study as markdown lines: settings, the two confusion matrices, the disagreement
    classes and the simulation's speed."""
    s, settings = document["summary"], document["settings"]
    planner = PLANNER_NAMES.get(settings.get("planner", "tsad"), settings.get("planner"))
    model = settings.get("feasibility", "geometric")
    lines = [f"{s['actions']} actions of {planner} ({model} model) "
             f"in {s['episodes']} episodes (scenarios {', '.join(map(str, settings['scenarios']))}"
             f", seeds {', '.join(map(str, settings['seeds']))}; physics aimed at the "
             f"{settings.get('aim', 'true')} poses), executed by the 2-D rule and by physics:", ""]
    table = confusion([a for e in document["episodes"] for a in e["actions"]])
    for name, counts in table.items():
        lines += [f"| {name}: rule \\ physics | yes | no |", "|---|---|---|"]
        for rule in ("yes", "no"):
            lines.append(f"| rule {rule} | {counts[f'rule {rule} / physics yes']} | "
                         f"{counts[f'rule {rule} / physics no']} |")
        lines.append("")
    classes = ", ".join(f"{k}: {v}" for k, v in sorted(s["disagreement_classes"].items()))
    lines.append(f"Disagreements by cause: {classes or 'none'} (causes: "
                 "`studies/physics_agreement.py`). Agreement on move and fall "
                 f"{s['agree_moved_fell']:.2f} of actions ({s['agree_moved_fell_before_divergence']:.2f}"
                 " before the worlds diverge).")
    if s.get("real_time_factor"):
        lines.append(f"Simulated {s['sim_seconds_per_action']:.1f} s per action at a real-time "
                     f"factor of {s['real_time_factor']:.2f}.")
    return lines + [""]


def is_agreement_document(document) -> bool:
    """Whether `document` is the agreement study's output (settings, summary, episodes)."""
    return (isinstance(document, dict) and {"settings", "summary", "episodes"} <= set(document)
            and isinstance(document["episodes"], list))
