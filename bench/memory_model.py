#!/usr/bin/env python3
"""The memory model of common/source/memory_budget.cc, measured.

Each program runs two cycles with nested iteration on seed-smooth (the
square, its default parameter file, no VTU) with each linear solver it
offers, the finer mesh having 2^r x 2^r cells; /usr/bin/time gives the
peak resident memory of the process. The bytes per unknown are the slope
between the two meshes, over the unknowns (all fields) that
memory_budget.cc counts per cell (three nodal fields; HHO: cells and
faces). memory_budget.cc charges them 25 % more.

Writes doc/data/memory-model.{csv,md}. About ten minutes:

    bench/memory_model.py
"""
import os
import tempfile

from vi_bench import program, run, write_table

# (label, program, parameter file, degree, unknowns per cell, finer meshes r)
METHODS = [("Q1", "membranes", "membranes-default.prm", 1, 3, (7, 8)),
           ("Q2", "membranes", "membranes-default.prm", 2, 12, (6, 7)),
           ("SIPG, p = 1", "membranes", "membranes-dg.prm", 1, 12, (6, 7)),
           ("HHO, p = 1", "hho", "hho-default.prm", 1, 3 * 3 + 2 * 2, (6, 7))]
# (label, Linear solver settings) per program
SOLVERS = {"membranes": [("direct", {"Linear solver/Solver": "direct"}),
                         ("GMRES + ILU", {"Linear solver/Solver": "gmres",
                                          "Linear solver/Preconditioner": "ilu"}),
                         ("GMRES + AMG", {"Linear solver/Solver": "gmres",
                                          "Linear solver/Preconditioner": "amg"})],
           "hho": [("direct", {"Linear solver/Solver": "direct"}),
                   ("CG + ILU", {"Linear solver/Solver": "cg",
                                 "Linear solver/Preconditioner": "ilu"}),
                   ("CG + AMG", {"Linear solver/Solver": "cg",
                                 "Linear solver/Preconditioner": "amg"})]}
MARGIN = 1.25
# GMRES + ILU needs thousands of iterations on SIPG: one refinement less
# (the Krylov basis, most of its memory, costs the same per unknown).
MESHES = {("SIPG, p = 1", "GMRES + ILU"): (5, 6)}


def peak_resident_bytes(name, prm, settings):
    """The peak resident memory of one run, in bytes."""
    with tempfile.TemporaryDirectory() as directory:
        record = os.path.join(directory, "time.txt")
        run(program(name), prm, settings, os.path.join(directory, "out"),
            wrapper=["/usr/bin/time", "-f", "%M", "-o", record])
        with open(record) as f:
            return 1024 * int(f.read().split()[-1])


def main():
    rows = []
    for label, name, prm, degree, per_cell, method_meshes in METHODS:
        for solver, solver_settings in SOLVERS[name]:
            resident, unknowns = [], []
            meshes = MESHES.get((label, solver), method_meshes)
            for r in meshes:
                settings = {"Mesh/Initial refinements": r - 1,
                            "Mesh/Cycles": 2,
                            "Discretization/Polynomial degree": degree,
                            "Output/Write VTU": "false",
                            **solver_settings}
                resident.append(peak_resident_bytes(name, prm, settings))
                unknowns.append(per_cell * 4 ** r)
                print(f"  {label}, {solver}, 2^{r} cells a side: "
                      f"{resident[-1] / 1e6:.0f} MB", flush=True)
            slope = (resident[1] - resident[0]) / (unknowns[1] - unknowns[0])
            rows.append({"method": label, "solver": solver,
                         "unknowns": unknowns[1],
                         "smaller_mb": resident[0] / 1e6,
                         "larger_mb": resident[1] / 1e6,
                         "bytes_per_unknown": slope,
                         "charged": MARGIN * slope})
    write_table("memory-model", rows,
                ["method", "solver", "unknowns of the larger mesh",
                 "peak, smaller mesh (MB)", "peak, larger mesh (MB)",
                 "bytes per unknown", "charged"],
                [("method", "{}"), ("solver", "{}"), ("unknowns", "{}"),
                 ("smaller_mb", "{:.0f}"), ("larger_mb", "{:.0f}"),
                 ("bytes_per_unknown", "{:.0f}"), ("charged", "{:.0f}")])


if __name__ == "__main__":
    main()
