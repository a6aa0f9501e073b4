#!/usr/bin/env bash
# Build the wheel, install it into a fresh venv outside the repository and run `tsad render` and
# `tsad plan` (Drake observer, motion level) from a temporary directory: proof that the package
# ships everything it reads (models/, network weights). The heavy dependencies (drake, torch,
# open3d) come read-only from the project's venv through a .pth line, so nothing is downloaded;
# tsad_drake itself comes only from the wheel.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
py="$repo/.venv/bin/python"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$py" -m pip wheel -q --no-deps --no-build-isolation -w "$tmp/dist" "$repo" > "$tmp/build.log" 2>&1 \
  || { tail -20 "$tmp/build.log"; echo "wheel-check: the wheel did not build"; exit 1; }
"$py" -m venv "$tmp/venv"
site="$("$tmp/venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
"$py" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])' > "$site/project_dependencies.pth"
"$tmp/venv/bin/python" -m pip install -q --no-deps --no-index "$tmp"/dist/tsad_drake-*.whl
cd "$tmp"
"$tmp/venv/bin/python" - "$repo" <<'PY'
import sys
from pathlib import Path

import tsad_drake
from tsad_drake.station_models import PACKAGE_XML

repo = Path(sys.argv[1])
for path in (Path(tsad_drake.__file__), PACKAGE_XML):
    assert repo not in path.resolve().parents, f"{path} comes from the repository, not the wheel"
# the study scripts stay in the repository (studies/); the report's pages of them are in the wheel
import importlib.util

assert importlib.util.find_spec("tsad_drake.bench.study_pages") is not None
assert not (Path(tsad_drake.__file__).parent / "bench" / "studies").exists(), "studies in the wheel"
assert (PACKAGE_XML.parent / "README.md").is_file(), "models/README.md missing from the wheel"
print(f"wheel-check: tsad_drake from {Path(tsad_drake.__file__).parent}, models {PACKAGE_XML.parent}")
PY
"$tmp/venv/bin/tsad" render --scenario 1 --seed 0 --out "$tmp/render" > "$tmp/render.log"
test -s "$tmp/render/depth.npy"
"$tmp/venv/bin/tsad" plan --scenario 1 --seed 0 --planner tsad --feasibility geometric \
  --observer drake --motion --out "$tmp/plan" > "$tmp/plan.log"
"$tmp/venv/bin/python" - "$tmp/plan/plan.json" <<'PY'
import json
import sys

from tsad_drake.prehensile.checkpoint import DEFAULT_WEIGHTS, load_checkpoint

plan = json.load(open(sys.argv[1]))
assert plan["success"] and plan["motion_checks"], "the plan failed or checked no motion"
net, meta = load_checkpoint()  # the shipped weights, from the wheel
assert "site-packages" in str(DEFAULT_WEIGHTS)
PY
echo "wheel-check: render, plan (Drake observer, motion level) and the shipped weights work from the wheel"
