#!/usr/bin/env bash
# System libraries multicontact needs on Debian: EGL/Mesa for off-screen pyvista rendering,
# SuiteSparse (CHOLMOD, the fast sparse Cholesky behind scikit-sparse) and Chromium (the HTML
# report test renders the report headless).  As root: installs what is missing.  Otherwise: prints
# exactly what is missing and the command to install it, and carries on (features degrade with a
# clear message; the tests that need them skip with the reason).
set -u
PKGS="libegl1 libegl-mesa0 libgl1-mesa-dri libglx-mesa0 libgl1 libxrender1 libxt6 libxext6 libx11-6 libsuitesparse-dev chromium"
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
  echo "multicontact: installing system packages:$missing"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >/dev/null && apt-get install -y -qq --no-install-recommends $missing >/dev/null \
    || { echo "multicontact: apt-get install failed for:$missing" >&2; exit 1; }
else
  echo "multicontact: missing system packages:$missing" >&2
  echo "  install them with: sudo apt-get install -y$missing" >&2
fi
