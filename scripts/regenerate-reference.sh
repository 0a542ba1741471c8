#!/usr/bin/env bash
# Regenerate the reference output of scene tests after a deliberate change,
# printing old and new side by side for review (the new numbers must be
# checked against the mathematics before they are committed):
#   scripts/regenerate-reference.sh tests/membranes/seed-smooth-p1.prm [...]
# Bad-input tests (tests/input/...) get the program's stderr line.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
for prm in "$@"; do
  prm=$(cd "$(dirname "$prm")" && pwd)/$(basename "$prm")
  name=$(basename "$prm" .prm)
  dir=$(dirname "$prm")
  program=$root/build/step-$(basename "$dir")/step-$(basename "$dir")
  case "$dir" in */tests/input/*)
    program=$root/build/step-$(basename "$dir")/step-$(basename "$dir");;
  esac
  work=$(mktemp -d)
  cp "$prm" "$work/"
  [[ -e $dir/meshes ]] && ln -s "$dir/meshes" "$work/meshes"
  np=1
  [[ $name =~ \.mpirun=([0-9]+) ]] && np=${BASH_REMATCH[1]}
  runner=()
  ((np > 1)) && runner=(mpirun --allow-run-as-root --oversubscribe -np "$np")
  (cd "$work" && TMPDIR=$work "${runner[@]}" "$program" "$(basename "$prm")" \
     > screen-output 2> error-output) || true
  reference=$dir/$name.output
  case "$dir" in
    */tests/input/*) new=$work/error-output ;;
    *) new=$work/output/convergence.txt ;;
  esac
  echo "== $name"
  [[ -f $reference ]] && { echo "-- old"; cat "$reference"; }
  echo "-- new"; cat "$new"
  cp "$new" "$reference"
  rm -rf "$work"
done
