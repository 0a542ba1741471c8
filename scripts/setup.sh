#!/usr/bin/env bash
# Shared set-up of demo.sh and test.sh: install the Debian packages that are
# missing, then configure (Release) and build in build/. Idempotent: a second
# call installs nothing and rebuilds only what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  libdeal.ii-dev   # deal.II 9.4 with Trilinos, p4est, PETSc, SUNDIALS, MPI
  libmuparser-dev  # formulas of Problem/Expression (deal.II depends on it too)
  # An optimised BLAS for the dense kernels of the direct solvers (MUMPS);
  # Debian's alternatives then prefer it to the reference BLAS that
  # libdeal.ii-dev pulls in. The threaded build, not libopenblas0-serial,
  # which is not safe to call from deal.II's threads (doc/performance.md).
  libopenblas0-pthread
  openmpi-bin      # mpirun for parallel runs and the MPI tests
  numdiff          # tolerant comparison of test output
  libgtest-dev     # GoogleTest unit tests
  cmake make g++ git
  gnuplot-nox      # plots of the benchmark scripts in bench/
  time             # /usr/bin/time: peak memory in bench/memory_model.py
  python3
)
missing=()
for package in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null |
    grep -q "install ok installed" || missing+=("$package")
done
if ((${#missing[@]})); then
  echo "== Installing missing Debian packages: ${missing[*]}"
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q "${missing[@]}"
fi

echo "== Configuring and building (Release) in build/ (log in build.log)"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > build.log 2>&1 ||
  { cat build.log; exit 1; }
# A line per compiled batch or file and linked program, so that a build of
# several minutes shows where it is ("   [ 12%] vi_common, batch 3 of its
# unity build", "   [ 15%] estimators.cc"); everything goes to build.log
# as well.
show_progress() {
  local line object name target
  while IFS= read -r line; do
    case "$line" in
      *"Building CXX object"* | *"Linking CXX"*)
        object=${line##* }
        name=${object##*/}
        case "$name" in
          unity_*_cxx.cxx.o)
            target=${object%%.dir/*}
            target=${target##*/}
            name=${name#unity_}
            name="$target, batch ${name%%_*} of its unity build"
            ;;
          *) name=${name%.o} ;;
        esac
        echo "   ${line%%]*}] $name"
        ;;
    esac
  done
}
if ! cmake --build build -j "$(nproc)" 2>&1 | tee -a build.log | show_progress
then
  tail -50 build.log
  exit 1
fi
echo "   built"
