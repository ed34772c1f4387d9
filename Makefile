# Each target creates .venv if it is missing, so a fresh clone needs nothing but python3.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
TSTAMP := $(VENV)/.installed-test
DSTAMP := $(VENV)/.installed-docs

.PHONY: demo test bench results apidocs lint clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(TSTAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test,rl,dask,pyomo]"
	touch $(STAMP) $@

$(DSTAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[docs,rl]"
	touch $(STAMP) $@

demo: $(STAMP)
	$(BIN)/voiopt demo

test: $(TSTAMP)
	$(BIN)/python -m pytest -n 2

bench: $(TSTAMP)
	$(BIN)/python benchmarks/run_all.py

# Every benchmark that backs a number in the docs, at its full setting, each writing
# docs/results/<name>.md: several hours (docs/reproduce.md).
results: $(TSTAMP)
	$(BIN)/python benchmarks/run_all.py --results

# The API reference from the public docstrings, as HTML in build/api/ (open build/api/index.html).
# Every sub-package and root module is named: voiopt's __all__ alone would hide them.
API_MODULES := voiopt $(patsubst %/__init__.py,%,$(wildcard voiopt/*/__init__.py)) \
	$(filter-out voiopt/__init__.py voiopt/__main__.py,$(wildcard voiopt/*.py))
apidocs: $(DSTAMP)
	rm -rf build/api
	$(BIN)/python -m pdoc --docformat markdown -o build/api $(API_MODULES)

lint: $(TSTAMP)
	$(BIN)/ruff check voiopt tests benchmarks

clean:
	rm -rf $(VENV) build *.egg-info
