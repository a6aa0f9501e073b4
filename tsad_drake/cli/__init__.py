"""`tsad` command line: render, scene, plan, verify, bench, sweep, report, config, the network's."""

from tsad_drake.cli.main import main

__all__ = ["main"]
