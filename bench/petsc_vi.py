#!/usr/bin/env python3
"""Our semismooth Newton against PETSc's SNES VI, side by side (doc/performance.md).

The [DMV20] disk case (Q1, parameters/estimators-disk-p1.prm) on globally
refined meshes from 3072 to 196608 cells (1e4 to 6e5 unknowns; the next
mesh needs more memory than the 24 GB of the test machine for our
estimators; 786432 cells, 2.4e6 unknowns, without them), with nested
iteration from the boundary data. Each run of
step-membranes uses Benchmark/Compare with PETSc VI: on every mesh our
solver runs, then PETSc's SNES VI solves the same discrete problem from the
same initial iterate, in the same process, so the time ratio is meaningful
on a noisy machine. Three pairings:

  adaptive-vs-rsls  our adaptive inexact Newton-min, GMRES + contact AMG,
                    against SNESVINEWTONRSLS with GMRES + BoomerAMG (KSP
                    relative tolerance 1e-8);
  adaptive-vs-ssls  the same against SNESVINEWTONSSLS;
  inexact-vs-rsls   our inexact Newton-min (forcing term 1e-2) without
                    estimators against RSLS, both with AMG as above, one
                    mesh further (786432 cells, 2.4e6 unknowns);
  exact-vs-rsls     exact Newton-min against RSLS, both with MUMPS and
                    without estimators: the nonlinear iterations alone.

Times: ours = set-up, assembly, Newton and the estimators that stop it
and certify the error (solve_seconds; also shown without the estimators,
which the peer does not compute); the peer's = the same set-up and
assembly plus its own solve (the copy to PETSc included). In exact-vs-rsls
the estimators are off. Errors are energy errors against the
exact solution; the speed-up counts only where both errors agree within 10 %.

Writes doc/data/petsc_vi.{csv,md,png}.
Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/petsc_vi.py [--quick] [--reuse=pairing,...]
--quick stops at 12288 cells (a smoke test of the script); --reuse takes
the named pairings from the summaries of the last run.
STEP_MEMBRANES names another binary (e.g. a copy, so that the build tree
can be rebuilt while the study runs).
"""
import json
import os
import sys

from vi_bench import (DATA, ROOT, estimator_seconds, gnuplot, program,
                      run as run_program, write_table)

PROGRAM = program("membranes")
OUT = os.path.join(ROOT, "output", "bench-petsc-vi")
QUICK = "--quick" in sys.argv
CYCLES = 2 if QUICK else 4  # 3072 cells and up to three refinements
# --reuse a,b: take pairings a and b from the last run's summaries.
SKIP = next((a.split("=", 1)[1].split(",") for a in sys.argv if a.startswith("--reuse=")), [])

PAIRINGS = {
    "adaptive-vs-rsls": {"Nonlinear solver/Strategy": "adaptive",
                         "Nonlinear solver/PETSc VI type": "rsls",
                         "Linear solver/Solver": "gmres",
                         "Linear solver/Preconditioner": "amg"},
    # SSLS's line search takes short steps far from the solution: it gets
    # 200 iterations (ours needs far fewer than the default 50).
    "adaptive-vs-ssls": {"Nonlinear solver/Strategy": "adaptive",
                         "Nonlinear solver/PETSc VI type": "ssls",
                         "Nonlinear solver/Maximum iterations": 200,
                         "Linear solver/Solver": "gmres",
                         "Linear solver/Preconditioner": "amg"},
    # Without estimators (the inexact strategy does not need them) the
    # meshes go one refinement further, to 2.4e6 unknowns.
    "inexact-vs-rsls": {"Nonlinear solver/Strategy": "inexact",
                        "Nonlinear solver/PETSc VI type": "rsls",
                        "Linear solver/Solver": "gmres",
                        "Linear solver/Preconditioner": "amg",
                        "Estimators/Enabled": "false",
                        "Mesh/Cycles": CYCLES + 1},
    "exact-vs-rsls": {"Nonlinear solver/Strategy": "exact",
                      "Nonlinear solver/PETSc VI type": "rsls",
                      "Linear solver/Solver": "direct",
                      "Estimators/Enabled": "false"},
}


def run(name, settings):
    settings = {"Mesh/Cycles": CYCLES, **settings}
    settings.update({"Mesh/Initial refinements": 4,
                     "Nonlinear solver/Nested iteration": "true",
                     "Linear solver/Tolerance": "1e-8",
                     "Estimators/At every check": "false",
                     "Estimators/Sharpen final estimate": "false",
                     "Benchmark/Compare with PETSc VI": "true",
                     "Output/Write VTU": "false"})
    summary = run_program(PROGRAM, "estimators-disk-p1.prm", settings,
                          os.path.join(OUT, name))
    print(f"  {name}: done", flush=True)
    return summary["cycles"]


