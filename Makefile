# The two set-up commands of the README. Each creates .venv inside the repo on first use.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
# what flying needs (the runtime dependencies), and what the tests need on top (extras, linters)
RUNTIME := $(VENV)/.runtime
STAMP := $(VENV)/.installed

.PHONY: fly test test-fast lint docs docs-serve bench clean

$(PY):
	$(PYTHON) -m venv $(VENV)

$(RUNTIME): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e .
	touch $(RUNTIME)

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP) $(RUNTIME)

## fly: set up the runtime only, then fly (with no display: record a scripted demo flight and say so)
fly: $(RUNTIME)
	$(PY) main.py fly

## lint: ruff (lint, import order, formatting) and mypy on the package
lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy

## docs: build the documentation site into site/ (a broken link or a page missing from the nav fails)
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --quiet

docs-serve: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs serve

## test: set up, lint, build the docs, then run the whole test suite headless: in parallel on one
## worker more than the cores (one test at a time, the longest first: tests/helpers/scheduling.py;
## -n auto's count: tests/conftest.py), then the tests that
## need the machine to themselves one after another (tests/conftest.py); both parts run, and a
## failure in either fails
HEADLESS := SDL_VIDEODRIVER=dummy SDL_AUDIODRIVER=dummy
test: lint docs
	@status=0; \
	$(HEADLESS) $(PY) -m pytest -n auto -m "not whole_machine" || status=1; \
	$(HEADLESS) $(PY) -m pytest -m whole_machine || status=1; \
	exit $$status

## test-fast: the unit and integration tests alone (tests/unit/, tests/integration/, the shipped
## recordings), in parallel (as test's), then their few that need the machine to themselves; no
## lint, no docs, no end-to-end tests (tests/e2e/: `make test` runs those)
test-fast: $(STAMP)
	@status=0; \
	$(HEADLESS) $(PY) -m pytest -n auto -m "(unit or integration) and not whole_machine" || status=1; \
	$(HEADLESS) $(PY) -m pytest -m "(unit or integration) and whole_machine" || status=1; \
	exit $$status

bench: $(RUNTIME)
	$(PY) main.py bench

clean:
	rm -rf $(VENV) build site *.egg-info
