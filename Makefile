# mcnkit — two commands on a fresh machine:  make demo   |   make test
# Everything installs into .venv from the package registries (torch: the local CPU wheel, pinned).

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
SHARED ?= ../shared/data

export RERUN_ANALYTICS = 0
export MCNKIT_SHARED_DATA = $(abspath $(SHARED))

.PHONY: help venv demo test lint typecheck pytest docs docs-check bench clean browser-check notebooks data

help:
	@echo "make demo   set up .venv and run the demo (simulated apartment: log -> info -> MCN-SLAM -> recordings/demo/demo.rrd)"
	@echo "make test   set up .venv and run ruff, mypy, the strict docs build and pytest (all tests, slow ones included)"
	@echo "make docs   build the documentation site (docs/) and serve it on http://127.0.0.1:$(DOCS_PORT)"
	@echo "make bench  run every benchmark in benchmarks/ in full (figures printed and written as JSON)"
	@echo "make notebooks       run every notebook in full mode (copies with outputs in notebooks/executed/)"
	@echo "make browser-check   JupyterLab + headless Chromium: run notebook 03, save a screenshot"

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -c constraints.txt -e ".[dev]"
	$(VENV)/bin/rerun analytics disable >/dev/null 2>&1 || true
	touch $(STAMP)

venv: $(STAMP)

# HouseExpo into data/ (sha256 checked) from the shared copy; users point --from at their own copy or a URL
HOUSEEXPO := data/houseexpo/json.tar.gz
$(HOUSEEXPO): $(STAMP)
	$(VENV)/bin/mcnkit data install houseexpo --from $(SHARED)/houseexpo/json.tar.gz

data: $(HOUSEEXPO)

demo: $(STAMP)
	$(VENV)/bin/mcnkit demo --overwrite

lint: $(STAMP)
	$(VENV)/bin/ruff check mcnkit tests benchmarks notebooks docs

typecheck: $(STAMP)
	$(VENV)/bin/mypy

pytest: $(STAMP)
	$(PY) -m pytest -q

# the documentation site: guide pages + the API reference generated from the docstrings (Sphinx, offline).
# docs-check rebuilds from scratch (-E) with every warning an error (-W) and mcnkit's references checked (-n).
DOCS_PORT ?= 8000
SPHINX    := $(PY) -m sphinx -q -b html docs docs/_build/html
docs-check: $(STAMP)
	$(SPHINX) -E -W -n --keep-going

docs: $(STAMP)
	$(SPHINX) -n
	@echo "serving docs/_build/html on http://127.0.0.1:$(DOCS_PORT) (Ctrl-C stops)"
	$(PY) -m http.server --bind 127.0.0.1 --directory docs/_build/html $(DOCS_PORT)

test: lint typecheck docs-check data pytest

# every benchmark in benchmarks/, in full (each prints its figures and writes JSON to benchmarks/results/);
# the one-off studies in benchmarks/studies/ are run by hand
BENCHMARKS := bench_io bench_slam bench_sim_slam bench_completion bench_mcn bench_mcn_weighting bench_sampling \
              bench_buildings bench_fuzz bench_interrupts bench_explore
bench: $(STAMP)
	set -e; for b in $(BENCHMARKS); do echo "== benchmarks/$$b.py"; $(PY) -m benchmarks.$$b; done

# every notebook top to bottom in full mode (make test runs them small, in CI mode)
notebooks: $(STAMP)
	$(PY) notebooks/run_notebooks.py

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache docs/_build docs/api/generated

# JupyterLab on 127.0.0.1 in headless Chromium (apt-get install chromium): runs notebook 03, saves a screenshot
browser-check: $(STAMP)
	$(PY) notebooks/browser_check.py notebooks/03_fastslam_step_by_step.ipynb notebooks/screenshots/03_jupyterlab.png
