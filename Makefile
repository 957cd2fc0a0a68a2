# The two set-up commands of the README. Each creates .venv inside the repo on first use.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: fly test bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

## fly: set up, then fly (with no display: record a scripted demo flight and say so)
fly: $(STAMP)
	$(PY) main.py fly

## test: set up, then run the whole test suite headless
test: $(STAMP)
	SDL_VIDEODRIVER=dummy SDL_AUDIODRIVER=dummy $(PY) -m pytest

bench: $(STAMP)
	$(PY) main.py bench

clean:
	rm -rf $(VENV) build *.egg-info
