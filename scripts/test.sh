#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite with ctest.
#
#   scripts/test.sh [CTEST ARGS…]             Release build in build/, every test
#   scripts/test.sh --sanitize [CTEST ARGS…]  a second build in build-asan/ (RelWithDebInfo,
#                                             AddressSanitizer + UndefinedBehaviorSanitizer, abort on
#                                             the first report) and the whole suite run there
#
# docs/development.md explains both. JOBS sets the build and ctest parallelism (default: nproc).
set -euo pipefail
cd "$(dirname "$0")/.."

sanitize=0
if [ "${1:-}" = "--sanitize" ]; then
  sanitize=1
  shift
fi

if [ "$sanitize" -eq 0 ]; then
  scripts/setup.sh
  cd build
  ctest --output-on-failure -j "${JOBS:-$(nproc)}" "$@"
  exit 0
fi

# Installs the packages (and builds build/, which the two CLI tests of the viewer and the
# benchmark do not need here, but setup.sh is the one place that knows the package list).
SETUP_ONLY_PACKAGES=1 scripts/setup.sh
# CROWDHEALTH_MPI=OFF: OpenMPI leaves memory allocated at exit, which LeakSanitizer reports; the
# job pool runs on local threads here and the MPI test (cli_sweep_mpi_test) is not registered.
# -O1 -g1 (line tables, no variable info): ASan's recommended optimisation level, and it compiles
# and links the second build in about half the time of RelWithDebInfo's -O2 -g (CI stays under
# 40 minutes); reports still name file and line. docs/development.md "Build time".
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCROWDHEALTH_SANITIZE=ON \
      -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
      -DCROWDHEALTH_BUILD_BENCHMARKS=OFF -DCROWDHEALTH_MPI=OFF
cmake --build build-asan -j "${JOBS:-$(nproc)}"
cd build-asan
# detect_leaks: LeakSanitizer as well; abort_on_error/halt_on_error: a report ends the test with a
# failure; the suppressions file lists only reports from outside the project (docs/development.md).
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="halt_on_error=1:abort_on_error=1:print_stacktrace=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
export LSAN_OPTIONS="suppressions=$(cd .. && pwd)/Tests/sanitizer/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
# The longest suites run their short variants here (vantoll_reference_test and
# sph_reference_test: seed 1 to t = 18 s, density at 15 s and people leaving; fewer steps, seeds
# or tests in examples_run_test, cli_verify_test, policies_vision_test): docs/development.md.
export CROWDHEALTH_SHORT=1
ctest --output-on-failure -j "${JOBS:-$(nproc)}" "$@"
