# Two entry points for a fresh machine with only Python 3.11 and make:
#   make demo   creates .venv, installs, runs the main job end to end
#   make test   creates .venv, installs, runs ruff, mypy and the product's and the lab's tests
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

LOCK := requirements/dev.lock

# The suite on 2 processes (pytest-xdist), each file's tests in one of them (module fixtures made
# once), one BLAS thread each (tests/conftest.py); `pytest -q` alone runs it in one process.
# (Not --dist loadgroup: with the lock's pytest 9.2 and pytest-xdist 3.8 it ignores xdist_group
# marks and spreads every test, pytest-xdist issue 1386.)
PYTEST_PARALLEL := -n 2 --dist loadfile

.PHONY: demo test lint typecheck bench clean lock test-latest fuzz

# The environment is installed from the lock (exact versions, SHA-256 hashes), so a fresh machine
# gets the set CI tested; the package itself goes in editable, without its dependencies, then
# the lab (lab/, its own distribution; it needs nothing beyond the lock).
$(STAMP): pyproject.toml lab/pyproject.toml $(LOCK)
	rm -rf $(VENV)
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --require-hashes -r $(LOCK)
	$(BIN)/python -m pip install --quiet --no-deps -e .
	$(BIN)/python -m pip install --quiet --no-deps -e lab
	touch $(STAMP)

# Refresh the lock after changing pyproject.toml's dependencies (uv is in the lock's dev set).
lock: $(STAMP)
	$(BIN)/uv pip compile pyproject.toml --extra dev --generate-hashes --universal \
		--python-version 3.11 --quiet -o $(LOCK)

# The suite against the newest releases the registry serves (no lock): drift shows here first.
test-latest:
	rm -rf .venv-latest
	$(PYTHON) -m venv .venv-latest
	.venv-latest/bin/python -m pip install --quiet --upgrade -e ".[dev]"
	.venv-latest/bin/python -m pip install --quiet --no-deps -e lab
	.venv-latest/bin/python -m pytest -q $(PYTEST_PARALLEL)

demo: $(STAMP)
	$(BIN)/axiswatch demo

lint: $(STAMP)
	$(BIN)/ruff check src tests lab $(wildcard benchmarks)
	$(BIN)/ruff format --check src tests lab $(wildcard benchmarks)
	$(BIN)/lint-imports --no-cache

typecheck: $(STAMP)
	$(BIN)/mypy

test: lint typecheck
	$(BIN)/python -m pytest -q $(PYTEST_PARALLEL)

# The capture fuzz test with many more examples than `make test` runs (30); the seed is fixed.
FUZZ_EXAMPLES ?= 500
fuzz: $(STAMP)
	AXISWATCH_FUZZ_EXAMPLES=$(FUZZ_EXAMPLES) $(BIN)/python -m pytest -q -n 0 tests/test_monitor_fuzz.py

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

clean:
	rm -rf $(VENV) .venv-latest build dist .pytest_cache .mypy_cache .ruff_cache
