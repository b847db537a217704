# Everything a fresh machine needs is installed from pyproject.toml into .venv.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo -n)

.PHONY: install system-deps check test demo bench bench-caregiving clean

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	touch $(STAMP)

# Debian packages for the browser and terminal tests, installed only when missing
# (those tests skip, saying why, if this could not install them).
system-deps:
	@if [ ! -x /usr/bin/chromium ] || ! command -v tmux >/dev/null; then \
		( $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq chromium chromium-driver tmux ) >/dev/null 2>&1 \
		|| echo "system-deps: could not install chromium and tmux; the browser and terminal tests will skip"; \
	fi

# Lint, format, types (strict on wm and the agent runtime) and the layering contracts of
# pyproject.toml ([tool.importlinter]: bridges -> agents -> wm). The same hooks run from pre-commit.
check: $(STAMP)
	$(VENV)/bin/ruff check src tests bench deploy docs
	$(VENV)/bin/ruff format --check src tests bench deploy docs
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports

test: check $(STAMP) system-deps
	$(PY) -m pytest -q

demo: $(STAMP)
	$(PY) -m bridges.experiment.demo

# The working memory's benchmarks (replication, catch-up, replicas, local rates, memory, against a raw
# Zenoh/pycrdt baseline and Redis in the same run): minutes.
WM_BENCH := $(addprefix bench/bench_,graph_local.py replication_latency.py replication_throughput.py \
	replica_scaling.py catchup.py vs_redis.py volatile_memory.py volatile_memory_processes.py)
# The caregiving stack's benchmarks, over every recorded run in docs/results: hours. These read what another run
# wrote (recorded searches, a closed-loop JSON), named on their command line, and are left to be run by hand.
BENCH_ON_RECORDINGS := bench/bench_exact_losses.py bench/bench_replay_searches.py bench/bench_replay_two_codes.py
CAREGIVING_BENCH := $(filter-out $(WM_BENCH) $(BENCH_ON_RECORDINGS),$(wildcard bench/bench_*.py))

bench: $(STAMP)
	mkdir -p bench/results
	for b in $(WM_BENCH); do $(PY) $$b --json bench/results/$$(basename $$b .py).json || exit 1; done

bench-caregiving: $(STAMP)
	mkdir -p bench/results
	for b in $(CAREGIVING_BENCH); do $(PY) $$b --json bench/results/$$(basename $$b .py).json || exit 1; done

clean:
	rm -rf $(VENV) build *.egg-info src/*.egg-info
