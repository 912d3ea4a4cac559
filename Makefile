# Two entry points: `make run` (derive the Puma 560, generate its code, print a
# summary) and `make test` (the whole suite).  Both set up .venv on first use.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test test-all test-torch generate bench docs docs-check release-check clean

$(STAMP): pyproject.toml Makefile
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,plot]'
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/symdyn run

test: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist worksteal

# Everything but the torch tests: the main suite and the cases marked slow (real robots from
# example-robot-data, optimal control around obstacles, the cases cut for time before).
test-all: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist worksteal -m 'not torch'

# PyTorch's default wheel is large (~0.5 GB, with its CUDA libraries ~5 GB, 77 s to install here):
# its tests have their own target, run after the main suite.  A CPU-only machine can install
# the CPU wheel first (pip install torch --index-url https://download.pytorch.org/whl/cpu).
$(VENV)/.torch-installed: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[torch]'
	touch $@

test-torch: $(VENV)/.torch-installed
	$(BIN)/python -m pytest -q -p no:xdist -m torch tests/test_torch.py

generate: $(STAMP)
	$(BIN)/symdyn generate --all

# The bench extra (Pinocchio's wheel with its C++ headers, Eigen's headers, the Robotics
# Toolbox); `symdyn bench` builds the Pinocchio C++ peer once into the cache, then times.
# Options through BENCH_ARGS, e.g. make bench BENCH_ARGS="--markdown bench.md".
$(VENV)/.bench-installed: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[bench]'
	touch $@

bench: $(VENV)/.bench-installed
	$(BIN)/symdyn bench $(BENCH_ARGS)

# The documentation site (mkdocs.yml, pages under docs/) into site/, strict: a warning, a broken
# link or a missing reference fails.  The shipped arms' equations are printed during the build
# (docs/_hooks/equations.py, one process per core: the build takes ~2 min on 2 cores;
# SYMDYN_DOCS_ARMS=twolink renders one arm, ~10 s).  docs-check then checks the built site
# (tests/test_site.py: reference anchors, and in
# a headless Chromium, where installed, the rendered equations and the figures) and runs every
# page's examples, the slow ones included.
$(VENV)/.docs-installed: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[docs]'
	touch $@

docs: $(VENV)/.docs-installed
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

$(VENV)/.browser-installed: $(VENV)/.docs-installed
	$(BIN)/python -m pip install --quiet -e '.[docs,browser]'
	touch $@

docs-check: docs $(VENV)/.browser-installed
	SYMDYN_SITE=site SYMDYN_SLOW_DOCS=1 $(BIN)/python -m pytest -q -p no:xdist tests/test_docs.py tests/test_site.py

# The release from HEAD: sdist and wheel by python -m build, twine check, and the sdist's wheel
# the same as the tree's (scripts/release_check.py, ~15 s).
$(VENV)/.release-installed: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[release]'
	touch $@

release-check: $(VENV)/.release-installed
	$(BIN)/python scripts/release_check.py

clean:
	rm -rf $(VENV) build *.egg-info site site-check
