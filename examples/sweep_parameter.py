"""Sweep one planner parameter over a few scenes and print a small table (the public API only).

Run: python examples/sweep_parameter.py [--field iterations] [--values 60,120,240]
         [--scenario 2] [--seeds 0,1,2] [--variant full]
"""

import argparse
import ast

import tsad_drake as td


def sweep(field: str, values: list, scenes: dict[int, td.Scenario], variant: str) -> list[dict]:
    """One closed-loop TSAD episode per (value, seed); rows of value, seed, success, actions."""
    rows = []
    for value in values:
        settings = td.EpisodeSettings(planner="tsad", variant=variant,
                                      planner_overrides=((field, value),))
        for seed, scenario in scenes.items():
            record = td.plan_episode(scenario, seed, settings)
            searched = [n for r in record.rounds for n in r.stats.get("iterations", [])]
            rows.append({"value": value, "seed": seed, "success": record.success,
                         "actions": record.num_actions, "plan_s": record.planning_time_s,
                         "sub_search_iterations": searched})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--field", default="iterations", help="a TSADConfig field")
    parser.add_argument("--values", default="60,120,240", help="comma-separated Python literals")
    parser.add_argument("--scenario", default="2")
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--variant", default="full", choices=["full", "paper"])
    args = parser.parse_args()
    values = [ast.literal_eval(v) for v in args.values.split(",")]
    scenes = {int(s): td.generate_scenario(args.scenario, int(s)) for s in args.seeds.split(",")}
    rows = sweep(args.field, values, scenes, args.variant)
    print(f"{args.field:>20} {'seed':>4} {'success':>7} {'actions':>7} {'plan [s]':>8}")
    for r in rows:
        print(f"{r['value']!s:>20} {r['seed']:>4} {r['success']!s:>7} {r['actions']:>7} "
              f"{r['plan_s']:>8.2f}")


if __name__ == "__main__":
    main()
