#!/usr/bin/env python3
"""FEM, dG (SIPG) and HHO side by side (doc/performance.md, "FEM, dG and
HHO side by side"): the energy error and the estimate against the number of
unknowns and against the wall time, uniform and adaptive refinement, p = 1
and 2, on the seed's two tests and the L-shape.

Each method runs with the solver a user would take for it, estimators on,
nested iteration:
  FEM (Q_p), SIPG (Q_p broken)  step-membranes, the adaptive inexact
                                strategy (GMRES + contact AMG, stopped by
                                the estimators); uniform and Dorfler (0.5)
                                adaptive refinement
  HHO (P_p cells, P_{p-1} faces) step-hho, exact Newton, CG + AMG on the
                                condensed systems; uniform and Dorfler
                                (0.5) adaptive refinement
The unknowns are those of the whole nonlinear system (both membranes and
the multiplier; HHO's before condensation); the wall time is summed over the
meshes, estimates included.

Writes doc/data/methods-comparison.{csv,md} and
doc/data/methods-comparison-<case>.png. About ten minutes on two cores.
Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/methods_comparison.py [--tables-only]
--tables-only draws the tables and plots again from the CSV.
STEP_MEMBRANES and STEP_HHO name other binaries.
"""
import math
import os
import sys

from vi_bench import DATA, ROOT, gnuplot, program, read_table, run, write_csv, write_dat, write_md

OUT = os.path.join(ROOT, "output", "bench-methods-comparison")
TABLES_ONLY = "--tables-only" in sys.argv
# case: (step-membranes scene, step-hho scene, initial refinements)
CASES = {"seed-smooth": ("membranes-seed-smooth.prm", "hho-seed-smooth.prm", 2),
         "seed-jump": ("membranes-seed-jump.prm", "hho-seed-jump.prm", 2),
         "L-shape": ("membranes-l-shape.prm", "membranes-l-shape.prm", 1)}
METHODS = [("fem", "FEM"), ("sipg", "SIPG"), ("hho", "HHO")]
# (uniform, adaptive) cycles per degree: up to a few 1e5 unknowns
CYCLES = {1: (7, 18), 2: (6, 18)}


def runs():
    for case in CASES:
        for p in (1, 2):
            for method, _ in METHODS:
                for refinement in ("global", "adaptive"):
                    yield case, p, method, refinement


def solve(case, p, method, refinement):
    membranes_scene, hho_scene, initial = CASES[case]
    cycles = CYCLES[p][0 if refinement == "global" else 1]
    settings = {"Discretization/Polynomial degree": p,
                "Mesh/Initial refinements": initial, "Mesh/Cycles": cycles,
                "Mesh/Refinement": refinement, "Mesh/Marking": "dorfler",
                "Mesh/Refinement fraction": 0.5,
                "Nonlinear solver/Nested iteration": "true",
                "Estimators/Enabled": "true", "Output/Write VTU": "false"}
    if method == "hho":
        binary, scene = program("hho"), hho_scene
        settings.update({"Discretization/Method": "hho",
                         "Linear solver/Solver": "cg",
                         "Linear solver/Preconditioner": "amg"})
    else:
        binary, scene = program("membranes"), membranes_scene
        settings.update({"Discretization/Method": method,
                         "Nonlinear solver/Strategy": "adaptive",
                         "Linear solver/Solver": "gmres",
                         "Linear solver/Preconditioner": "amg"})
    name = f"{case}-p{p}-{method}-{refinement}"
    summary = run(binary, scene, settings, os.path.join(OUT, name))
    print(f"  {name}: done", flush=True)
    rows, seconds = [], 0.
    for c in summary["cycles"]:
        seconds += c["wall_seconds"]
        unknowns = c["dofs"] if method == "hho" else 3 * c["dofs_per_field"]
        rows.append({"case": case, "p": p, "method": method,
                     "refinement": refinement, "cycle": c["cycle"],
                     "cells": c["cells"], "unknowns": unknowns,
                     "newton": c["newton_iterations"],
                     "error_energy": c["error_energy"], "eta": c["eta"],
                     "effectivity": c["effectivity"], "seconds": seconds})
    return rows


# The order in unknowns: least squares of log(error) against log(N) over
# the meshes with at least this many unknowns (the first meshes are
# pre-asymptotic, and the adaptive errors of seed-jump fall in steps).
FIT_FROM = 3000


def order(rows):
    points = [(math.log(x["unknowns"]), math.log(x["error_energy"]))
              for x in rows if x["unknowns"] >= FIT_FROM]
    mx = sum(a for a, _ in points) / len(points)
    my = sum(b for _, b in points) / len(points)
    return -sum((a - mx) * (b - my) for a, b in points) / sum(
        (a - mx) ** 2 for a, _ in points)


