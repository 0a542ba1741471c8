#!/usr/bin/env python3
"""Estimator-driven adaptive refinement against uniform refinement
(doc/performance.md): the energy error and the estimate against the number
of unknowns for the seed's jump test (on the square and on the mesh fitted
to the circle r = 1/3) and the L-shape corner singularity,
Q1 and Q2, with the Newton iterations of every cycle (nested iteration).

Writes doc/data/adaptivity.{csv,md} and doc/data/adaptivity-<case>.png
(with --method sipg|nipg|iipg: adaptivity-<method>.{csv,md} and
adaptivity-<method>-<case>.png, the same study with the dG method).
Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/membranes_adaptivity.py [--method fem|sipg|nipg|iipg] [--tables-only]
--tables-only writes the table and the plots again from the runs recorded in
doc/data/adaptivity[-<method>].csv, without running them.
STEP_MEMBRANES names another binary (e.g. a copy, so that the build tree can
be rebuilt while the study runs).
"""
import os
import sys

from vi_bench import (DATA, ROOT, plot_png, program, read_table, run as run_program,
                      write_csv, write_dat, write_md)

PROGRAM = program("membranes")
# --method: the discretisation (Discretization/Method)
METHOD = sys.argv[sys.argv.index("--method") + 1] if "--method" in sys.argv else "fem"
if METHOD not in ("fem", "sipg", "nipg", "iipg"):
    sys.exit(f"--method {METHOD}: use fem, sipg, nipg or iipg")
# the stem of the data files and of the output folder
STEM = "adaptivity" if METHOD == "fem" else f"adaptivity-{METHOD}"
LABEL = "Q" if METHOD == "fem" else f"{METHOD.upper()} Q"
OUT = os.path.join(ROOT, "output", "bench-" + STEM)
# --tables-only: the table and the plots again from doc/data/<STEM>.csv
TABLES_ONLY = "--tables-only" in sys.argv

# case: (scene, initial refinements); the fitted square-circle mesh starts
# from 20 cells, the square from one.
CASES = {"seed-jump": ("membranes-seed-jump.prm", 2),
         "seed-jump-fitted": ("membranes-seed-jump-fitted.prm", 0),
         "l-shape": ("membranes-l-shape.prm", 2)}
# Cycles so that both refinements reach about 1e4 - 1e5 unknowns per field
# (Q2 adaptive on the fitted mesh, whose error falls fastest: a few thousand).
# (uniform, adaptive) cycles per degree; the unfitted seed-jump Q2 runs go
# further: their adaptive error falls in steps (the band of cut cells and
# the smooth region take turns in the marking), and 16 cycles end inside
# one step.
CYCLES = {1: (6, 16), 2: (5, 16)}
# (dG has (p + 1)^2 unknowns per cell and field, FEM about p^2: fewer
# adaptive cycles reach as many unknowns)
LONGER = {("seed-jump", 2): (6, 26 if METHOD == "fem" else 22)}
RUNS = [(case, p, refinement, cycles)
        for case in CASES
        for p in (1, 2)
        for refinement, cycles in zip(("global", "adaptive"),
                                      LONGER.get((case, p), CYCLES[p]))]
# The fitted orders: least squares of log(error) against log(N) over the
# cycles with at least this many unknowns per field.
FIT_FROM = (1000, 10000)


def run(case, p, refinement, cycles):
    name = f"{case}-p{p}-{refinement}"
    settings = {"Discretization/Method": METHOD,
                "Discretization/Polynomial degree": p, "Mesh/Refinement": refinement,
                "Mesh/Cycles": cycles, "Mesh/Initial refinements": CASES[case][1],
                "Mesh/Marking": "dorfler", "Mesh/Refinement fraction": 0.5,
                "Output/Write VTU": "false"}
    summary = run_program(PROGRAM, CASES[case][0], settings, os.path.join(OUT, name))
    print(f"  {name}: done", flush=True)
    return summary["cycles"]


