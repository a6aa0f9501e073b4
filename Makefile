# tsad_drake: `make demo` and `make test` bootstrap everything on a fresh Debian machine.
SHELL := /bin/bash
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
DEB_PACKAGES := libusb-1.0-0 libegl1 libegl-mesa0 libgl1-mesa-dri libglib2.0-0 libgomp1
export MESA_SHADER_CACHE_DISABLE := true

.PHONY: all setup system-deps demo test test-slow wheel-check bench bench-paper bench-realistic bench-frames footprints bench-extra bench-motion bench-real-physics bench-wide bench-physics bench-noise net-realistic report cost-curves lint clean

all: test

# Debian libraries for open3d (libusb) and headless EGL rendering; installed only when missing.
system-deps:
	@missing=""; for p in $(DEB_PACKAGES); do \
	  dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  SUDO=""; [ "$$(id -u)" = 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi

$(STAMP): pyproject.toml constraints.txt | system-deps
	@command -v $(PYTHON) >/dev/null || { echo "need $(PYTHON)"; exit 1; }
	[ -x $(PY) ] || $(PYTHON) -m venv $(VENV)
	# setuptools >= 70 builds wheels without the separate `wheel` package (make wheel-check)
	$(PY) -m pip install -q --upgrade pip 'setuptools>=70'
	# torch first: the CPU wheel on this disk (a bare `torch` would pull a CUDA build)
	$(PY) -m pip install -q torch==2.13.0
	# the package with the tested pins of constraints.txt (pyproject.toml keeps ranges)
	$(PY) -m pip install -q -c constraints.txt -e '.[dev,ray,net]'
	touch $(STAMP)

setup: system-deps $(STAMP)

# The main job: scenario 1 seed 0 rendered in the Drake station, perceived, planned by TSAD,
# every pick-and-place turned into a verified UR5e motion, and a Meshcat replay written.
# Every action is executed as a Drake contact simulation of the station (WORLD=geometric: the
# 2-D corridor rule instead, a few times faster), re-rendered after each sub-search.
DEMO_FEASIBILITY ?= net
WORLD ?= physics
VARIANT ?= full
demo: setup
	$(VENV)/bin/tsad plan --scenario 1 --seed 0 --planner tsad --feasibility $(DEMO_FEASIBILITY) \
	  --variant $(VARIANT) --observer drake --motion --world $(WORLD) --out out/demo

test: setup
	$(VENV)/bin/pytest -q
	$(MAKE) --no-print-directory wheel-check

# The built wheel, installed outside the repository, renders and plans (tools/wheel_check.sh).
wheel-check: setup
	tools/wheel_check.sh

test-slow: setup
	$(VENV)/bin/pytest -q -m slow

# The paper's Tables I-III: 30 episodes per scenario and planner, reward ablations on scenario 1,
# occluded targets (15 episodes) on scenarios 1 and 2. Interrupted runs resume where they stopped.
BENCH_EPISODES ?= 30
BENCH_WORKERS ?= 2
BENCH_FEASIBILITY ?= geometric
BENCH_DIR := results/bench
TSAD := $(VENV)/bin/tsad
bench: setup
	mkdir -p $(BENCH_DIR)
	for s in 1 2 3; do for p in tsad gp3 rots rots-star optimal; do \
	  f=$(BENCH_FEASIBILITY); [ $$p = optimal ] && f=oracle; \
	  $(TSAD) bench --scenario $$s --planner $$p --feasibility $$f --episodes $(BENCH_EPISODES) \
	    --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/s$$s-$$p.json || exit 1; done; done
	for a in no-ro no-re; do \
	  $(TSAD) bench --scenario 1 --planner tsad --ablation $$a --feasibility $(BENCH_FEASIBILITY) \
	    --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/s1-tsad-$$a.json || exit 1; done
	for s in 1 2; do \
	  $(TSAD) bench --scenario $$s --planner tsad --occluded --feasibility $(BENCH_FEASIBILITY) \
	    --episodes 15 --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/s$$s-tsad-occluded.json || exit 1; done
	$(MAKE) bench-paper
	$(MAKE) report

# The paper's TSAD as written (--variant paper): Table I rows on scenarios 1-3, Table II (the
# reward ablations, scenario 1), Table III (occluded targets, 15 episodes), and Table IV's
# counterpart on the `real` shelf (5 objects, 15 episodes: TSAD in both variants, GP3, ROTS*),
# rendered by the Drake station with realistic depth noise and cluster segmentation, as a robot sees.
REAL_SENSING := --feasibility $(BENCH_FEASIBILITY) --observer drake --sensor realistic --segmentation cluster
bench-paper: setup
	mkdir -p $(BENCH_DIR)
	for s in 1 2 3; do \
	  $(TSAD) bench --scenario $$s --planner tsad --variant paper --feasibility $(BENCH_FEASIBILITY) \
	    --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/s$$s-tsad-paper.json || exit 1; done
	for a in no-ro no-re; do \
	  $(TSAD) bench --scenario 1 --planner tsad --variant paper --ablation $$a \
	    --feasibility $(BENCH_FEASIBILITY) --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/s1-tsad-paper-$$a.json || exit 1; done
	for s in 1 2; do \
	  $(TSAD) bench --scenario $$s --planner tsad --variant paper --occluded \
	    --feasibility $(BENCH_FEASIBILITY) --episodes 15 --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/s$$s-tsad-paper-occluded.json || exit 1; done
	for v in full paper; do \
	  $(TSAD) bench --scenario real --planner tsad --variant $$v $(REAL_SENSING) \
	    --episodes 15 --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/real-tsad-$$v.json || exit 1; done
	for p in gp3 rots-star; do \
	  $(TSAD) bench --scenario real --planner $$p $(REAL_SENSING) \
	    --episodes 15 --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/real-$$p.json || exit 1; done
	$(MAKE) bench-real-physics

# Table IV executed in the physics world: every pick-and-place a Drake contact simulation of the
# station, the next view rendered from the simulated state (about a minute per episode).
bench-real-physics: setup
	mkdir -p $(BENCH_DIR)
	for p in tsad gp3 rots-star; do \
	  $(TSAD) bench --scenario real --planner $$p $(REAL_SENSING) --world physics \
	    --episodes 15 --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/real-$$p-physics.json || exit 1; done

# Realistic perception: the depth sensor model (`--sensor realistic`: distance-dependent noise,
# dropout and flying pixels at edges, quantisation) and segmentation without the renderer's
# labels (`cluster`), for TSAD in both variants and ROTS* on scenarios 1-3; one depth frame per view
# (the rows of 2026-12-02; the preset has taken eight since 2026-12-03).
bench-realistic: setup
	mkdir -p $(BENCH_DIR)
	for s in 1 2 3; do for v in full paper; do \
	  $(TSAD) bench --scenario $$s --planner tsad --variant $$v --sensor realistic --segmentation cluster \
	    --set sensor.frames=1 \
	    --feasibility $(BENCH_FEASIBILITY) --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/s$$s-tsad-$$v-realistic.json || exit 1; done; \
	  $(TSAD) bench --scenario $$s --planner rots-star --sensor realistic --segmentation cluster \
	    --set sensor.frames=1 --feasibility $(BENCH_FEASIBILITY) --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/s$$s-rots-star-realistic.json || exit 1; done
	$(MAKE) footprints

# The headline rows as a robot senses it: realistic depth with eight frames fused per view,
# `cluster` segmentation, held-out seeds 1000-1029 of scenarios 1-3; TSAD on the geometric model
# and on the network (median 7-11 s of planning per episode), TSAD with ideal sensing, then ROTS*,
# ROTS and GP3 (a few s per episode), each also with ideal sensing.
bench-frames: setup
	mkdir -p $(BENCH_DIR)/heldout
	for f in geometric net; do for s in 1 2 3; do \
	  $(TSAD) bench --scenario $$s --planner tsad --feasibility $$f --sensor realistic \
	    --segmentation cluster --set sensor.frames=8 --episodes 30 --seed-start 1000 \
	    --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/heldout/s$$s-tsad$$( [ $$f = net ] && echo -net )-realistic-frames8.json \
	    || exit 1; done; done
	for s in 1 2 3; do \
	  $(TSAD) bench --scenario $$s --planner tsad --feasibility geometric --episodes 30 \
	    --seed-start 1000 --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/heldout/s$$s-tsad.json \
	    || exit 1; done
	for p in rots-star rots gp3; do for s in 1 2 3; do \
	  $(TSAD) bench --scenario $$s --planner $$p --feasibility geometric --sensor realistic \
	    --segmentation cluster --set sensor.frames=8 --episodes 30 --seed-start 1000 \
	    --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/heldout/s$$s-$$p-realistic-frames8.json \
	    || exit 1; \
	  $(TSAD) bench --scenario $$s --planner $$p --feasibility geometric --episodes 30 \
	    --seed-start 1000 --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/heldout/s$$s-$$p.json \
	    || exit 1; done; done

# Perceived footprints against the true ones (median / p90 / worst shortfall and excess), ideal
# and realistic sensing, scenarios 1-3 seeds 0-9: a section of the results page.
footprints: setup
	mkdir -p results/perception
	for c in "ideal label" "realistic cluster" "realistic label"; do set -- $$c; \
	  $(PY) -m studies.hull_errors --sensor $$1 --segmentation $$2 --seeds 10 \
	    --json results/perception/footprints-$$1-$$2.json || exit 1; done

# Extras: TSAD on the prehensile network and on the oracle model (scenarios 1-3, 30 episodes
# each: the network issue's target is net within 0.03 of oracle), the stronger ROTS* variant
# (rots-star-search), and the motion-level rows (bench-motion).
bench-extra: setup
	mkdir -p $(BENCH_DIR)
	for s in 1 2 3; do for f in net oracle; do \
	  $(TSAD) bench --scenario $$s --planner tsad --feasibility $$f --episodes $(BENCH_EPISODES) \
	    --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/s$$s-tsad-$$f.json || exit 1; done; done
	for s in 1 2 3; do \
	  $(TSAD) bench --scenario $$s --planner rots-star-search --feasibility geometric \
	    --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/s$$s-rots-star-search.json || exit 1; \
	  $(TSAD) bench --scenario $$s --planner rots-star --feasibility net \
	    --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/s$$s-rots-star-net.json || exit 1; done
	$(MAKE) bench-motion

# Plans the arm executes as planned: every action verified at the motion level (`--motion`) before
# it is executed. TSAD on scenarios 1-3 on the geometric model and on the network (30 episodes),
# and on held-out seeds 1000-1029 (the generator and the planners were tuned on 0-29); the
# baselines on scenario 1 (10 episodes). Rows report the motion-feasible share and the
# rejections by cause.
bench-motion: setup
	mkdir -p $(BENCH_DIR)/heldout
	for s in 1 2 3; do \
	  $(TSAD) bench --scenario $$s --planner tsad --feasibility geometric --motion \
	    --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/s$$s-tsad-motion.json || exit 1; \
	  $(TSAD) bench --scenario $$s --planner tsad --feasibility net --motion \
	    --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/s$$s-tsad-net-motion.json || exit 1; \
	  $(TSAD) bench --scenario $$s --planner tsad --feasibility geometric --motion --seed-start 1000 \
	    --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/heldout/s$$s-tsad-motion.json || exit 1; done
	for p in gp3 rots rots-star; do \
	  $(TSAD) bench --scenario 1 --planner $$p --feasibility geometric --motion --episodes 10 \
	    --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/s1-$$p-motion.json || exit 1; done
	$(MAKE) report

# The wide shelf (scenario `wide`: 0.75 x 0.36 m, a 5 x 9 grid, 3-9 objects, the target hidden in
# the front view) on held-out seeds 1000-1029, ideal sensing: TSAD in both variants on the network
# and on the geometric model, the baselines and `optimal`; then TSAD on the network as a robot
# senses (realistic depth, eight frames, `cluster`). About 20 minutes on 2 cores.
bench-wide: setup
	mkdir -p $(BENCH_DIR)/heldout
	for v in full paper; do for f in net geometric; do \
	  $(TSAD) bench --scenario wide --planner tsad --variant $$v --feasibility $$f --episodes 30 \
	    --seed-start 1000 --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/heldout/wide-tsad-$$v-$$f.json || exit 1; done; done
	for p in gp3 rots rots-star rots-star-search; do \
	  $(TSAD) bench --scenario wide --planner $$p --feasibility geometric --episodes 30 \
	    --seed-start 1000 --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/heldout/wide-$$p.json \
	    || exit 1; done
	$(TSAD) bench --scenario wide --planner optimal --episodes 30 --seed-start 1000 \
	  --workers $(BENCH_WORKERS) --out $(BENCH_DIR)/heldout/wide-optimal.json
	$(TSAD) bench --scenario wide --planner tsad --sensor realistic --segmentation cluster \
	  --set sensor.frames=8 --episodes 30 --seed-start 1000 --workers $(BENCH_WORKERS) \
	  --out $(BENCH_DIR)/heldout/wide-tsad-net-realistic-frames8.json

# Table I executed in the physics world: every pick-and-place a Drake contact simulation, the next
# view observed from the simulated state (TSAD, GP3, ROTS, ROTS* on scenarios 1-3, 30 episodes,
# about 25 s per episode on one core).
bench-physics: setup
	mkdir -p $(BENCH_DIR)
	for p in tsad gp3 rots-star rots; do for s in 1 2 3; do \
	  $(TSAD) bench --scenario $$s --planner $$p --feasibility geometric --world physics \
	    --episodes $(BENCH_EPISODES) --workers $(BENCH_WORKERS) \
	    --out $(BENCH_DIR)/s$$s-$$p-physics.json || exit 1; done; done

# Success against depth-noise level (0, 1, 2, 4 mm; cluster segmentation; scenario 2, held-out
# seeds 2000-2014) for TSAD and ROTS*: a sweep per planner, results/noise/<planner>/sweep.md.
bench-noise: setup
	for p in tsad rots_star; do \
	  $(TSAD) sweep examples/grids/noise_curve_$$p.yaml --workers $(BENCH_WORKERS) \
	    --out results/noise/$$p || exit 1; done

# The network weights for realistic sensing (tsad_drake/data/prehensile_net_realistic.pt): the
# shipped weights fine-tuned on scenes observed with the realistic depth sensor and cluster
# segmentation, one depth frame per view (400 scenes, two processes: about 12 minutes; training
# about 9 minutes).
NET_DATA_REALISTIC ?= out/data-realistic
net-realistic: setup
	$(TSAD) dataset --scenes 200 --seed-start 0 --sensor realistic --frames 1 --segmentation cluster --out $(NET_DATA_REALISTIC) & \
	  $(TSAD) dataset --scenes 200 --seed-start 200 --sensor realistic --frames 1 --segmentation cluster --out $(NET_DATA_REALISTIC); wait
	$(TSAD) train --data $(NET_DATA_REALISTIC) --out tsad_drake/data/prehensile_net_realistic.pt \
	  --init tsad_drake/data/prehensile_net.pt --epochs 10 --lr 5e-4 --sensor realistic --frames 1 \
	  --segmentation cluster --threads 1

# Two pages: the paper's tables (seeds 0-29/0-99) and the held-out seeds 1000-1029 (realistic
# sensing beside ideal: `make bench-frames`, `make bench-motion`).
report: setup
	$(TSAD) report $(wildcard $(BENCH_DIR)/*.json results/physics/*.json results/perception/*.json) \
	  --out results/RESULTS.md
	$(TSAD) report $(wildcard $(BENCH_DIR)/heldout/*.json) --out results/HELDOUT.md

# Planning time and iterations against objects (3-15) and the grid (24-60 cells, shelves
# 0.50-0.80 m) for TSAD (geometric, network), the baselines and optimal: table and plot in
# results/cost_curves (docs/benchmark.md quotes them). Resumes where it stopped.
cost-curves: setup
	$(PY) -m studies.cost_curves --out results/cost_curves

lint: setup
	$(VENV)/bin/ruff check tsad_drake tests examples tools studies

clean:
	rm -rf out .pytest_cache