def tables(rows):
    lines = ["| case | p | method | refinement | meshes | final unknowns | "
             f"final error | order in unknowns (fit, N >= {FIT_FROM}) | effectivity, "
             "first ... last | seconds (all meshes) |",
             "|---|---:|---|---|---:|---:|---:|---:|---|---:|"]
    labels = dict(METHODS)
    for case, p, method, refinement in runs():
        r = [x for x in rows if (x["case"], x["p"], x["method"], x["refinement"])
             == (case, p, method, refinement)]
        lines.append(f"| {case} | {p} | {labels[method]} | {refinement} | {len(r)} | "
                     f"{r[-1]['unknowns']} | {r[-1]['error_energy']:.3e} | "
                     f"{order(r):.2f} | {r[0]['effectivity']:.2f} ... "
                     f"{r[-1]['effectivity']:.2f} | {r[-1]['seconds']:.1f} |")
    # The time each run takes to reach the largest final error of its case
    # and degree (log-log interpolation between meshes).
    lines += ["", "| case | p | error | " + " | ".join(
        f"{labels[m]} {'uniform' if r == 'global' else 'adaptive'}"
        for m, _ in METHODS for r in ("global", "adaptive")) + " |",
              "|---|---:|---:|" + "---:|" * 6]
    for case in CASES:
        for p in (1, 2):
            group = {(m, r): [x for x in rows if (x["case"], x["p"], x["method"],
                                                  x["refinement"]) == (case, p, m, r)]
                     for c, q, m, r in runs() if (c, q) == (case, p)}
            target = max(r[-1]["error_energy"] for r in group.values())
            lines.append(f"| {case} | {p} | {target:.2e} | " + " | ".join(
                f"{seconds_to(r, target):.2f} s" for r in group.values()) + " |")
    write_md("methods-comparison", lines)


def seconds_to(rows, target):
    """The wall time at which a run's error reaches target."""
    for previous, x in zip([None] + rows[:-1], rows):
        if x["error_energy"] <= target:
            if previous is None:
                return x["seconds"]
            t = math.log(target / previous["error_energy"]) / math.log(
                x["error_energy"] / previous["error_energy"])
            return previous["seconds"] * (x["seconds"] / previous["seconds"]) ** t
    return float("nan")


def plots(rows):
    labels = dict(METHODS)
    colours = {"fem": "#1f77b4", "sipg": "#d62728", "hho": "#2ca02c"}
    for case in CASES:
        dat = os.path.join(DATA, f"methods-comparison-{case}.dat")
        keys = [(p, method, refinement) for c, p, method, refinement in runs()
                if c == case]
        write_dat(dat, [(f"{p} {m} {r}",
                         [(x["unknowns"], x["seconds"], x["error_energy"], x["eta"])
                          for x in rows if (x["case"], x["p"], x["method"],
                                            x["refinement"]) == (case, p, m, r)])
                        for p, m, r in keys])
        panels = []
        for p in (1, 2):
            for column, xlabel in ((1, "unknowns"), (2, "wall time in seconds, all meshes")):
                items = []
                for index, (q, m, r) in enumerate(keys):
                    if q != p:
                        continue
                    style = "lw 2" if r == "adaptive" else "lw 1"
                    point = 7 if r == "adaptive" else 6
                    name = f"{labels[m]} {'adaptive' if r == 'adaptive' else 'uniform'}"
                    items.append(f"'{dat}' index {index} using {column}:3 with "
                                 f"linespoints {style} pt {point} lc rgb "
                                 f"'{colours[m]}' title '{name}'")
                    items.append(f"'{dat}' index {index} using {column}:4 with "
                                 f"lines dt 2 lc rgb '{colours[m]}' notitle")
                panels.append(f"set title '{case}, p = {p}: error (solid), "
                              f"estimate (dashed)'\nset xlabel '{xlabel}'\n"
                              f"plot {', '.join(items)}")
        gnuplot(f"""set terminal pngcairo size 1400,1000 font ',11'
set output '{os.path.join(DATA, f"methods-comparison-{case}.png")}'
set multiplot layout 2,2
set logscale xy
set format y '10^{{%L}}'
set ylabel 'energy error'
set key bottom left
set grid
""" + "\n".join(panels) + "\nunset multiplot\n")
        os.remove(dat)


def main():
    rows = read_table("methods-comparison") if TABLES_ONLY else [
        row for key in runs() for row in solve(*key)]
    if not TABLES_ONLY:
        write_csv("methods-comparison", rows)
    tables(rows)
    plots(rows)
    print("wrote doc/data/methods-comparison.{csv,md} and "
          "methods-comparison-<case>.png")


if __name__ == "__main__":
    main()
