# Two commands do all set-up on a fresh machine:
#   make demo   simulate the gallery's demo systems, write plots and a report to out/demo
#   make test   lint (ruff), type check (mypy), the layers (import-linter) and the whole
#               test suite (unit, doctests, validation)
#   make bench  the benchmark suite against SymPy, MuJoCo and Exudyn (JSON + PNG in bench/results)
#   make bench-quick  the same at small n with short caps (under 5 minutes)
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint bench bench-quick clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/dalembert demo --out out/demo

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/lint-imports --no-cache

# the suite on every core (pytest-xdist): each test file's tests run in one worker
test: lint
	$(BIN)/python -m pytest -n auto --dist loadfile

BENCH_STAMP := $(VENV)/.bench-installed

$(BENCH_STAMP): $(STAMP)
	$(BIN)/pip install --quiet -e '.[dev,bench]'
	touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)
	$(BIN)/python bench/suite.py
	$(BIN)/python bench/plot.py bench/results/suite.json

bench-quick: $(BENCH_STAMP)
	$(BIN)/python bench/suite.py --quick --out bench/results/suite_quick.json
	$(BIN)/python bench/plot.py bench/results/suite_quick.json

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
