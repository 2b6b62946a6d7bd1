# Two commands do all set-up on a fresh machine:
#   make demo   simulate the gallery's demo systems, write plots and a report to out/demo
#   make test   lint (ruff), type check (mypy), the layers (import-linter) and the whole
#               test suite (unit, doctests, validation); installs Debian's chromium for
#               the 3D viewer's browser tests when it is missing
#   make viewer-asset  rebuild dalembert/plotting/viewer/viewer.js (three.js bundled by
#               esbuild, versions pinned in viewer/package-lock.json; needs node and npm)
#   make bench  the benchmark suite against SymPy, MuJoCo and Exudyn (JSON + PNG in bench/results)
#   make bench-quick  the same at small n with short caps (under 5 minutes)
#   make soak   ten million steps of a 16-link chain in C: flat memory, residuals (about
#               10 minutes; fails if either drifts; not in CI)
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

CHROMIUM := /usr/bin/chromium

.PHONY: demo test lint bench bench-quick soak clean viewer-asset

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

# the 3D viewer's browser tests drive Debian's chromium through Playwright (Playwright's
# own browser download is not used): install it when missing, or stop saying why
$(CHROMIUM):
	DEBIAN_FRONTEND=noninteractive apt-get install -y chromium || \
	  (apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y chromium) || \
	  { echo "make test: the 3D viewer's browser tests need Debian's chromium at" \
	         "$(CHROMIUM); install it (apt-get install -y chromium, as root)" >&2; exit 1; }

# the suite on every core (pytest-xdist): each test file's tests run in one worker
test: lint $(CHROMIUM)
	$(BIN)/python -m pytest -n auto --dist loadfile

viewer-asset:
	viewer/build.sh

BENCH_STAMP := $(VENV)/.bench-installed

$(BENCH_STAMP): $(STAMP)
	$(BIN)/pip install --quiet -e '.[dev,bench]'
	touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)
	$(BIN)/python bench/suite.py
	$(BIN)/python bench/plot.py bench/results/suite.json

soak: $(STAMP)
	$(BIN)/python bench/soak.py

bench-quick: $(BENCH_STAMP)
	$(BIN)/python bench/suite.py --quick --out bench/results/suite_quick.json
	$(BIN)/python bench/plot.py bench/results/suite_quick.json

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
