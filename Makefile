# Quick start (fresh machine with python3, pip, gcc, make):
#   make run    create .venv, install postcapture, run the main job on the embedded Envisat scenario
#   make test   create .venv, install postcapture with its test and optional extras, run the test suite
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip
OUT ?= results

.PHONY: run test test-slow test-all bench lint clean

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

$(VENV)/.run-stamp: pyproject.toml | $(VENV)/bin/python
	$(PIP) install --quiet -e .
	@touch $@

$(VENV)/.test-stamp: pyproject.toml | $(VENV)/bin/python
	@# cfchecker (test extra) loads the system's UDUNITS-2 library: install it where it is missing (Debian)
	@ldconfig -p | grep -q libudunits2 || { apt-get update -qq && apt-get install -y -qq libudunits2-0; }
	$(PIP) install --quiet -e ".[all,test]"
	@touch $@ $(VENV)/.run-stamp

run: $(VENV)/.run-stamp
	$(VENV)/bin/postcapture run --out $(OUT)

test: $(VENV)/.test-stamp
	$(PY) -m pytest -q
	$(VENV)/bin/lint-imports

test-slow: $(VENV)/.test-stamp
	$(PY) -m pytest -q -m slow

test-all: $(VENV)/.test-stamp
	$(PY) -m pytest -q -m "slow or not slow"

bench: $(VENV)/.run-stamp
	$(VENV)/bin/postcapture bench

clean:
	rm -rf $(VENV) build *.egg-info src/*.egg-info .pytest_cache $(OUT)
