# The two commands the README promises. Both set everything up first (idempotent):
#   make lab   -> .venv + package + notebook deps + sample data, then JupyterLab on notebooks/
#   make test  -> the same set-up, then every unit test and every notebook under nbval
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.stagger_nb-installed
PORT   ?= 8888
# JupyterLab refuses to run as root unless told; containers and CI machines often are root
ROOTFLAG := $(if $(filter 0,$(shell id -u)),--allow-root)

.PHONY: setup data lab test bench clean

$(STAMP): pyproject.toml setup.py stagger_nb/io/_cparse.c stagger_nb/staggered/_cspline.c stagger_nb/_carray.h
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --disable-pip-version-check -q -e '.[test,notebooks,bench]'
	touch $(STAMP)

setup: $(STAMP) data

data: $(STAMP)
	$(PY) -m stagger_nb.data.prepare

lab: setup
	@echo "Starting JupyterLab on notebooks/ (open the URL printed below; Ctrl-C stops it)"
	$(VENV)/bin/jupyter lab --no-browser --ip 127.0.0.1 --port $(PORT) --notebook-dir notebooks $(ROOTFLAG)

test: setup
	$(PY) -m pytest tests notebooks --nbval-lax --nbval-current-env -p no:cacheprovider

bench: setup
	for f in benchmarks/bench_*.py; do echo "== $$f"; $(PY) $$f || exit 1; done

clean:
	rm -rf $(VENV) data/*.bvh .pytest_cache
