#!/usr/bin/env python3
"""The contact AMG for interior penalty dG, against ILU(0)
(doc/step-membranes.md, "Interior penalty dG", "Preconditioners").

SIPG on seed-smooth (parameters/membranes-dg.prm), p = 1 and 2, nested
iteration from 8 x 8 to 128 x 128 cells, exact Newton-min with GMRES to the
relative residual 1e-12, estimators off: the same discrete solutions (the
bench checks the energy errors agree), the GMRES iterations per Newton step
and the wall time of each mesh with ILU(0) and with the contact AMG of
step-membranes applied to the interior penalty matrix. --mpi adds the AMG
runs on two processes. About 10 minutes on two cores. Writes
doc/data/dg-amg.{csv,md}. Usage, from the repository root after ./demo.sh
or ./test.sh:
  bench/dg_amg.py [--mpi]
"""
import os
import sys

from vi_bench import ROOT, program, run, write_table

PROGRAM = program("membranes")
OUT = os.path.join(ROOT, "output", "bench-dg-amg")
CASES = [("ilu", 1), ("amg", 1)] + ([("amg", 2)] if "--mpi" in sys.argv else [])


def main():
    rows = []
    for degree in (1, 2):
        errors = {}
        for preconditioner, np in CASES:
            name = f"p{degree}-{preconditioner}-np{np}"
            summary = run(PROGRAM, "membranes-dg.prm",
                          {"Discretization/Polynomial degree": degree,
                           "Mesh/Initial refinements": 3,
                           "Mesh/Cycles": 5,
                           "Linear solver/Solver": "gmres",
                           "Linear solver/Preconditioner": preconditioner,
                           "Estimators/Enabled": "false",
                           "Output/Write VTU": "false"},
                          os.path.join(OUT, name), np=np)
            for cycle in summary["cycles"]:
                newton = max(cycle["newton_iterations"], 1)
                errors.setdefault(cycle["cells"], []).append(
                    cycle["error_energy"])
                rows.append({"p": degree,
                             "preconditioner": preconditioner,
                             "processes": np,
                             "cells": cycle["cells"],
                             "unknowns per field": cycle["dofs_per_field"],
                             "Newton": cycle["newton_iterations"],
                             "GMRES": cycle["linear_iterations"],
                             "GMRES per Newton step":
                                 round(cycle["linear_iterations"] / newton, 1),
                             "seconds": round(cycle["wall_seconds"], 2),
                             "energy error": f"{cycle['error_energy']:.4e}"})
            print(f"p = {degree}, {preconditioner} on {np}: done", flush=True)
        for cells, values in errors.items():
            if max(values) > (1 + 1e-6) * min(values):
                sys.exit(f"p = {degree}, {cells} cells: the preconditioners "
                         f"end at different solutions: {values}")
    columns = [("p", "{}"), ("preconditioner", "{}"), ("processes", "{}"),
               ("cells", "{}"), ("unknowns per field", "{}"),
               ("Newton", "{}"), ("GMRES", "{}"),
               ("GMRES per Newton step", "{}"), ("seconds", "{}"),
               ("energy error", "{}")]
    write_table("dg-amg", rows, [key for key, _ in columns], columns)
    print("wrote doc/data/dg-amg.{csv,md}")


if __name__ == "__main__":
    main()
