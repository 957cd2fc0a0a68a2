# The two set-up commands of the README. Each creates .venv inside the repo on first use.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: fly test lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

## fly: set up, then fly (with no display: record a scripted demo flight and say so)
fly: $(STAMP)
	$(PY) main.py fly

## lint: ruff (lint, import order, formatting) and mypy on the package
lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy

## test: set up, lint, then run the whole test suite headless
test: lint
	SDL_VIDEODRIVER=dummy SDL_AUDIODRIVER=dummy $(PY) -m pytest

bench: $(STAMP)
	$(PY) main.py bench

clean:
	rm -rf $(VENV) build *.egg-info
