#!/usr/bin/env python3
"""Distributed adaptive runs (doc/performance.md): the same estimator-driven
adaptive refinement of the L-shape (Q1, corner singularity and contact) on
one and on two MPI ranks, in the configuration of the cost study (adaptive
inexact Newton-min, GMRES + AMG, nested iteration, estimates at the end of
the Newton steps). Per cycle: the meshes (cells, unknowns), Newton and
GMRES iterations, energy error and estimate on both process counts, their
largest relative difference, and the time of the solve (with its estimator
share) on each. The runs on one and on two ranks use one thread per
rank; a third run on one rank with all cores (deal.II's default, two
threads here) must give the one-rank numbers exactly (the estimators sum
in a fixed order) and times the threads against the ranks.

Writes doc/data/parallel.{csv,md}.
Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/membranes_parallel.py [--quick]
--quick stops after 8 cycles (a smoke test of the script). The full study
takes about 4 minutes (at 1db72e7).
STEP_MEMBRANES names another binary (e.g. a copy, so that the build tree
can be rebuilt while the study runs).
"""
import os
import sys

from vi_bench import ROOT, estimator_seconds, program, run, write_table

PROGRAM = program("membranes")
OUT = os.path.join(ROOT, "output", "bench-parallel")
CYCLES = 8 if "--quick" in sys.argv else 15
SETTINGS = {"Mesh/Initial refinements": 2, "Mesh/Refinement": "adaptive",
            "Mesh/Marking": "fixed-fraction", "Mesh/Refinement fraction": 0.3,
            "Mesh/Cycles": CYCLES,
            "Nonlinear solver/Strategy": "adaptive",
            "Nonlinear solver/Nested iteration": "true",
            "Linear solver/Solver": "gmres",
            "Linear solver/Preconditioner": "amg",
            "Estimators/At every check": "false",
            "Output/Write VTU": "false"}


def relative_difference(a, b):
    return abs(a - b) / max(abs(a), abs(b))


def main():
    cycles = {}
    for np in (1, 2):
        summary = run(PROGRAM, "membranes-l-shape.prm", SETTINGS,
                      os.path.join(OUT, f"np{np}"), np, threads=1)
        cycles[np] = summary["cycles"]
        print(f"  np = {np} x 1 thread: done", flush=True)
    summary = run(PROGRAM, "membranes-l-shape.prm", SETTINGS,
                  os.path.join(OUT, "np1-threads"), 1)
    threaded = summary["cycles"]
    print(f"  np = 1 x {summary['threads_per_rank']} threads: done", flush=True)

    rows = []
    for one, two, many in zip(cycles[1], cycles[2], threaded):
        row = {"cycle": one["cycle"], "cells_np1": one["cells"],
               "cells_np2": two["cells"], "dofs_per_field": one["dofs_per_field"],
               "dofs_per_field_np2": two["dofs_per_field"]}
        for np, c in ((1, one), (2, two)):
            row[f"newton_np{np}"] = c["newton_iterations"]
            row[f"gmres_np{np}"] = c["linear_iterations"]
            row[f"error_np{np}"] = c["error_energy"]
            row[f"eta_np{np}"] = c["eta"]
            row[f"solve_s_np{np}"] = c["solve_seconds"]
            row[f"estimators_s_np{np}"] = estimator_seconds(c["timing"])
        row["same_mesh"] = (one["cells"] == two["cells"]
                            and one["dofs_per_field"] == two["dofs_per_field"])
        row["max_rel_diff"] = max(relative_difference(one[k], two[k])
                                  for k in ("error_energy", "eta"))
        row["speed_up"] = one["solve_seconds"] / two["solve_seconds"]
        row["same_with_threads"] = all(one[k] == many[k] for k in
                                       ("cells", "dofs_per_field", "newton_iterations",
                                        "linear_iterations", "error_energy", "eta"))
        row["solve_s_threads"] = many["solve_seconds"]
        row["speed_up_threads"] = one["solve_seconds"] / many["solve_seconds"]
        row["effectivity"] = one["effectivity"]
        rows.append(row)

    header = ["cycle", "cells", "DoFs per field", "same mesh on 2 ranks",
              "Newton (1/2)", "GMRES (1/2)", "energy error", "estimate",
              "effectivity", "largest rel. difference 1 vs 2 ranks",
              "solve np=1 (s)", "solve np=2 (s)", "estimators np=1 (s)",
              "speed-up", "same on 2 threads", "solve np=1, 2 threads (s)",
              "speed-up, 2 threads"]
    for row in rows:
        row["newton"] = f"{row['newton_np1']}/{row['newton_np2']}"
        row["gmres"] = f"{row['gmres_np1']}/{row['gmres_np2']}"
        row["same"] = "yes" if row["same_mesh"] else "no"
        row["same_threads"] = "yes" if row["same_with_threads"] else "no"
    formats = [("cycle", "{}"), ("cells_np1", "{}"), ("dofs_per_field", "{}"),
               ("same", "{}"), ("newton", "{}"), ("gmres", "{}"),
               ("error_np1", "{:.4e}"), ("eta_np1", "{:.4e}"),
               ("effectivity", "{:.3f}"), ("max_rel_diff", "{:.1e}"),
               ("solve_s_np1", "{:.2f}"), ("solve_s_np2", "{:.2f}"),
               ("estimators_s_np1", "{:.2f}"), ("speed_up", "{:.2f}"),
               ("same_threads", "{}"), ("solve_s_threads", "{:.2f}"),
               ("speed_up_threads", "{:.2f}")]
    write_table("parallel", rows, header, formats)
    total = [sum(r[f"solve_s_np{np}"] for r in rows) for np in (1, 2)]
    print(f"Total solve time: np=1 {total[0]:.1f} s, np=2 {total[1]:.1f} s, "
          f"speed-up {total[0] / total[1]:.2f}; meshes identical on every cycle: "
          f"{all(r['same_mesh'] for r in rows)}; largest relative difference "
          f"{max(r['max_rel_diff'] for r in rows):.1e}; one rank on threads identical: "
          f"{all(r['same_with_threads'] for r in rows)}, total "
          f"{sum(r['solve_s_threads'] for r in rows):.1f} s")
    print("Wrote doc/data/parallel.{csv,md}")


if __name__ == "__main__":
    main()
