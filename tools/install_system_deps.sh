#!/usr/bin/env bash
# Installs the Debian packages yore needs to build, only those missing. Idempotent; needs root
# (or sudo) only when something is missing.
set -euo pipefail

python=${PYTHON:-python3}
# libsundials-dev: CVODE and ARKODE (the error-controlled integrators); Debian built it with
# MPI, hypre and PETSc, so it pulls ~350 MB of packages in.
# libegl1 libegl-mesa0 libgl1-mesa-dri libx11-6: polyscope's headless (EGL, Mesa llvmpipe)
# pictures and the viewer; xvfb xdotool: the test that drives the viewer's real window
# doctest-dev: the C++ tests (tests/cpp, `make test-cpp`); clang-format: the C++ style check
packages=(g++ make cmake ninja-build ccache pkg-config
          libeigen3-dev libsuitesparse-dev libcgal-dev libsundials-dev libopenblas0-pthread
          libegl1 libegl-mesa0 libgl1-mesa-dri libx11-6 xvfb xdotool doctest-dev clang-format)
missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done
if ! command -v "$python" >/dev/null 2>&1; then
  missing+=(python3 python3-venv python3-dev)
else
  "$python" -c 'import venv, ensurepip' 2>/dev/null || missing+=(python3-venv)
  "$python" - <<'PY' || missing+=(python3-dev)
import os, sys, sysconfig
sys.exit(0 if os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")) else 1)
PY
fi

if ((${#missing[@]} == 0)); then
  exit 0
fi
echo "yore: installing Debian packages: ${missing[*]}"
sudo=()
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then
    sudo=(sudo)
  else
    echo "yore: missing packages (${missing[*]}) and not root; install them with apt-get" >&2
    exit 1
  fi
fi
"${sudo[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends \
  "${missing[@]}"
