#!/usr/bin/env python3
"""The obstacle problem with a known free boundary (doc/step-membranes.md,
"The obstacle problem"): parameters/membranes-obstacle.prm (Bueler's radial
test, PETSc's SNES ex9) with Problem/Smooth obstacle = true, nested
iteration, exact solves (MUMPS), Q1 from 8 x 8 to 1024 x 1024 cells and Q2
to 128 x 128. Per mesh: Newton steps, the energy error and its rate, eta,
the effectivity and the radius of the disk with the area of the contact
nodes (original coordinates, (-2,2)^2: each node stands for (h/p)^2).

Writes doc/data/obstacle-radial.{csv,md}. About five minutes on two cores
(most of it the Q1 mesh of 1024 x 1024 cells, 1.05e6 unknowns per field).
Run from the repository root after ./demo.sh or ./test.sh, as the other
scripts; --reuse takes the summaries of the last run.
"""
import json
import math
import os
import sys

from vi_bench import ROOT, program, run, write_csv, write_md

# (degree, meshes from 8 x 8 cells)
RUNS = [(1, 8), (2, 5)]
OUT = os.path.join(ROOT, "output", "bench-obstacle-radial")
REUSE = "--reuse" in sys.argv


def main():
    rows = []
    for p, cycles in RUNS:
        directory = os.path.join(OUT, f"p{p}")
        if REUSE:
            with open(os.path.join(directory, "summary.json")) as f:
                summary = json.load(f)
        else:
            summary = run(program("membranes"), "membranes-obstacle.prm",
                          {"Problem/Smooth obstacle": "true",
                           "Discretization/Polynomial degree": p,
                           "Mesh/Cycles": cycles,
                           "Estimators/Enabled": "true",
                           "Output/Write VTU": "false"},
                          directory)
        previous = None
        for c in summary["cycles"]:
            # each node of Q_p stands for (h / p)^2
            h = 4.0 / math.sqrt(c["cells"]) / p
            rate = (math.log2(previous / c["error_energy"]) if previous else None)
            previous = c["error_energy"]
            rows.append({"p": p, "cells": c["cells"],
                         "newton": c["newton_iterations"],
                         "error_energy": c["error_energy"], "rate": rate,
                         "eta": c["eta"], "effectivity": c["effectivity"],
                         "radius": math.sqrt(c["contact_nodes"] * h * h / math.pi)})
        print(f"  p={p}: done", flush=True)
    write_csv("obstacle-radial", rows)
    lines = ["| p | cells | Newton | energy error | rate | eta | effectivity | "
             "radius (a = 0.6980) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        rate = f"{r['rate']:.2f}" if r["rate"] is not None else ""
        lines.append(f"| {r['p']} | {r['cells']} | {r['newton']} | "
                     f"{r['error_energy']:.3g} | {rate} | {r['eta']:.3g} | "
                     f"{r['effectivity']:.2f} | {r['radius']:.3f} |")
    write_md("obstacle-radial", lines, echo=True)
    print("wrote doc/data/obstacle-radial.{csv,md}")


if __name__ == "__main__":
    main()
