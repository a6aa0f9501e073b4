"""`tsad` command line: render, scene, plan, bench, report, dataset, train, net-eval, net-calibrate."""

from tsad_drake.cli.main import main

__all__ = ["main"]
