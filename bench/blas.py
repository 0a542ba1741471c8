#!/usr/bin/env python3
"""What the BLAS costs the direct solver (doc/performance.md, "The BLAS of
the direct solver").

libdeal.ii-dev pulls in Debian's reference BLAS; scripts/setup.sh installs
OpenBLAS (threaded build), which Debian's alternatives then prefer. MUMPS
spends its factorisation in dense BLAS kernels on the fronts, so the BLAS
decides much of the cost of the exact solves (`Linear solver/Solver =
direct`). This study runs the same binary on the same scenes with the
system's BLAS and with the reference BLAS (loaded first through
LD_LIBRARY_PATH), alternating, in rounds, and reports per scene the median
over the rounds of the preconditioner time on the finest mesh ("newton:
preconditioner": for the direct solver the numeric factorisations of its
Newton steps) and of the wall time of the whole run, the ratios reference /
system, and the largest relative difference of the errors between the two
(the iterates must not depend on the BLAS beyond round-off). A scene of the
cost study (GMRES + AMG, no direct solver) shows what the BLAS does not
change.

  disk Q2           parameters/membranes-disk.prm (Q2, Newton-min, MUMPS,
                    4 meshes to 49409 unknowns per field), one process
                    with deal.II's default threads and two processes of
                    one thread
  seed-smooth Q1    parameters/membranes-seed-smooth.prm at p = 1 from 8 x 8
                    cells, 7 meshes to 66049 unknowns per field (the Q1 run
                    of bench/error_vs_time.py), estimators off, one process
  disk Q1 AMG       the cost study's configuration (bench/membranes_cost.py
                    --c-function=fischer-burmeister --flux-degree=p-1
                    --coarse-start), 5 meshes to 197121 unknowns per field
                    on one process of one thread, and 6 meshes to 787457
                    on two processes (where OpenBLAS's threads could
                    compete with the other rank for the two cores)

Writes doc/data/blas.{csv,md}. Usage, from the repository root after
./demo.sh or ./test.sh:
  bench/blas.py [--rounds=N]
N rounds (default 3) take about 4 minutes each (OpenBLAS on this
machine). STEP_MEMBRANES names another binary.
"""
import os
import statistics
import subprocess
import sys

from vi_bench import ROOT, cost_study_settings, option, program, run, write_table

PROGRAM = program("membranes")
OUT = os.path.join(ROOT, "output", "bench-blas")
ROUNDS = option("rounds", 3, int)
LIBRARIES = "/usr/lib/x86_64-linux-gnu"
REFERENCE = {"LD_LIBRARY_PATH": f"{LIBRARIES}/blas:{LIBRARIES}/lapack"}

# The cost study's configuration (bench/membranes_cost.py
# --c-function=fischer-burmeister --flux-degree=p-1 --coarse-start).
COST_STUDY = cost_study_settings("fischer-burmeister", "p-1", 3)

SCENES = [
    ("disk Q2", "membranes-disk.prm", {}, 1, None),
    ("disk Q2", "membranes-disk.prm", {}, 2, 1),
    ("seed-smooth Q1", "membranes-seed-smooth.prm",
     {"Discretization/Polynomial degree": 1, "Mesh/Initial refinements": 2,
      "Mesh/Cycles": 7, "Estimators/Enabled": "false"}, 1, None),
    ("disk Q1 AMG", "estimators-disk-p1.prm", {**COST_STUDY, "Mesh/Cycles": 5}, 1, 1),
    ("disk Q1 AMG", "estimators-disk-p1.prm", {**COST_STUDY, "Mesh/Cycles": 6}, 2, None),
]


def system_blas():
    """The library behind libblas.so.3 (Debian's alternatives)."""
    return os.path.realpath(f"{LIBRARIES}/libblas.so.3")


