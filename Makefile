# whale-adapter -- every target installs what it needs first, idempotently (see README.md).
#
#   make run-case   the main job: pimpleFoam coupled to the step-server (SCENE, CASE, NP)
#   make study      the flow study: three meshes (GCI) and the time step (SCENE, STUDY, NP)
#   make test       lint + the whole test suite, OpenFOAM and ParaView included
#   make lint       ruff, then mypy on adapter/ (make typecheck: mypy alone)
#   make test-fast  lint + the tests that need no OpenFOAM, ParaView, chromium or apt (under 90 s)
#   make dry-run    animate without fluid (SCENE, OUT, CYCLES)
#   make bench      performance figures (bench-flow: moving against static flow step; bench-cases: 1/2 ranks,
#                   full/half domain); make chart: the numerics study
#   make paraview   ParaView pictures of the case just run (CASE; DIR=out/dry-run for a dry-run)
#   make validate   the flows with known answers (docs/validation.md; NP, VALIDATION)
#   make mutation   mutation testing of the core modules (MODULES, JOBS; docs/mutation.md)
#   make clean      remove outputs, keep the built plugin (make distclean: the build too)

SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
# a preset name (default, smoke, fine) or a scene TOML file
SCENE ?= default
OUT ?= out/dry-run
CYCLES ?=
NP ?=
CASE ?= runs/$(basename $(notdir $(SCENE)))
STUDY ?= runs/study-$(basename $(notdir $(SCENE)))
VALIDATION ?= out/validation
PYTEST_ARGS ?=
# the fast lane: the tests without a mark for a program from outside Python, nor slow
# (tests/conftest.py; tests/test_fast_lane.py checks the selection)
FAST := not openfoam and not plugin and not paraview and not browser and not slow and not install
# make mutation: the modules to mutate (default: all of pyproject's [tool.whale-adapter.mutation])
MODULES ?=
JOBS ?= 2

scene_args = $(if $(filter %.toml,$(SCENE)),--scene $(SCENE),--preset $(SCENE))

.PHONY: help setup venv system openfoam plugin test test-fast lint typecheck dry-run calibrate run-case study bench bench-flow bench-cases \
        chart paraview paraview-deps chromium-deps mutation validate clean distclean

help:
	@sed -n '1,/^$$/p' Makefile

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	touch $@

venv: $(BIN)/.installed

# off-screen rendering libraries for pyvista (EGL)
system:
	@bash scripts/install_system.sh

openfoam:
	@bash scripts/install_openfoam.sh

plugin: openfoam
	@bash scripts/build_plugin.sh

paraview-deps:
	@bash scripts/install_paraview.sh

# the browser that tests/test_report.py opens report.html in
chromium-deps:
	@bash scripts/install_chromium.sh

# a one-node SLURM cluster on this machine (docs/cluster.md); tests/test_slurm.py runs it itself
.PHONY: slurm
slurm:
	@bash scripts/install_slurm.sh

# compile check of the plugin against another OpenFOAM.com source tree, without linking; not in
# `make test` (a tree is 100 MB): OPENFOAM_TREE=DIR, or OPENFOAM_GIT=GITDIR [OPENFOAM_COMMIT=C]
.PHONY: plugin-check
plugin-check:
	@$(if $(OPENFOAM_TREE)$(OPENFOAM_GIT),,echo "plugin-check: set OPENFOAM_TREE=DIR or OPENFOAM_GIT=GITDIR (docs/openfoam-plugin.md)" >&2; exit 2;) \
	bash scripts/check_plugin_compile.sh $(if $(OPENFOAM_TREE),$(OPENFOAM_TREE),--git $(OPENFOAM_GIT) $(or $(OPENFOAM_COMMIT),HEAD))

setup: venv system openfoam plugin paraview-deps chromium-deps

lint: venv
	$(BIN)/ruff check adapter tests scripts
	$(BIN)/mypy

# mypy on adapter/ (pyproject's [tool.mypy]), as make lint runs it
typecheck: venv
	$(BIN)/mypy

test: setup lint
	$(BIN)/pytest -ra $(PYTEST_ARGS)

# no apt: the Python packages alone
test-fast: lint
	$(BIN)/pytest -ra -m "$(FAST)" $(PYTEST_ARGS)

dry-run: venv system
	$(BIN)/whale-adapter dry-run $(scene_args) --out $(OUT) $(if $(CYCLES),--cycles $(CYCLES))

calibrate: venv
	$(BIN)/whale-adapter calibrate $(scene_args)

run-case: venv system openfoam plugin
	$(BIN)/whale-adapter run-case $(scene_args) --case $(CASE) $(if $(NP),--np $(NP))

# about half an hour on 2 cores for the default (docs/case.md, "The flow study"); run again to continue a stopped study
study: venv system openfoam plugin
	$(BIN)/whale-adapter study $(scene_args) --out $(STUDY) $(if $(NP),--np $(NP))

# at most 30 minutes on 2 cores (docs/validation.md)
validate: venv system openfoam plugin
	$(BIN)/whale-adapter validate --out $(VALIDATION) $(if $(NP),--np $(NP))

bench: venv
	$(BIN)/python scripts/bench.py

# make bench-flow: a moving-mesh flow step against a static one, side by side, from a written
# time of a coupled case that has run (CASE, default runs/default from make run-case)
bench-flow: venv
	$(BIN)/python scripts/bench_flow.py $(if $(CASE),--case $(CASE))

# make bench-cases: the scene's coupled case on 1 and 2 ranks, full and half domain, side by
# side: wall time per stroke cycle and the coupling's share (SCENE; WRITES write intervals, 2)
WRITES ?= 2
bench-cases: venv system openfoam plugin
	$(BIN)/python scripts/bench_cases.py $(scene_args) --writes $(WRITES)

chart: venv
	$(BIN)/whale-adapter numerics --out out/numerics

# make paraview: the case just run (CASE, default runs/<scene> as make run-case); DIR=... any
# case or dry-run folder; OUT=... given alone, the dry-run that make dry-run OUT=... wrote
paraview_dir = $(or $(DIR),$(if $(and $(filter file,$(origin CASE)),$(filter command line,$(origin OUT))),$(OUT),$(CASE)))

paraview: venv paraview-deps
	$(BIN)/whale-adapter paraview $(paraview_dir)

mutation: venv
	$(BIN)/python scripts/mutation.py --jobs $(JOBS) $(MODULES)

# keeps the built plugin (build/lib) and Debian's source package it is built from
# (build/openfoam-src, 134 MB to fetch again); make distclean removes those too
clean:
	rm -rf out .pytest_cache build/plugin-src build/plugin-build.log

distclean: clean
	rm -rf build
