"""`tsad verify PLAN`: a plan from any planner checked at the motion level (and in a world)."""

from __future__ import annotations

import argparse
import json
import statistics

from tsad_drake.cli.common import add_threads_arg
from tsad_drake.cli.config import add_config_args, apply_config_args
from tsad_drake.outputs import prepare_out_dir
from tsad_drake.runtime import detail

#: what executes the verified motions (`--world`; tsad_drake.verification.VERIFY_WORLDS)
WORLD_CHOICES = ("none", "geometric", "physics")


def add_verify_parser(sub) -> None:
    p = sub.add_parser("verify", help="verify a plan (tsad-plan/1 JSON) at the motion level",
                       description=(
                           "Build the station for the plan's scenario and, action by action on "
                           "the true scene, solve each pick-and-place's motion as `tsad plan "
                           "--motion` does (IK keyframes, trajectory optimisation, dense "
                           "collision check), naming the cause of every refusal. Writes "
                           "report.json, replay.html and scene.dmd.yaml into --out. Exit 0 when "
                           "every action verifies (and the target is retrieved when the plan "
                           "asks), 1 when not, 2 for a malformed plan (docs/plan-format.md)."))
    p.add_argument("plan", help="plan file in the tsad-plan/1 format (as `tsad plan` writes "
                                "DIR/plan.tsad.json)")
    p.add_argument("--world", choices=WORLD_CHOICES, default="none",
                   help="what executes the verified motions: none (the motion level only; "
                        "default), geometric (the 2-D corridor rule judges each action) or "
                        "physics (a Drake contact simulation plays the verified motions and "
                        "reports moved / fell / disturbed / placement error per action; about "
                        "5-10 s of wall time per action)")
    p.add_argument("--keep-going", action="store_true",
                   help="after a refused action, skip it and check the later actions on the "
                        "scene without it (default: stop at the first refused action)")
    p.add_argument("--out", default="out/verify", help="output directory (default out/verify)")
    add_config_args(p)
    add_threads_arg(p)


def _action_line(verdict: dict) -> str:
    x, y = verdict["place_xy"]
    where = (f"{verdict['index'] + 1:2d}. {verdict['object']:<8} pick "
             f"{verdict['theta_pick_deg']:+4.0f} deg -> ({x:.3f}, {y:.3f}) place "
             f"{verdict['theta_place_deg']:+4.0f} deg")
    if verdict["status"] == "not checked":
        return f"{where}: not checked"
    line = f"{where}: {'verified' if verdict['verified'] else 'REFUSED'} " \
           f"({verdict['planning_time_s']:.2f} s)"
    cause = verdict["cause"]
    if cause:
        pair = " vs ".join(cause["bodies"])
        margin = "" if cause["margin_mm"] is None else f", {cause['margin_mm']:+.1f} mm"
        line += f" at {cause['where'] or '?'}: {cause['kind']}" + (f" {pair}{margin}" if pair else "")
        if verdict["skipped"]:
            line += " [skipped]"
    world = verdict["world"]
    if world is not None:
        from tsad_drake.cli.plan import physics_line

        line += "; world: " + (physics_line(world) if "sim_seconds" in world else
                               ("moved" if world["moved"] else f"NOT moved ({world['reason']})")
                               + (f", fell: {', '.join(world['fallen'])}" if world["fallen"]
                                  else ""))
    return line


def cmd_verify(args: argparse.Namespace) -> int:
    from tsad_drake.plan_format import load_plan
    from tsad_drake.run_config import default_run_config

    plan = load_plan(args.plan)  # a malformed plan: one line, exit 2, nothing written
    # the station, motion and world sections are what verification uses (the planner's unused)
    config = apply_config_args(default_run_config(), args)
    out = prepare_out_dir(args.out)
    from tsad_drake.motion.export import write_scene_directives
    from tsad_drake.motion.replay import write_replay_html
    from tsad_drake.placement import placed_config
    from tsad_drake.verification import verify_plan

    scenario = plan.scenario
    config = placed_config(scenario, config)  # where the robot stands for this shelf
    count = len(plan.actions)

    def progress(i: int, motion) -> None:
        state = "verified" if motion.verified else "refused"
        detail(f"  action {i + 1}/{count} ({motion.action.object}): {state} "
               f"({motion.planning_time_s:.2f} s)")

    report = verify_plan(scenario, plan.actions, world=args.world,
                         retrieve_target=plan.retrieve_target, theta_retrieve=plan.theta_retrieve,
                         keep_going=args.keep_going, config=config, progress=progress)
    document = report.to_json()
    document["plan"] = str(args.plan)
    X_WS = config.station.X_WS(scenario.shelf.floor_height)
    if report.physics_world is not None:
        report.physics_world.write_replay(out / "replay.html")
        write_replay_html(scenario, plan.actions, report.motions, out / "planned_replay.html",
                          X_WS=X_WS)
        replays = "replay.html (the contact simulation) and planned_replay.html (the motion)"
    else:
        write_replay_html(scenario, plan.actions, report.motions, out / "replay.html", X_WS=X_WS)
        replays = "replay.html"
    write_scene_directives(scenario, out, X_WS)
    path = out.write_text("report.json", json.dumps(document, indent=2))
    print(f"verify {args.plan}: scenario {scenario.name}, {count} actions, world {args.world}"
          + (", keep going" if args.keep_going else ""))
    for verdict in document["actions"]:
        print("  " + _action_line(verdict))
    retrieval = document["retrieval"]
    if retrieval is not None:
        if retrieval["verified"]:
            state = f"verified at {retrieval['theta_deg']:+.0f} deg"
        else:
            state = "not checked" if retrieval["status"] == "not checked" else "REFUSED"
        world = retrieval["world"]
        if world is not None:
            state += "; world: " + ("retrieved" if world["retrieved"] else
                                    f"NOT retrieved ({world['reason']})")
        print(f"  target {scenario.target} retrieval: {state}")
    times = report.planning_times
    if times:
        print(f"motion planning per action: median {statistics.median(times):.2f} s, worst "
              f"{max(times):.2f} s; whole verification {report.verification_time_s:.2f} s")
    verdict = "plan verified" if report.success else f"NOT verified: {report.failure_reason}"
    print(verdict)
    print(f"wrote {path}, {out / 'scene.dmd.yaml'} and {replays} in {out}")
    return 0 if report.success else 1


VERIFY_COMMANDS = {"verify": cmd_verify}