def load(name):
    """The summary of an earlier run (for --reuse)."""
    with open(os.path.join(OUT, name, "summary.json")) as f:
        return json.load(f)["cycles"]


def main():
    os.makedirs(OUT, exist_ok=True)
    rows = []
    for name, settings in PAIRINGS.items():
        for c in run(name, settings) if name not in SKIP else load(name):
            peer = c["petsc_vi"]
            if not peer["converged"]:
                print(f"  {name}, {c['dofs']} unknowns: {peer['reason']}")
                peer.update({"newton_iterations": "failed", "linear_iterations": "-",
                             "error_energy": float("nan"),
                             "residual_complementarity": float("nan"),
                             "relative_distance_to_ours": float("nan")})
            timing = c["timing"]
            shared = timing.get("setup", 0.) + timing.get("assembly", 0.)
            peer_seconds = shared + peer["seconds"]
            same_error = abs(peer["error_energy"] / c["error_energy"] - 1) <= 0.1  # NaN: False
            estimators = estimator_seconds(timing)
            rows.append({
                "pairing": name, "cells": c["cells"], "unknowns": c["dofs"],
                "newton": c["newton_iterations"], "linear": c["linear_iterations"],
                "error": c["error_energy"], "seconds": c["solve_seconds"],
                "estimator_seconds": estimators,
                "peer": peer["solver"], "peer_newton": peer["newton_iterations"],
                "peer_linear": peer["linear_iterations"],
                "peer_error": peer["error_energy"], "peer_seconds": peer_seconds,
                "peer_complementarity": peer["residual_complementarity"],
                "distance": peer["relative_distance_to_ours"],
                "speedup": peer_seconds / c["solve_seconds"] if same_error else float("nan"),
                "speedup_without_estimators":
                    peer_seconds / (c["solve_seconds"] - estimators) if same_error else float("nan")})

    header = ["pairing", "unknowns", "ours: Newton", "GMRES", "error", "time (s)",
              "of which estimators", "peer", "Newton", "KSP", "error", "time (s)",
              "peer / ours", "peer / ours without estimators", "distance"]
    formats = [("pairing", "{}"), ("unknowns", "{}"), ("newton", "{}"),
               ("linear", "{}"), ("error", "{:.4e}"), ("seconds", "{:.2f}"),
               ("estimator_seconds", "{:.2f}"),
               ("peer", "{}"), ("peer_newton", "{}"), ("peer_linear", "{}"),
               ("peer_error", "{:.4e}"), ("peer_seconds", "{:.2f}"),
               ("speedup", "{:.2f}"), ("speedup_without_estimators", "{:.2f}"),
               ("distance", "{:.1e}")]
    write_table("petsc_vi", rows, header, formats)

    dat = os.path.join(OUT, "petsc_vi.dat")
    with open(dat, "w") as f:
        for name in PAIRINGS:
            f.write(f"# {name}: unknowns, ours (s), peer (s)\n")
            for row in rows:
                if row["pairing"] == name:
                    f.write(f"{row['unknowns']} {row['seconds']} {row['peer_seconds']}\n")
            f.write("\n\n")
    script = f"""
set terminal pngcairo size 900,600 font ',11'
set output '{os.path.join(DATA, 'petsc_vi.png')}'
set logscale xy
set grid
set key left top font ',9'
set xlabel 'unknowns (u1, u2, lambda)'
set ylabel 'wall time of the solve on each mesh (s)'
set title '[DMV20] disk, Q1, nested iteration: our semismooth Newton against PETSc SNES VI'
plot '{dat}' index 0 using 1:2 with linespoints lw 2 pt 7 lc 1 title 'ours: adaptive inexact Newton-min, GMRES + contact AMG', \\
     '{dat}' index 0 using 1:3 with linespoints lw 2 pt 5 lc 2 title 'RSLS, GMRES (rtol 1e-8) + BoomerAMG', \\
     '{dat}' index 1 using 1:3 with linespoints lw 2 pt 9 lc 3 title 'SSLS, GMRES (rtol 1e-8) + BoomerAMG', \\
     '{dat}' index 2 using 1:2 with linespoints lw 2 pt 7 lc 4 title 'ours: inexact Newton-min (rtol 1e-2), no estimators, GMRES + contact AMG', \\
     '{dat}' index 2 using 1:3 with linespoints lw 1 pt 5 lc 4 dt 2 title 'RSLS, GMRES (rtol 1e-2) + BoomerAMG', \\
     '{dat}' index 3 using 1:2 with linespoints lw 1 pt 6 lc 1 dt 2 title 'ours: exact Newton-min, MUMPS, no estimators', \\
     '{dat}' index 3 using 1:3 with linespoints lw 1 pt 4 lc 2 dt 2 title 'RSLS, MUMPS'
"""
    gnuplot(script)
    print(f"wrote {os.path.join(DATA, 'petsc_vi')}.{{csv,md,png}}")


if __name__ == "__main__":
    main()