def main():
    os.makedirs(DATA, exist_ok=True)
    rows = []
    if TABLES_ONLY:
        rows = read_table(STEM)
    for case, p, refinement, cycles in ([] if TABLES_ONLY else RUNS):
        for c in run(case, p, refinement, cycles):
            rows.append({"case": case, "p": p, "refinement": refinement,
                         "cycle": c["cycle"], "cells": c["cells"],
                         "dofs_per_field": c["dofs_per_field"],
                         "newton": c["newton_iterations"],
                         "error_energy": c["error_energy"], "eta": c["eta"],
                         "effectivity": c["effectivity"],
                         "wall_seconds": c["wall_seconds"]})
    if not TABLES_ONLY:
        write_csv(STEM, rows)

    # The convergence order in DoFs over the last three cycles of each run,
    # and fitted over all its cycles from FIT_FROM unknowns on.
    lines = ["| case | p | refinement | cycles | final DoFs per field | final error | "
             "order in DoFs (last 3 cycles) | "
             + " | ".join(f"order of error / estimate (fit, N >= {n})" for n in FIT_FROM)
             + " | optimal | Newton per cycle | effectivity range |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    import math

    def fitted_order(r, key, smallest):
        points = [(math.log(x["dofs_per_field"]), math.log(x[key]))
                  for x in r if x["dofs_per_field"] >= smallest]
        if len(points) < 2:
            return float("nan")
        mx = sum(a for a, _ in points) / len(points)
        my = sum(b for _, b in points) / len(points)
        return -sum((a - mx) * (b - my) for a, b in points) / sum(
            (a - mx) ** 2 for a, _ in points)
    for case, p, refinement, cycles in RUNS:
        r = [x for x in rows if (x["case"], x["p"], x["refinement"]) == (case, p, refinement)]
        a, b = r[-3], r[-1]
        order = -math.log(b["error_energy"] / a["error_energy"]) / math.log(
            b["dofs_per_field"] / a["dofs_per_field"])
        newton = " ".join(str(x["newton"]) for x in r)
        eff = [x["effectivity"] for x in r]
        fit = " | ".join(f"{fitted_order(r, 'error_energy', n):.2f} / "
                         f"{fitted_order(r, 'eta', n):.2f}".replace("nan", "-")
                         for n in FIT_FROM)
        lines.append(f"| {case} | {p} | {refinement} | {len(r)} | {b['dofs_per_field']} | "
                     f"{b['error_energy']:.3e} | {order:.2f} | {fit} | {p / 2:.2f} | {newton} | "
                     f"{min(eff):.2f} - {max(eff):.2f} |")
    write_md(STEM, lines)

    for case in CASES:
        dat = os.path.join(DATA, f"{STEM}-{case}.dat")
        series = [(p, refinement) for p in (1, 2) for refinement in ("global", "adaptive")]
        write_dat(dat, [(f"{case} p={p} {refinement}",
                         [(x["dofs_per_field"], x["error_energy"], x["eta"]) for x in rows
                          if (x["case"], x["p"], x["refinement"]) == (case, p, refinement)])
                        for p, refinement in series])
        colours = {1: "#0072b2", 2: "#d55e00"}
        plots = []
        for n, (p, refinement) in enumerate(series):
            dash = "dt 1" if refinement == "adaptive" else "dt 2"
            plots.append(f"'{dat}' index {n} using 1:2 with linespoints {dash} pt 7 "
                         f"lc rgb '{colours[p]}' title 'error, {LABEL}{p}, {refinement}'")
            plots.append(f"'{dat}' index {n} using 1:3 with lines {dash} lw 1 "
                         f"lc rgb '{colours[p]}' notitle")
        plots.append("2*x**(-0.5) with lines dt 3 lc rgb 'gray' title 'DoFs^{-1/2}'")
        plots.append("2*x**(-1.0) with lines dt 4 lc rgb 'gray' title 'DoFs^{-1}'")
        plot_png(f"{DATA}/{STEM}-{case}.png",
                 ["set logscale xy", "set format y '10^{%L}'",
                  "set xlabel 'unknowns per field'",
                  "set ylabel 'energy error (points), estimate (thin lines)'",
                  f"set title '{case}: uniform (dashed) and Dorfler-adaptive (solid) "
                  "refinement'",
                  "set key bottom left", "set grid"],
                 plots)
        os.remove(dat)
    print(f"wrote {DATA}/{STEM}.*")


if __name__ == "__main__":
    main()
