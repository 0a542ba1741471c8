#!/usr/bin/env bash
# One command from a fresh Debian machine to a first result: installs what is
# missing, builds in Release and runs the default scene of step-membranes.
set -euo pipefail
cd "$(dirname "$0")"
./scripts/setup.sh

# Fresh memory in 2 MiB pages (glibc >= 2.35; no effect on the numbers, see
# README.md): fewer page faults on large meshes.
export GLIBC_TUNABLES="${GLIBC_TUNABLES-glibc.malloc.hugetlb=1}"

scene=parameters/membranes-default.prm
echo "== Running step-membranes on $scene"
./build/step-membranes/step-membranes "$scene"

output=output/membranes-default
echo
echo "== Done. In $output/:"
echo "   solution_*.pvtu   the solution of each cycle for ParaView (u1, u2, gap,"
echo "                     lambda, contact, partition): paraview $output/solution_03.pvtu"
echo "   convergence.txt   the convergence table"
echo "   summary.json      every number of the run, machine-readable"
