# The two commands of the README: `make run` (the main job) and `make test` (the whole suite).
# Both create .venv when needed and install the project with everything it needs.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)

.PHONY: run test test-fast lint format bench docs clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/pip install --quiet -e ".[all]"
	$(BIN)/pip install --quiet --no-deps "asam-qc-opendrive==1.0.0"  # pins numpy<2: see pyproject
	rm -f $(VENV)/.installed-*
	touch $@

run: $(STAMP)
	$(BIN)/acc-fusion sumo --net motorway --end 300 --out results/make_run

test: $(STAMP)
	$(BIN)/ruff check acc_fusion scripts tests examples docs/gen
	$(BIN)/ruff format --check acc_fusion scripts tests examples docs/gen
	$(BIN)/lint-imports
	DISABLE_MKDOCS_2_WARNING=true NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet
	$(BIN)/pytest -q -n 2 --dist loadgroup

test-fast: $(STAMP)
	$(BIN)/pytest -q -n 2 --dist loadgroup -m "not slow"

lint: $(STAMP)
	$(BIN)/ruff check acc_fusion scripts tests examples docs/gen
	$(BIN)/lint-imports

format: $(STAMP)
	$(BIN)/ruff format acc_fusion scripts tests examples docs/gen
	$(BIN)/ruff check --fix acc_fusion scripts tests examples docs/gen

bench: $(STAMP)
	$(BIN)/python scripts/bench_all.py

docs: $(STAMP)
	DISABLE_MKDOCS_2_WARNING=true NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs serve

clean:
	rm -rf $(VENV) build dist *.egg-info .pytest_cache .ruff_cache site
