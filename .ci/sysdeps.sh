#!/usr/bin/env bash
# System libraries multicontact needs on Debian: EGL/Mesa for off-screen pyvista rendering,
# SuiteSparse (CHOLMOD, the fast sparse Cholesky behind scikit-sparse), serial OpenBLAS (CHOLMOD's
# supernodes run on the system BLAS; Debian's reference libblas3 makes the level-6 history 2.3x
# slower, benchmarks/bench_fem.py; installing OpenBLAS switches the libblas.so.3 alternative in
# auto mode), the Python headers of the interpreter $PYTHON (default python3; scikit-sparse
# compiles against its Python.h), Chromium (the HTML report test renders the report headless) and
# the X/GLU libraries gmsh's wheel links (the tests mesh meshes/*.geo with it).
# As root: installs what is missing.  Otherwise: prints exactly what is missing and the command to
# install it, and carries on (features degrade with a clear message; the tests that need them
# skip with the reason).
set -u
PYTHON=${PYTHON:-python3}
PKGS="libegl1 libegl-mesa0 libgl1-mesa-dri libglx-mesa0 libgl1 libxrender1 libxt6 libxext6 libx11-6 libsuitesparse-dev libopenblas0-serial chromium calculix-ccx libglu1-mesa libxcursor1 libxft2 libxinerama1 libfontconfig1 libopengl0"

# The Debian package holding Python.h of $PYTHON, if it is missing and Debian's to give.
python_headers() {
  local inc ver
  inc=$("$PYTHON" -c "import sysconfig; print(sysconfig.get_paths()['include'])" 2>/dev/null) \
    || return 0
  [ -f "$inc/Python.h" ] && return 0
  case "$inc" in
    /usr/include/python3.*)
      ver=${inc#/usr/include/python}
      if [ "$(readlink -f /usr/bin/python3)" = "/usr/bin/python$ver" ]; then
        echo python3-dev
      else
        echo "python$ver-dev"
      fi ;;
    *) echo "multicontact: $PYTHON has no $inc/Python.h and is not Debian's interpreter:" \
         "install its headers to build the fast sparse solver (CHOLMOD)" >&2 ;;
  esac
}
PKGS="$PKGS $(python_headers)"
missing=""
for p in $PKGS; do
  dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"
done
[ -z "$missing" ] && exit 0
if ! command -v apt-get >/dev/null 2>&1; then
  echo "multicontact: not a Debian system; please install the equivalents of:$missing" >&2
  exit 0
fi
if [ "$(id -u)" = "0" ]; then
  echo "multicontact: set-up: installing system packages with apt-get:$missing" \
    "(all of them: ~0.6 GB, Chromium ~0.3 GB of it; typically 1-3 min, once)"
  t0=$(date +%s)
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >/dev/null && apt-get install -y -qq --no-install-recommends $missing >/dev/null \
    || { echo "multicontact: apt-get install failed for:$missing" >&2; exit 1; }
  echo "multicontact: set-up: system packages installed in $(( $(date +%s) - t0 )) s"
else
  echo "multicontact: missing system packages:$missing" >&2
  echo "  install them with: sudo apt-get install -y$missing" >&2
fi
