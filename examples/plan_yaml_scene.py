"""Plan a scene written as YAML (your own layout, or one `tsad scene` wrote) with any planner.

Run: python examples/plan_yaml_scene.py SCENE.yaml [--planner tsad] [--feasibility geometric]
"""

import argparse

import tsad_drake as td


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="scenario YAML file")
    parser.add_argument("--planner", default="tsad")
    parser.add_argument("--feasibility", default="geometric", choices=["geometric", "oracle", "net"])
    args = parser.parse_args()
    scenario = td.load_scenario(args.scene)  # validated; a bad file raises ScenarioError
    settings = td.EpisodeSettings(planner=args.planner, feasibility=args.feasibility)
    record = td.plan_episode(scenario, 0, settings)
    moves = ", ".join(f"{a.object} -> ({a.place_xy[0]:.2f}, {a.place_xy[1]:.2f})"
                      for a in record.actions)
    verdict = "target retrieved" if record.success else record.failure_reason
    print(f"{scenario.name}: {verdict}; {record.num_actions} actions: {moves or 'none'}")


if __name__ == "__main__":
    main()
