#!/usr/bin/env bash
# The optional fast sparse solver: scikit-sparse (CHOLMOD), compiled against SuiteSparse and the
# Python headers of the venv's interpreter.  Run from the repository root.
#   fastsolver.sh install VENV_PYTHON  build it unless it imports; a failed build is retried as
#                                       soon as a prerequisite changes (headers or SuiteSparse
#                                       installed later), not on every run
#   fastsolver.sh check VENV_PYTHON    a loud notice when it does not import (end of make test/run)
set -u
mode=${1:?usage: fastsolver.sh install|check VENV_PYTHON}
py=${2:?usage: fastsolver.sh install|check VENV_PYTHON}
venv=$(dirname "$(dirname "$py")")
log="$venv/fastsolver.log"
failed="$venv/.fastsolver-failed"

imports() { "$py" -c "import sksparse.cholmod" >/dev/null 2>&1; }

python_h() { echo "$("$py" -c "import sysconfig; print(sysconfig.get_paths()['include'])")/Python.h"; }

cholmod_h() {
  for d in /usr/include/suitesparse /usr/local/include/suitesparse; do
    [ -f "$d/cholmod.h" ] && { echo "$d/cholmod.h"; return; }
  done
}

missing() {  # one line per missing prerequisite
  [ -f "$(python_h)" ] || echo "the Python headers $(python_h) (Debian: python3-dev)"
  [ -n "$(cholmod_h)" ] || echo "SuiteSparse's cholmod.h (Debian: libsuitesparse-dev)"
  command -v cc >/dev/null 2>&1 || echo "a C compiler (Debian: gcc)"
}

requirement() {  # the pin of the 'fast' extra in pyproject.toml (one source of truth)
  "$py" -c "import tomllib; d = tomllib.load(open('pyproject.toml', 'rb')); \
print(d['project']['optional-dependencies']['fast'][0])"
}

signature() {  # what a retry depends on
  requirement
  stat -c '%n %Y' "$(python_h)" $(cholmod_h) 2>/dev/null
  command -v cc
}

install() {
  imports && { rm -f "$failed"; return 0; }
  if [ -n "$(missing)" ]; then
    return 0  # `check` names what is missing, at the end of the run
  fi
  if [ -f "$failed" ] && [ "$(cat "$failed")" = "$(signature)" ]; then
    return 0  # failed before with the same prerequisites; `check` points at the log
  fi
  echo "multicontact: set-up: building the fast sparse solver $(requirement) against" \
    "SuiteSparse (CHOLMOD; compiles C, typically 0.5-2 min, once; log: $log)"
  t0=$(date +%s)
  if "$py" -m pip install "$(requirement)" >"$log" 2>&1 && imports; then
    rm -f "$failed"
    echo "multicontact: set-up: fast sparse solver built in $(( $(date +%s) - t0 )) s"
  else
    signature >"$failed"
    echo "multicontact: set-up: the fast sparse solver did not build ($(( $(date +%s) - t0 )) s;" \
      "see the notice at the end)"
  fi
}

blas() {  # the BLAS library CHOLMOD resolves (a slow reference BLAS is named as such)
  local so lib
  so=$("$py" -c "import sksparse.cholmod as c; print(c.__file__)" 2>/dev/null) || return 0
  lib=$(ldd "$so" 2>/dev/null | awk '/libblas\.so/ {print $3; exit}')
  [ -n "$lib" ] || return 0
  lib=$(readlink -f "$lib")
  case "$lib" in
    *openblas*) echo ", BLAS: OpenBLAS ($lib)" ;;
    */blas/libblas*) echo ", BLAS: the slow reference BLAS ($lib; Debian: libopenblas0-serial)" ;;
    *) echo ", BLAS: $lib" ;;
  esac
}

check() {
  imports && { echo "multicontact: sparse backend: CHOLMOD (scikit-sparse)$(blas)"; return 0; }
  bar="======================================================================================"
  echo "$bar"
  echo "multicontact: the fast sparse solver (CHOLMOD, scikit-sparse) is NOT available."
  echo "  The FE model ran on SciPy's SuperLU instead (2.5-4x slower); the results are the same."
  why=$(missing)
  if [ -n "$why" ]; then
    echo "  Missing: $(echo "$why" | paste -sd ';' | sed 's/;/; /g')."
    echo "  Install them (as root on Debian, make does it: .ci/sysdeps.sh) and run make again:"
    echo "  the build is retried automatically."
  elif [ -f "$failed" ]; then
    echo "  The build failed: see $log (it is retried when a prerequisite changes;"
    echo "  delete $failed to retry now)."
  else
    echo "  It has not been built yet: make test or make run builds it."
  fi
  echo "$bar"
}

case "$mode" in
  install) install ;;
  check) check ;;
  *) echo "usage: fastsolver.sh install|check VENV_PYTHON" >&2; exit 2 ;;
esac
