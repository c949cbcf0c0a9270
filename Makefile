# multicontact: `make test` passes the tests, `make run` runs the default verification suite.
# Both create/reuse .venv, install the project and its needs (and, as root on Debian, the system
# libraries: see .ci/sysdeps.sh), then run.
VENV   ?= .venv
PYTHON ?= python3
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

# One BLAS thread: numpy's bundled OpenBLAS with 2 threads on 2 cores is 30-100x slower here.
export OPENBLAS_NUM_THREADS := 1
export OMP_NUM_THREADS := 1
export MKL_NUM_THREADS := 1
export MPLBACKEND := Agg

.PHONY: test run sysdeps lint bench slow clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e ".[test,cluster]"
	@if dpkg -s libsuitesparse-dev >/dev/null 2>&1; then \
	  $(PY) -m pip install -q "scikit-sparse==0.4.16" || \
	  echo "multicontact: scikit-sparse (CHOLMOD) did not build; the FE model falls back to SciPy"; \
	fi
	touch $(STAMP)

sysdeps:
	@bash .ci/sysdeps.sh

test: sysdeps $(STAMP)
	$(PY) -m pytest -q

run: sysdeps $(STAMP)
	$(VENV)/bin/multicontact report -o report

slow: sysdeps $(STAMP)
	$(PY) -m pytest -q -m slow

lint: $(STAMP)
	$(VENV)/bin/ruff check analytic fem compare tests benchmarks

bench: $(STAMP)
	$(PY) benchmarks/bench_analytic.py
	$(PY) benchmarks/bench_fem.py
	$(PY) benchmarks/bench_bem.py

clean:
	rm -rf $(VENV) report build *.egg-info
