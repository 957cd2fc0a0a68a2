# The two set-up commands of the README. Each creates .venv inside the repo on first use.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
# what flying needs (the runtime dependencies), and what the tests need on top (extras, linters)
RUNTIME := $(VENV)/.runtime
STAMP := $(VENV)/.installed

.PHONY: fly test lint bench clean

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

## test: set up, lint, then run the whole test suite headless
test: lint
	SDL_VIDEODRIVER=dummy SDL_AUDIODRIVER=dummy $(PY) -m pytest

bench: $(RUNTIME)
	$(PY) main.py bench

clean:
	rm -rf $(VENV) build *.egg-info