def measure(scene, prm, settings, np, threads, blas, round_):
    directory = os.path.join(OUT, f"{scene.replace(' ', '-')}-np{np}-{blas}-{round_}")
    summary = run(PROGRAM, prm, {**settings, "Output/Write VTU": "false"},
                  directory, np, threads, REFERENCE if blas == "reference" else None)
    finest = summary["cycles"][-1]
    return {"preconditioner": finest["timing"]["newton: preconditioner"],
            "wall": sum(c["wall_seconds"] for c in summary["cycles"]),
            "newton": [c["newton_iterations"] for c in summary["cycles"]],
            "errors": [c["error_energy"] for c in summary["cycles"]],
            "dofs_per_field": finest["dofs_per_field"],
            "threads": summary["threads_per_rank"]}


def main():
    blas = system_blas()
    print(f"system BLAS: {blas}")
    # The loader must take the reference BLAS and LAPACK from LD_LIBRARY_PATH
    # (missing if Debian's libblas3, liblapack3 are not installed).
    loaded = subprocess.run(["ldd", PROGRAM], capture_output=True, text=True,
                            env={**os.environ, **REFERENCE}).stdout
    for library in ("blas/libblas.so.3", "lapack/liblapack.so.3"):
        if f"{LIBRARIES}/{library}" not in loaded:
            sys.exit(f"LD_LIBRARY_PATH does not give {PROGRAM} the reference "
                     f"{LIBRARIES}/{library} (Debian's libblas3, liblapack3): "
                     "nothing to compare with")
    if blas.startswith(f"{LIBRARIES}/blas/"):
        sys.exit("the system's BLAS is the reference BLAS: nothing to compare "
                 "(install libopenblas0-pthread, as scripts/setup.sh does)")
    runs = {}
    for round_ in range(ROUNDS):
        for key in SCENES:
            for which in ("system", "reference"):
                runs.setdefault((key[0], key[3], which), []).append(
                    measure(*key, which, round_))
        print(f"  round {round_ + 1} of {ROUNDS}: done", flush=True)

    rows = []
    for scene, prm, settings, np, threads in SCENES:
        system, reference = runs[(scene, np, "system")], runs[(scene, np, "reference")]
        counts = {str(r["newton"]) for r in system + reference}
        if len(counts) > 1:
            print(f"warning: {scene}, np = {np}: the Newton counts differ "
                  f"between runs: {sorted(counts)}")
        difference = max(abs(a - b) / b for r in system + reference
                          for a, b in zip(r["errors"], reference[0]["errors"]))
        row = {"scene": scene, "processes": np, "threads": system[0]["threads"],
               "configuration": f"{np} x {system[0]['threads']}",
               "dofs_per_field": system[0]["dofs_per_field"],
               "newton": "/".join(map(str, system[0]["newton"])),
               "error_difference": difference}
        for which, results in (("system", system), ("reference", reference)):
            row[f"preconditioner_{which}"] = statistics.median(r["preconditioner"] for r in results)
            row[f"wall_{which}"] = statistics.median(r["wall"] for r in results)
        row["preconditioner_ratio"] = row["preconditioner_reference"] / row["preconditioner_system"]
        row["wall_ratio"] = row["wall_reference"] / row["wall_system"]
        rows.append(row)

    write_table("blas", rows,
                ["scene", "processes x threads", "unknowns per field (finest)",
                 "Newton steps per mesh", "preconditioner, finest mesh (s): system",
                 "reference", "ratio", "whole run (s): system", "reference",
                 "ratio", "largest relative difference of the errors"],
                [("scene", "{}"), ("configuration", "{}"), ("dofs_per_field", "{}"),
                 ("newton", "{}"), ("preconditioner_system", "{:.2f}"),
                 ("preconditioner_reference", "{:.2f}"), ("preconditioner_ratio", "{:.2f}"),
                 ("wall_system", "{:.1f}"), ("wall_reference", "{:.1f}"),
                 ("wall_ratio", "{:.2f}"), ("error_difference", "{:.1e}")])
    print(f"wrote doc/data/blas.{{csv,md}} (system BLAS {blas}, "
          f"medians of {ROUNDS} rounds)")


if __name__ == "__main__":
    main()
