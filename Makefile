# Each target creates .venv if it is missing, so a fresh clone needs nothing but python3.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
TSTAMP := $(VENV)/.installed-test

.PHONY: demo test bench lint clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(TSTAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test,rl,dask,pyomo]"
	touch $(STAMP) $@

demo: $(STAMP)
	$(BIN)/voiopt demo

test: $(TSTAMP)
	$(BIN)/python -m pytest -n 2

bench: $(TSTAMP)
	$(BIN)/python benchmarks/run_all.py

lint: $(TSTAMP)
	$(BIN)/ruff check voiopt tests benchmarks

clean:
	rm -rf $(VENV) build *.egg-info
