# loadarm: two commands on a fresh machine with only Python 3.11+:
#   make demo   -> bootstrap .venv, run the paper's case end to end, report in out/
#   make test   -> bootstrap .venv, run the whole test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-test
BSTAMP := $(VENV)/.installed-bench

.PHONY: demo test bench clean

$(BIN)/python:
	$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "loadarm needs Python 3.11 or newer, found " + sys.version.split()[0])'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

$(BSTAMP): pyproject.toml $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[test,bench]'
	touch $(BSTAMP)

demo: $(STAMP)
	$(BIN)/loadarm demo --out out

test: $(STAMP)
	$(BIN)/python -m pytest -q

bench: $(BSTAMP)
	$(BIN)/python -m pytest benchmarks -q --benchmark-columns=min,median,mean,ops --benchmark-sort=name

clean:
	rm -rf $(VENV) out .pytest_cache
