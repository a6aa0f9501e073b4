"""Agreement study: do the 2-D corridor rule and Drake physics agree on what an action did?

Per scenario and seed: `--planner` (TSAD by default; ROTS, ROTS*, GP3) plans a closed-loop
episode in the geometric world (ray-cast observer, `--feasibility` model, every action
motion-checked as `--motion` does); its executed
actions (true object names) are then executed
again, in order and open loop, in a fresh GeometricWorld and in a fresh PhysicsWorld, and each
action's verdicts are compared: the object moved or not, which objects fell, which were disturbed
(physics only; the rule has no such notion). With `--aim perceived` the physics world observes
(Drake renders of the simulated state) before each action and plans its motion on the perceived
poses; by default it aims at the true poses, so that only the judging differs.

Every disagreement is classified:
  rule-fall-physics-stands      the rule knocks an object over, physics leaves it standing
                                (sub-label: "disturbed" when physics moved it > 1 cm)
  physics-fall-rule-missed      physics knocks an object over, the rule does not
  moved-rule-only               the rule moves the object, physics does not (reason recorded)
  no-motion                     the physics world found no motion for the action (planned
                                from where its arm is, on what it believes), so nothing ran
  moved-physics-only            physics moves it, the rule does not
  disturbed-only                same falls and moves, but physics disturbed a neighbour
After the first disagreement on falls or moves the two worlds hold different scenes; later
actions are still compared and flagged `diverged`.

    python -m studies.physics_agreement --scenarios 1 2 3 --seeds 0 1 2 \
        --out results/physics_agreement.json
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import json
import math
import sys
import time
from pathlib import Path

from tsad_drake.bench.study_pages import PLANNER_NAMES, confusion
from tsad_drake.execution.world import ActionOutcome, GeometricWorld
from tsad_drake.planning.types import Action
from tsad_drake.scenario import Scenario

#: planners whose actions the study compares, and their names in the text


# the episode machinery (pipeline, scene generator) is imported where episodes run: `tsad report`
# reads study files through this module and needs only its summaries


def planned_actions(scenario: Scenario, seed: int, feasibility: str, planner: str = "tsad"
                    ) -> list[Action]:
    """The actions `planner` executes in a closed-loop geometric episode (true object names)."""
    from tsad_drake.pipeline import EpisodeSettings, run_settings

    row = run_settings(scenario, seed, EpisodeSettings(planner=planner, feasibility=feasibility,
                                                       motion=True))
    return [Action(a["true_object"], math.radians(a["theta_pick_deg"]), a["place_xy"][0],
                   a["place_xy"][1], math.radians(a["theta_place_deg"]))
            for a in row["actions"]]


def classify(rule: ActionOutcome, physics: ActionOutcome) -> list[str]:
    """The disagreement classes of one action (empty when the worlds agree)."""
    classes = []
    for name in sorted(set(rule.fallen) - set(physics.fallen)):
        label = "disturbed" if name in physics.disturbed else "untouched"
        classes.append(f"rule-fall-physics-stands:{label}:{name}")
    classes += [f"physics-fall-rule-missed:{n}" for n in sorted(set(physics.fallen)
                                                                 - set(rule.fallen))]
    if rule.moved and not physics.moved:
        classes.append("no-motion" if physics.sim_seconds == 0 else "moved-rule-only")
    if physics.moved and not rule.moved:
        classes.append("moved-physics-only")
    if not classes and physics.disturbed:
        classes.append("disturbed-only:" + ",".join(physics.disturbed))
    return classes


def compare_episode(scenario: Scenario, actions: list[Action], aim: str) -> list[dict]:
    """Execute `actions` in both worlds; one comparison record per action."""
    from tsad_drake.physics.world import PhysicsWorld

    rule_world = GeometricWorld(scenario)
    physics_world = PhysicsWorld(scenario)
    records, diverged = [], False
    for action in actions:
        if rule_world.done or physics_world.done:
            break
        if aim == "perceived":
            physics_world.observe()
        rule = rule_world.execute(action)
        physics = physics_world.execute(action)
        classes = classify(rule, physics)
        records.append({"object": action.object, "diverged": diverged,
                        "rule": {"moved": rule.moved, "fallen": rule.fallen,
                                 "reason": rule.reason},
                        "physics": dc.asdict(physics), "disagreements": classes})
        diverged = diverged or any(not c.startswith("disturbed-only") for c in classes)
    return records


def summarise(episodes: list[dict]) -> dict:
    """Agreement rates over every compared action (and over those before any divergence)."""
    actions = [a for e in episodes for a in e["actions"]]
    clean = [a for a in actions if not a["diverged"]]
    classes: dict[str, int] = {}
    for a in actions:
        for c in a["disagreements"]:
            key = ":".join(c.split(":")[:2]) if c.startswith("rule-fall") else c.split(":")[0]
            classes[key] = classes.get(key, 0) + 1
    simulated = [a["physics"] for a in actions if a["physics"]["sim_seconds"] > 0]
    sim = sum(p["sim_seconds"] for p in simulated)
    wall = sum(p["wall_seconds"] for p in simulated)

    def rate(items, key) -> float | None:
        return sum(key(a) for a in items) / len(items) if items else None

    def agree(a: dict) -> bool:
        return not [c for c in a["disagreements"] if not c.startswith("disturbed-only")]

    return {
        "episodes": len(episodes), "actions": len(actions),
        "confusion": confusion(actions),
        "agree_moved_fell": rate(actions, agree),
        "agree_moved_fell_before_divergence": rate(clean, agree),
        "agree_moved": rate(actions, lambda a: a["rule"]["moved"] == a["physics"]["moved"]),
        "agree_fell": rate(actions, lambda a: sorted(a["rule"]["fallen"])
                           == sorted(a["physics"]["fallen"])),
        "physics_disturbed_actions": sum(bool(a["physics"]["disturbed"]) for a in actions),
        "disagreement_classes": classes,
        "physics_moved": sum(a["physics"]["moved"] for a in actions),
        "rule_moved": sum(a["rule"]["moved"] for a in actions),
        "physics_falls": sum(len(a["physics"]["fallen"]) for a in actions),
        "rule_falls": sum(len(a["rule"]["fallen"]) for a in actions),
        "sim_seconds_per_action": sim / len(simulated) if simulated else None,
        "real_time_factor": sim / wall if wall else None,
    }


def main(argv: list[str] | None = None) -> int:
    from tsad_drake.scenes import generate_scenario

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenarios", nargs="+", default=["1", "2", "3"])
    p.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    p.add_argument("--planner", default="tsad", choices=sorted(PLANNER_NAMES),
                   help="whose executed actions are compared (default tsad)")
    p.add_argument("--feasibility", default="geometric",
                   help="the planner's feasibility model (default geometric)")
    p.add_argument("--aim", default="true", choices=("true", "perceived"),
                   help="the poses the physics world plans its motions on (default true)")
    p.add_argument("--out", default="results/physics_agreement.json")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    episodes: list[dict] = []
    document: dict = {}
    for name in args.scenarios:
        for seed in args.seeds:
            scenario = generate_scenario(name, seed)
            t0 = time.perf_counter()
            actions = planned_actions(scenario, seed, args.feasibility, args.planner)
            records = compare_episode(scenario, actions, args.aim)
            episodes.append({"scenario": name, "seed": seed, "actions": records,
                             "wall_s": time.perf_counter() - t0})
            bad = sum(bool(r["disagreements"]) for r in records)
            print(f"scenario {name} seed {seed}: {len(records)} actions, {bad} with "
                  f"disagreements ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
            document = {"settings": vars(args), "summary": summarise(episodes),
                        "episodes": episodes}
            out.write_text(json.dumps(document, indent=1))  # after every episode
    print(json.dumps(document.get("summary", {}), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
