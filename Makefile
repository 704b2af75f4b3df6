# loadarm: two commands on a fresh machine with only Python 3.11+:
#   make demo   -> bootstrap .venv, run the paper's case end to end, report in out/
#   make test   -> bootstrap .venv, run the test suite (slow tests too with SLOW=1; CI runs them all)
# Installs take their versions from requirements.lock (refreshed on purpose with `make lock`).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
LOCK   := requirements.lock
UV     := uv==0.13.9
STAMP  := $(VENV)/.installed-test
BSTAMP := $(VENV)/.installed-bench
DSTAMP := $(VENV)/.installed-docs
PYTEST_MARK := $(if $(SLOW),-m "not realtime",-m "not slow")
# Tests that time real processes against the wall clock (OPC UA load, PLC link loss, hardware in the loop) run
# after the rest, one at a time: beside another worker on a 2-core machine their deadlines measure the neighbour.
REALTIME := $(BIN)/python -m pytest -q -p no:xdist -m realtime

.PHONY: demo test test-all bench docs lock test-latest clean

$(BIN)/python:
	$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "loadarm needs Python 3.11 or newer, found " + sys.version.split()[0])'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# Installing compiles the numba kernels into the cache too (`loadarm warmup`: cold on 2 cores about 37 s, measured
# 2026-12-07), as on a controller after an install; `make test` runs it again (2 s when warm, or after an edit the
# kernels that changed).
$(STAMP): pyproject.toml $(LOCK) | $(BIN)/python
	$(BIN)/python -m pip install --quiet -c $(LOCK) -e '.[test]'
	$(BIN)/loadarm warmup
	touch $(STAMP)

$(BSTAMP): pyproject.toml $(LOCK) $(STAMP)
	$(BIN)/python -m pip install --quiet -c $(LOCK) -e '.[test,bench]'
	touch $(BSTAMP)

demo: $(STAMP)
	$(BIN)/loadarm demo --out out

# The suite spreads over every core (pytest-xdist); idle workers steal queued tests (measured on 2 cores:
# 110 s against 123 s a file to a worker, 197 s against 216 s of CPU): make test stays within two minutes
# (2026-12-07: pytest 95 s, with the properties on 100 examples: the quick profile, tests/conftest.py).
# `loadarm warmup` compiles the numba kernels into the cache once, its families side by side, before the suite
# (cold on 2 cores: 37 s, where each worker compiling them again cost 55 s of the run; warm: 2 s).
test: $(STAMP)
	$(BIN)/loadarm warmup
	HYPOTHESIS_PROFILE=$${HYPOTHESIS_PROFILE:-$(if $(SLOW),ci,quick)} \
	    $(BIN)/python -m pytest -q -n auto --dist worksteal $(PYTEST_MARK)
	$(if $(SLOW),$(REALTIME))

test-all: $(STAMP)
	$(BIN)/loadarm warmup
	$(BIN)/python -m pytest -q -n auto --dist worksteal -m "not realtime"
	$(REALTIME)

bench: $(BSTAMP)
	$(BIN)/python -m pytest benchmarks -q --benchmark-columns=min,median,mean,ops --benchmark-sort=name

# Regenerate every figure in docs/img and the generated blocks of README.md and docs/*.md.
docs: $(STAMP)
	$(BIN)/python -m loadarm.present.docsgen

# Refresh the lock on purpose: newest releases that satisfy pyproject.toml, for every platform and
# Python >= 3.11. Commit the result after `make test-all` passes with it.
lock: | $(BIN)/python
	$(BIN)/python -m pip install --quiet '$(UV)'
	$(BIN)/uv pip compile pyproject.toml --all-extras --universal --python-version 3.11 --upgrade \
	    --quiet -o $(LOCK)
	@echo "wrote $(LOCK); run 'make test-all' before committing it"

# The suite against the newest releases (no lock), in a separate venv; safe to run in CI.
test-latest:
	rm -rf .venv-latest
	$(PYTHON) -m venv .venv-latest
	.venv-latest/bin/python -m pip install --quiet --upgrade pip
	.venv-latest/bin/python -m pip install --quiet --upgrade -e '.[test]'
	.venv-latest/bin/python -m pytest -q -n auto --dist worksteal -p no:cacheprovider -m "not realtime"
	.venv-latest/bin/python -m pytest -q -p no:cacheprovider -p no:xdist -m realtime

clean:
	rm -rf $(VENV) .venv-latest out .pytest_cache
