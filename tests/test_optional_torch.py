"""PyTorch is the `net` extra: the geometric path runs without it, the network path says so in
one line (exit status 2)."""

import json
import subprocess
import sys

#: run before tsad_drake in the child: every import of torch fails as if it were not installed
NO_TORCH = """
import importlib.abc, importlib.util, sys
class NoTorch(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "torch" or name.startswith("torch."):
            raise ModuleNotFoundError("No module named 'torch'", name=name)
        return None
sys.meta_path.insert(0, NoTorch())
importlib.util.find_spec = (lambda find: lambda name, *a: None if name == "torch"
                            else find(name, *a))(importlib.util.find_spec)
"""


def _child(code: str, tmp_path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", NO_TORCH + code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=300)


def test_the_default_path_imports_no_torch_and_plans_without_it(tmp_path):
    out = tmp_path / "run"
    run = _child(f"""
import sys
import tsad_drake.pipeline, tsad_drake.bench.runner, tsad_drake.cli
assert "torch" not in sys.modules
from tsad_drake.cli import main
code = main(["plan", "--scenario", "3", "--seed", "0", "--planner", "gp3",
             "--feasibility", "geometric", "--out", {str(out)!r}])
assert "torch" not in sys.modules
sys.exit(code)
""", tmp_path)
    assert run.returncode in (0, 1), run.stderr[-2000:]
    document = json.loads((out / "plan.json").read_text())
    assert document["planner"] == "gp3" and document["num_actions"] >= 1


def test_the_network_without_torch_is_one_line_and_exit_status_2(tmp_path):
    run = _child(f"""
import sys
from tsad_drake.cli import main
sys.exit(main(["plan", "--scenario", "3", "--seed", "0", "--feasibility", "net",
               "--planner", "tsad", "--out", {str(tmp_path / "net")!r}]))
""", tmp_path)
    lines = [line for line in run.stderr.splitlines() if line.strip()]
    assert run.returncode == 2 and len(lines) == 1, run.stderr[-2000:]
    assert "needs PyTorch: pip install 'tsad_drake[net]'" in lines[0]
    assert not (tmp_path / "net" / "plan.json").exists()
