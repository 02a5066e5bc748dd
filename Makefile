# The two entry points of the README: `make demo` and `make test`. Each builds the virtual
# environment from nothing on first use (pyproject.toml is the only list of dependencies).
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.stewart-jax-installed

# Demo size: trials of the Table 2 study (Wang et al. 2018) per method (a few minutes on 2 cores).
# The methods: every registered calibration method (`--methods all` reads the registry).
DEMO_TRIALS ?= 10
DEMO_BUDGET ?= 50000
DEMO_METHODS ?= all

.PHONY: venv demo test test-all durations lint docs bench bench-deps clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(BIN)/stewart-jax study --methods $(DEMO_METHODS) --trials $(DEMO_TRIALS) --max-evaluations $(DEMO_BUDGET)

# Two workers, one test file each (module fixtures and compilations stay shared within a file),
# the slowest files first (the seconds recorded in tests/durations.json; `make durations` runs the
# whole suite and records them again). Most of the suite's time is XLA compiling small programs,
# so the tests compile with LLVM's -O0 (XLA's own HLO optimisations, fusion included, are
# unchanged): 20-30 % less time per file. The tests run without the persistent compilation cache
# (STEWART_JAX_CACHE_DIR=off unless set). Benchmarks and the demo compile with the defaults. A
# worker that dies ends the run at once (--max-worker-restart=0): pytest-xdist 3 could wait
# forever to reschedule a dead worker's file.
#
# `make test` leaves out the tests marked `slow` (statistical rates over many seeds, whole
# studies and diagnoses end to end, the documentation build): it is the tier CI runs, about
# 9½ minutes on 2 cores. `make test-all` runs every test (about 37 minutes on 2 cores).
PYTEST_RUN = STEWART_JAX_CACHE_DIR="$${STEWART_JAX_CACHE_DIR:-off}" \
	XLA_FLAGS="--xla_backend_optimization_level=0 $$XLA_FLAGS" $(BIN)/python -m pytest -q -n 2 --dist loadfile --max-worker-restart=0

test: $(STAMP)
	$(PYTEST_RUN) -m "not slow" --durations=15

test-all: $(STAMP)
	$(PYTEST_RUN) --durations=15

durations: $(STAMP)
	$(PYTEST_RUN) --record-durations

lint: $(STAMP)
	$(BIN)/ruff check stewart_jax tests benchmarks

# The documentation site in site/: mkdocs-material, the API reference from the docstrings, the
# notebooks executed in quick mode. --strict: a broken link, a missing API object or a failing
# notebook fails the build.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

bench-deps: $(STAMP)
	$(BIN)/python -m pip install --quiet pandas requests Pillow moordyn
	$(BIN)/python -m pip install --quiet --no-deps mealpy==3.0.3 opfunu
	$(BIN)/python -m pip install --quiet coco-experiment cocopp six cma pyswarms

bench: bench-deps
	$(BIN)/python benchmarks/kinematics.py
	$(BIN)/python benchmarks/optimisers.py
	$(BIN)/python benchmarks/table2.py
	$(BIN)/python benchmarks/comparison.py
	$(BIN)/python benchmarks/fast.py
	$(BIN)/python benchmarks/fast_moordyn.py
	$(BIN)/python benchmarks/discrepancy.py
	$(BIN)/python benchmarks/identifiability.py
	$(BIN)/python benchmarks/sharding.py
	$(BIN)/python benchmarks/tracker_points.py
	$(BIN)/python benchmarks/tracker_points.py --timing
	$(BIN)/python benchmarks/bbob.py
	$(BIN)/python benchmarks/cma_vs_pycma.py

clean:
	rm -rf $(VENV) build site *.egg-info
