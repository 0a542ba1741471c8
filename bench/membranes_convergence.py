#!/usr/bin/env python3
"""Convergence study of step-membranes (doc/step-membranes.md).

Runs the seed's tests for several polynomial degrees, with and without
nested iteration, and writes into doc/data/:
  membranes-convergence.csv   one row per (test, p, nested, cycle)
  membranes-convergence.md    the tables quoted in doc/step-membranes.md
  membranes-convergence.png   energy error against DoFs (gnuplot)

Usage: bench/membranes_convergence.py [--quick]   (from the repository root,
after ./demo.sh or ./test.sh has built the programs). --quick runs fewer
cycles for a smoke test.
"""
import math
import os
import sys

from vi_bench import (DATA, ROOT, convergence_rows, plot_png, program, run as run_program,
                      write_csv, write_dat, write_md)

PROGRAM = program("membranes")
QUICK = "--quick" in sys.argv

# (scene, degree, cycles): cycles from 4x4 cells on.
RUNS = [("seed-smooth", 1, 6), ("seed-smooth", 2, 6), ("seed-smooth", 3, 5),
        ("seed-smooth", 4, 5), ("seed-jump", 1, 6), ("seed-jump", 2, 6)]


def run(test, degree, cycles, nested):
    if QUICK:
        cycles = min(cycles, 3)
    settings = {"Discretization/Polynomial degree": degree, "Mesh/Cycles": cycles,
                "Nonlinear solver/Nested iteration": nested,
                # From zero, Newton-min needs O(1/h) iterations.
                "Nonlinear solver/Maximum iterations": 500}
    return run_program(PROGRAM, f"membranes-{test}.prm", settings,
                       os.path.join(ROOT, "output", "bench", f"{test}-p{degree}-nested-{nested}")
                       )["cycles"]


def rate(previous, current):
    # rate in h from the DoF count (d = 2)
    return 2 * math.log(previous["error_energy"] / current["error_energy"]) / \
        math.log(current["dofs_per_field"] / previous["dofs_per_field"])


def main():
    os.makedirs(DATA, exist_ok=True)
    rows, tables = [], []
    for test, degree, cycles in RUNS:
        nested_values = ["true", "false"] if test == "seed-smooth" else ["true"]
        results = {nested: run(test, degree, cycles, nested) for nested in nested_values}
        print(f"{test} p={degree}: done", flush=True)
        for nested, records in results.items():
            rows += convergence_rows(records, rate,
                                     {"test": test, "p": degree, "nested": nested},
                                     lambda c: {"dofs_per_field": c["dofs_per_field"],
                                                "newton": c["newton_iterations"]})
        nested = results["true"]
        lines = [f"#### {test}, Q{degree}", "",
                 "| cells | DoFs per field | energy error | rate | Newton-min (nested) |"
                 + (" Newton-min (from zero) |" if "false" in results else ""),
                 "|---:|---:|---:|---:|---:|" + ("---:|" if "false" in results else "")]
        for n, c in enumerate(nested):
            line = (f"| {c['cells']} | {c['dofs_per_field']} | {c['error_energy']:.3e} | "
                    f"{rate(nested[n - 1], c):.2f} | " if n else
                    f"| {c['cells']} | {c['dofs_per_field']} | {c['error_energy']:.3e} | - | ")
            line += f"{c['newton_iterations']} |"
            if "false" in results:
                line += f" {results['false'][n]['newton_iterations']} |"
            lines.append(line)
        tables.append("\n".join(lines))

    write_csv("membranes-convergence", rows)
    write_md("membranes-convergence", tables, separator="\n\n")

    # gnuplot: energy error against DoFs per field, nested runs.
    dat = os.path.join(DATA, "membranes-convergence.dat")
    write_dat(dat, [(f"{test} p={degree}",
                     [(r["dofs_per_field"], r["error_energy"]) for r in rows
                      if r["test"] == test and r["p"] == degree and r["nested"] == "true"])
                    for test, degree, _ in RUNS])
    plots = []
    for index, (test, degree, _) in enumerate(RUNS):
        plots.append(f"'{dat}' index {index} with linespoints lw 2 pt {index + 4} "
                     f"title '{test}, Q{degree}'")
    for p in (1, 2, 3, 4):
        plots.append(f"{2.0 ** (p / 2) * 0.05}*x**(-{p}/2.) dt 2 lc rgb 'gray' "
                     f"notitle")
    plot_png(os.path.join(DATA, "membranes-convergence.png"),
             ["set logscale xy", "set format y '10^{%L}'", "set xlabel 'DoFs per field'",
              "set ylabel 'energy error |||u - u_h|||'",
              "set title 'step-membranes: seed tests, uniform refinement "
              "(dashed: DoFs^{-p/2})'",
              "set key bottom left", "set grid"],
             plots, size="900,650")
    os.remove(dat)
    print(f"wrote {DATA}/membranes-convergence.{{csv,md,png}}")


if __name__ == "__main__":
    main()
