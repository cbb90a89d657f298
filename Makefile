# drivelash — set-up and everyday targets. Every target creates .venv when missing.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
PYTEST_WORKERS ?= 2
export NUMBA_CACHE_DIR := $(CURDIR)/.venv/numba-cache
# Python's byte-code cache, in this project's .venv and src/ (an environment may switch it off
# with PYTHONDONTWRITEBYTECODE=1): without it every CLI process the tests start compiles each
# module again — `drivelash track --help` 4.5 s against 1.4 s (session 25).
export PYTHONDONTWRITEBYTECODE :=

.PHONY: venv components demo test test-slow bench lint clean

venv: $(STAMP)

# --no-compile: Python writes the byte code of the modules it imports on first use (see
# PYTHONDONTWRITEBYTECODE above) instead of pip compiling every installed file, torch's thousands
# among them: set-up 2 min 12 s -> 45 s on 2 cores (session 25, a fresh venv each, same wheels).
$(STAMP): pyproject.toml requirements.lock
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check --upgrade pip
	$(PY) -m pip install --quiet --disable-pip-version-check --no-compile -c requirements.lock -e ".[train,batch,dev]"
	@touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/drivelash demo -o demo-output

# The real components some tests start (BRIEF): the distribution's chromium (headless report
# checks) and PostgreSQL server binaries (initdb + pg_ctl for a throwaway server). Installed from
# Debian when missing and possible (root with apt-get; apt-get update first); otherwise the tests
# that need them skip and say why.
components:
	@missing=""; \
	command -v chromium >/dev/null 2>&1 || missing="$$missing chromium"; \
	ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || command -v initdb >/dev/null 2>&1 || missing="$$missing postgresql"; \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then \
	  echo "missing:$$missing; not root with apt-get, so not installed: the tests that need them will skip"; exit 0; fi; \
	echo "installing$$missing (Debian packages)"; \
	export DEBIAN_FRONTEND=noninteractive; \
	{ apt-get update -qq && apt-get install -y -qq $$missing >/dev/null; } \
	  || echo "apt-get could not install$$missing: the tests that need them will skip"

# One BLAS/OpenMP thread per pytest worker: two workers on two cores with two OpenBLAS threads
# each oversubscribe the cores (tests/identify: 176 s -> 105 s wall, session 25).
test: $(STAMP) components
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 \
	  $(PY) -m pytest -q -n $(PYTEST_WORKERS) -m "not slow"

test-slow: $(STAMP) components
	$(PY) -m pytest -q -n $(PYTEST_WORKERS) -m "slow"

bench: $(STAMP)
	@for b in benchmarks/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks examples
	$(VENV)/bin/ruff format --check src tests benchmarks examples

clean:
	rm -rf $(VENV) demo-output .pytest_cache .ruff_cache
