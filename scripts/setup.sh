#!/usr/bin/env bash
# Installs the Debian packages CrowdHealth needs (when missing), configures CMake in Release
# into build/ and builds (the program, the tests, and the Python module into build/python).
# Called by demo.sh and test.sh; safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(g++ cmake make pkg-config libtinyxml2-dev libeigen3-dev libboost-program-options-dev
          libboost-test-dev libgnuplot-iostream-dev libboost-iostreams-dev libboost-system-dev
          libboost-filesystem-dev gnuplot-nox
          # every JSON file written or read (summary.json, render.json)
          nlohmann-json3-dev
          # <Obstacles file="venue.dxf">: the DXF reader (docs/geometry.md)
          libdxflib-dev
          # crowdhealth-viewer and its test, screenshots/PNG checks (docs/rendering.md)
          libglfw3-dev libgl-dev zlib1g-dev xvfb xauth
          # the Python module crowdhealth in build/python, its tests and examples (docs/python.md)
          pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib python3-setuptools python3-wheel
          # the C API's install test (docs/c-api.md): gcc comes with g++, pkg-config is above; readelf
          binutils
          # `mpirun -n K crowdhealth sweep`: the runs of a study on MPI ranks, on one host or a cluster
          # (OpenMPI, the MPI clusters already run; CMake option CROWDHEALTH_MPI; docs/sweeps.md)
          libopenmpi-dev openmpi-bin)

# EXTRA_PACKAGES: more packages for a caller (scripts/fuzz.sh: clang, libFuzzer, …).
read -r -a extra <<< "${EXTRA_PACKAGES:-}"
PACKAGES+=("${extra[@]}")
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"
fi

# SETUP_ONLY_PACKAGES=1: install only (scripts/test.sh --sanitize configures its own build).
if [ -n "${SETUP_ONLY_PACKAGES:-}" ]; then exit 0; fi

JOBS="${JOBS:-$(nproc)}"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build build -j "$JOBS"
