# multicontact: `make test` passes the tests, `make run` runs the default verification suite.
# Both create/reuse .venv, install the project and its needs (and, as root on Debian, the system
# libraries: see .ci/sysdeps.sh), then run, and end by naming the sparse backend (a loud notice
# when the fast one, CHOLMOD, is missing: .ci/fastsolver.sh).
VENV   ?= .venv
PYTHON ?= python3
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

# One BLAS thread: numpy's bundled OpenBLAS with 2 threads on 2 cores is 30-100x slower here.
export OPENBLAS_NUM_THREADS := 1
export OMP_NUM_THREADS := 1
export MKL_NUM_THREADS := 1
export MPLBACKEND := Agg

.PHONY: test run sysdeps fastsolver lint bench slow clean

# The stamp depends on everything that decides what gets installed.  The first set-up says what
# it does and how long it took (pip: ~1.2 GB into .venv, VTK alone 0.57 GB).
$(STAMP): pyproject.toml Makefile .ci/sysdeps.sh .ci/fastsolver.sh
	@echo "multicontact: set-up: installing the Python packages into $(VENV) (numpy, scipy," \
	  "scikit-fem, VTK/pyvista, matplotlib, dask, pytest, gmsh: ~1.2 GB; typically 2-5 min, once)"
	@t0=$$(date +%s); $(PYTHON) -m venv $(VENV) && \
	  $(PY) -m pip install -q --upgrade pip && \
	  $(PY) -m pip install -q -e ".[test,cluster]" && \
	  echo "multicontact: set-up: Python packages installed in $$(( $$(date +%s) - t0 )) s"
	@touch $(STAMP)

sysdeps:
	@PYTHON=$(PYTHON) bash .ci/sysdeps.sh

# CHOLMOD is optional: built when its prerequisites are there, retried when they change.
fastsolver: sysdeps $(STAMP)
	@bash .ci/fastsolver.sh install $(PY)

test: sysdeps fastsolver
	@$(PY) -m pytest -q; rc=$$?; bash .ci/fastsolver.sh check $(PY); exit $$rc

run: sysdeps fastsolver
	@$(VENV)/bin/multicontact report -o report; rc=$$?; bash .ci/fastsolver.sh check $(PY); \
	exit $$rc

slow: sysdeps fastsolver
	@$(PY) -m pytest -q -m slow; rc=$$?; bash .ci/fastsolver.sh check $(PY); exit $$rc

lint: $(STAMP)
	$(VENV)/bin/ruff check analytic fem compare tests benchmarks

bench: $(STAMP)
	$(PY) benchmarks/bench_analytic.py
	$(PY) benchmarks/bench_fem.py
	$(PY) benchmarks/bench_bem.py

clean:
	rm -rf $(VENV) report build *.egg-info
