# Quick start: `make bench` (runs the paper suite, writes results/) and `make test`.
# Both create .venv with $(PYTHON) (>= 3.10) if it is missing and install diffbench into it.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.diffbench-installed
SEEDS ?= 20

.PHONY: bench bench-suite studies timing test test-kernels docs lint check-install clean-venv

$(STAMP): pyproject.toml constraints.txt
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 10) else "diffbench needs Python >= 3.10; set PYTHON=python3.x")'
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[test,peers,data,dask,docs]'
	touch $(STAMP)

# `make bench`, the paper suite: the paper signal (every native method and the fast peers at
# their presets, the native methods oracle-tuned for ẋ and ẍ), table I, the paper's figures
# and the simulated robot, into results/ (its store: results/store/).
# `make studies`, the long studies, into results/studies/ (their own store): every peer and
# every tuning criterion on the paper signals (10-seed and whole-record tunings too), the
# real robot, the online track, the scenario grid and the data-only recommendation checked on
# every scenario; the limit study (every method's efficiency against the least possible error
# on random signals with known spectra). `make timing`: throughput, peak memory and the speed ratios against the peers
# (results/timing/). Every step resumes from its store: a rerun recomputes and re-tunes
# nothing and only rewrites the reports.
# The steps of `make studies` are listed, with why each is there, in bench/studies/steps.py
# (`diffbench studies` runs them, each step its own diffbench process, and writes each step's
# wall time to results/timing/studies.md). The grid and the paper-signal peers are the fast
# ones (a call costs milliseconds); the paper signal's bench peers:
GRID_PEERS := pynumdiff.spectraldiff,pynumdiff.butterdiff,pynumdiff.savgoldiff,pynumdiff.kerneldiff,derivative.spectral
STUDIES := results/studies

bench: $(STAMP)
	@$(MAKE) --no-print-directory bench-suite

# the suite alone, by the diffbench in $(BIN), into $(BENCH_OUT): what tests/bench/
# test_reproducible_results.py runs under two other BLAS kernels to find the tracked files the same.
# The paper signal's report is written once, by its tuning (the first command only stores)
BENCH_OUT ?= results
bench-suite:
	$(BIN)/diffbench run paper-signal --methods native,$(GRID_PEERS) --seeds $(SEEDS) --jobs 2 \
	  --no-report --out $(BENCH_OUT)
	$(BIN)/diffbench tune native paper-signal --criteria oracle --orders 1,2 --seeds $(SEEDS) \
	  --jobs 2 --out $(BENCH_OUT)
	$(BIN)/diffbench run jacobi-influence --seeds $(SEEDS) --out $(BENCH_OUT)
	$(BIN)/diffbench run paper-figures --methods native,$(GRID_PEERS) --jobs 2 --out $(BENCH_OUT)
	$(BIN)/diffbench run robot-sim --methods native,$(GRID_PEERS) --seeds $(SEEDS) --jobs 2 \
	  --out $(BENCH_OUT)

studies: $(STAMP)
	$(BIN)/diffbench studies --seeds $(SEEDS) --jobs 2 --out $(STUDIES)

timing: $(STAMP)
	$(BIN)/diffbench timing --out results

# the documentation site (mkdocs.yml), into build/site/; strict: any warning (a broken link, a
# missing included file) fails it. Its methods reference and results pages are generated
# (bench/report/docs_site.py), so it needs the installed package.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

# one formatting for the whole tree: ruff's, with no line exempted from it
lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	@! grep -rnE --include='*.py' 'fmt: *(skip|off)' bench methods signals tests \
	  || { echo "lint: remove the formatter exemptions above (ruff format decides)"; exit 1; }

# two worker processes (pytest-xdist); the suite's wall time is measured, not typed here:
# see the note of the last session. The paper suite under other BLAS kernels (marker
# `kernels`, about 200 CPU-s) runs in test-kernels, which CI runs after this.
test: lint
	$(BIN)/python -m pytest -q -n 2 --benchmark-disable -m "not kernels"

# the numerical suites under OpenBLAS's Haswell kernel (a CPU without AVX-512) and Sandybridge
# kernel (AVX): every tolerance must come from the computation, not from one kernel's last bits;
# then make bench's paper suite under both, which must write the committed files byte for byte
KERNELS ?= Haswell Sandybridge
NUMERICAL_SUITES ?= tests/methods tests/signals
test-kernels: $(STAMP)
	for kernel in $(KERNELS); do \
	  echo "OPENBLAS_CORETYPE=$$kernel"; \
	  OPENBLAS_CORETYPE=$$kernel $(BIN)/python -m pytest -q -n 2 --benchmark-disable \
	    -p no:cacheprovider $(NUMERICAL_SUITES) || exit 1; \
	done
	$(BIN)/python -m pytest -q -n 2 --benchmark-disable -p no:cacheprovider -m kernels

# pip install . beside PyPI's `bench` 2.8 and `signals` 0.0.2 (same top-level names as our
# folders), then `diffbench list` and the tests against that installation.
CLASH_VENV ?= $(VENV)-clash
check-install:
	rm -rf $(CLASH_VENV)
	$(PYTHON) -m venv $(CLASH_VENV)
	$(CLASH_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(CLASH_VENV)/bin/python -m pip install --quiet 'bench==2.8' 'signals==0.0.2'
	$(CLASH_VENV)/bin/python -m pip install --quiet -c constraints.txt '.[test,peers,data,dask,docs]'
	$(CLASH_VENV)/bin/diffbench list > /dev/null
	$(CLASH_VENV)/bin/python -c 'import diffbench.signals, signals; assert signals.__file__ != diffbench.signals.__file__'
	$(CLASH_VENV)/bin/python -m pytest -q -n 2 --benchmark-disable -p no:cacheprovider \
	  -m "not kernels"

clean-venv:
	rm -rf $(VENV)
