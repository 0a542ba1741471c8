#!/usr/bin/env bash
# The same set-up as demo.sh, then the test suite (all but the 'long' label).
# Exits non-zero if anything fails.
set -euo pipefail
cd "$(dirname "$0")"
./scripts/setup.sh
cd build
ctest --output-on-failure --label-exclude long -j "$(nproc)"
