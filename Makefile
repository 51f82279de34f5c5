# The two commands the README promises. Both set everything up first (idempotent):
#   make lab   -> .venv + package + notebook deps + sample data, then JupyterLab on notebooks/
#   make test  -> the same set-up, then every unit test and every notebook under nbval
# The developer's fast loop (CONTRIBUTING.md):
#   make lint  -> ruff check (rules in pyproject.toml [tool.ruff])
#   make check -> lint + the unit tests without the browser tests and the notebooks (<= 3 min)
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.stagger_nb-installed
PORT   ?= 8888
# JupyterLab refuses to run as root unless told; containers and CI machines often are root
ROOTFLAG := $(if $(filter 0,$(shell id -u)),--allow-root)

.PHONY: setup data lab test bench clean lint check

$(STAMP): pyproject.toml setup.py stagger_nb/io/_cparse.c stagger_nb/staggered/_cspline.c stagger_nb/timewarp/_cdp.c \
         stagger_nb/_carray.h
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --disable-pip-version-check -q -e '.[test,notebooks,bench]'
	touch $(STAMP)

setup: $(STAMP) data

data: $(STAMP)
	$(PY) -m stagger_nb.data.prepare

lab: setup
	@echo "Starting JupyterLab on notebooks/ (open the URL printed below; Ctrl-C stops it)"
	$(VENV)/bin/jupyter lab --no-browser --ip 127.0.0.1 --port $(PORT) --notebook-dir notebooks $(ROOTFLAG)

# TEST_WORKERS=2 (the default): the tests without a browser and the notebooks on two pytest-xdist workers (one per
# core), each file on one worker (--dist loadfile: a notebook's cells run in order in one kernel, a module's fixtures
# are built once), one BLAS thread per worker; then the browser tests alone, one at a time (JupyterLab and Chromium
# get the machine to themselves). Both steps always run; the target fails if either failed. TEST_WORKERS=0: everything
# in one process. Fresh-clone CI, 2 cores: serial 1048 s; two workers for everything 492 s (all passed).
TEST_WORKERS ?= 2
PYTEST_RUN = $(PY) -m pytest -p no:cacheprovider
test: setup
ifeq ($(TEST_WORKERS),0)
	$(PYTEST_RUN) tests notebooks --nbval-lax --nbval-current-env
else
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(PYTEST_RUN) tests notebooks --nbval-lax --nbval-current-env \
	  -m "not browser" -n $(TEST_WORKERS) --dist loadfile; first=$$?; \
	$(PYTEST_RUN) tests -m browser; second=$$?; \
	test $$first -eq 0 -a $$second -eq 0
endif

lint: $(STAMP)
	$(VENV)/bin/ruff check .

# the fast loop leaves out the browser tests, the real-clip sweeps (marker "shared") and the slow end-to-end files;
# `make test` (and .ci/run) runs them all
SLOW_TESTS := hostile_corpus hostile_batch hostile_heldout batch acceptance_editors acceptance_rigs compose_heldout io_gltf \
              compose_session editors_never_lock wand_repeats session_warm staggered_timing_limit
check: lint
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest tests -m "not browser and not shared" -q -p no:cacheprovider \
	  $(foreach t,$(SLOW_TESTS),--ignore=tests/test_$(t).py)

bench: setup
	for f in benchmarks/bench_*.py; do echo "== $$f"; $(PY) $$f || exit 1; done

clean:
	rm -rf $(VENV) data/*.bvh .pytest_cache
