#!/usr/bin/env bash
# The whole test suite on a fresh Debian 12 machine: installs packages, builds (release preset) and
# runs every ctest label (unit, scenario, realdata). Extra arguments go to ctest (e.g. -L unit).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh release
ctest --preset release "$@"
