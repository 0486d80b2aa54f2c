# Two commands set everything up on a fresh machine with only Python 3.11 + pip:
#   make demo   - venv, install, run the reference mission on the simulator, log + plots
#   make test   - venv, install with test extras, run the whole suite (the realtime-marked tests alone, after the others)
#   make test-fast - the same without the slow, protocol-peer and viewer tests (under a minute)
#   make check     - ruff (lint, format), mypy and the import contracts (run by .ci/run before the tests)
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
RUNS   ?= runs
# our packages (pyproject.toml's [tool.setuptools.packages.find] include)
PACKAGES := kcl hal sim_backend mission behaviours maris_common vision

.PHONY: demo check test test-fast bench install install-test install-bench viewer clean

# The Foxglove viewer used by tests/viewer (Chromium + Foxglove Studio 1.48 web app);
# without it those tests are skipped with the reason. Needs root (apt) and npm.
VIEWER_TOOL ?= ../shared/tools/mcap-viewer
VIEWER_APP  ?= /opt/foxglove-studio-web

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

$(VENV)/.installed: $(PY) pyproject.toml
	$(PIP) install --quiet -e .
	@# bytecode of our own modules now: where PYTHONDONTWRITEBYTECODE is set (many Docker
	@# images, CI), every process would otherwise compile ~115 of them from source at start
	$(PY) -m compileall -q $(PACKAGES)
	@echo "compiling the KCL kernels (once per machine, then cached)..."
	$(PY) -m kcl.warmup
	$(PY) -m sim_backend.warmup
	touch $@

$(VENV)/.installed-test: $(VENV)/.installed
	$(PIP) install --quiet -e '.[test]'
	touch $@

$(VENV)/.installed-bench: $(VENV)/.installed
	$(PIP) install --quiet -e '.[bench]'
	touch $@

install: $(VENV)/.installed
install-test: $(VENV)/.installed-test
install-bench: $(VENV)/.installed-bench

demo: install
	@mkdir -p $(RUNS)
	$(VENV)/bin/maris sim missions/maris_pipe_recovery.yaml --seed 1 --log $(RUNS)/demo.mcap
	$(VENV)/bin/maris log plot $(RUNS)/demo.mcap --out $(RUNS)/demo_plots

# the whole suite in two parts: the tests that do not depend on wall-clock timing on
# TEST_WORKERS processes (pytest-xdist), then the `realtime` ones alone, one at a time
# (pyproject.toml's markers); both parts always run, and either failing fails the target
TEST_WORKERS ?= 2
test: install-test
	@status=0; \
	$(PY) -m pytest -q -n $(TEST_WORKERS) -m "not realtime" || status=$$?; \
	$(PY) -m pytest -q -m realtime || status=$$?; \
	exit $$status

# the habits that run themselves: lint and format (ruff), types (mypy), the import contracts
check: install-test
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports

# pytest markers (pyproject.toml): slow (whole dry runs, campaigns, long peer sessions),
# peer (a protocol peer in another process), viewer (Foxglove Studio in Chromium), realtime
# (a verdict by wall-clock timing). test-fast leaves out slow, peer and viewer and runs the
# rest in one pytest run on TEST_WORKERS processes: the realtime ones left (drivers' unit
# tests, short timeouts) one after another on one of them (their xdist group,
# tests/conftest.py), the others shared out
test-fast: install-test
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadgroup -m "not slow and not peer and not viewer"

bench: install-bench
	@for b in benchmarks/*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

viewer:
	@command -v chromium >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -qq chromium >/dev/null; }
	@test -f $(VIEWER_APP)/assets/index.js || $(VIEWER_TOOL)/install_app.sh $(VIEWER_APP)
	@echo "viewer ready: chromium + $(VIEWER_APP)"

clean:
	rm -rf $(VENV) $(RUNS) build *.egg-info .pytest_cache .hypothesis
