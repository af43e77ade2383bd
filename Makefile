# Quick start: `make bench` (runs the paper-signal benchmark, writes results/) and `make test`.
# Both create .venv with $(PYTHON) (>= 3.10) if it is missing and install diffbench into it.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.diffbench-installed
SEEDS ?= 20

.PHONY: bench test lint clean-venv

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 10) else "diffbench needs Python >= 3.10; set PYTHON=python3.x")'
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

bench: $(STAMP)
	$(BIN)/diffbench run paper-signal --seeds $(SEEDS) --out results
	for criterion in oracle no-truth pynumdiff; do for order in 1 2; do \
	  $(BIN)/diffbench tune all paper-signal --$$criterion --order $$order --seeds $(SEEDS) \
	    --out results --no-progress || exit 1; done; done
	$(BIN)/diffbench paper-figures --seeds $(SEEDS) --out results
	$(BIN)/diffbench identify sim --seeds $(SEEDS) --out results
	$(BIN)/diffbench identify dfki --out results
	$(BIN)/diffbench grid --seeds 10 --jobs 2 --out results --no-progress
	$(BIN)/diffbench timing --out results

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

test: lint
	$(BIN)/python -m pytest -q --benchmark-disable

clean-venv:
	rm -rf $(VENV)
