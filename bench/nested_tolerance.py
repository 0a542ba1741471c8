#!/usr/bin/env python3
"""Newton's tolerance along a nested sequence of meshes (doc/performance.md,
"Newton's tolerance on nested meshes").

The contact solve of the cost study from its coarser start
(bench/membranes_cost.py --flux-degree=p-1 --coarse-start: the disk scene,
Q1, adaptive inexact semismooth Newton with GMRES + AMG, nested iteration
over six globally refined meshes from 768 cells to 7.9e5 unknowns per
field, RT_0 fluxes) for several gamma_lin (Nonlinear solver/gamma_lin:
Newton stops when eta_lin <= gamma_lin eta_disc; gamma_alg stays 0.3),
with both C-functions, on one process with one thread. Per mesh: Newton
steps, eta_lin / eta_disc at the stop, the effectivity, and the contact
solve against two Poisson solves timed in the same run. The table sums
the meshes from 1e4 unknowns per field on: Newton steps, and the contact
solves' time over the Poisson pairs' (one run each: the counts and
effectivities are exact, the ratios carry the machine's noise).

Writes doc/data/nested-tolerance.{csv,md,png} (--quick: nested-tolerance-quick.*). Usage, from the repository
root after ./demo.sh or ./test.sh:
  bench/nested_tolerance.py [--quick] [--tables-only]
--quick stops at about 5e4 unknowns per field (a smoke test of the script).
--tables-only writes the table and the plot again from the study's
doc/data/nested-tolerance.csv, without running it.
The full study takes about 15 minutes and 8 GB of memory.
STEP_MEMBRANES names another binary (see vi_bench.program).
"""
import os
import sys

from vi_bench import (DATA, ROOT, cost_study_settings, plot_png, poisson_seconds, program,
                      read_table, run, write_csv, write_dat, write_markdown)

PROGRAM = program("membranes")
OUT = os.path.join(ROOT, "output", "bench-nested-tolerance")
QUICK = "--quick" in sys.argv
TABLES_ONLY = "--tables-only" in sys.argv
STEM = "nested-tolerance" + ("-quick" if QUICK else "")
C_FUNCTIONS = ["min", "fischer-burmeister"]
GAMMAS = [0.5, 0.3, 0.2, 0.1, 0.05, 0.02]
# 768 cells, then five refinements (--quick: three)
CYCLES = 4 if QUICK else 6
# the meshes the cost targets are about
SMALLEST = 10000


def run_sequence(c_function, gamma):
    settings = {**cost_study_settings(c_function, "p-1", 3),
                "Nonlinear solver/gamma_lin": gamma,
                "Mesh/Cycles": CYCLES,
                "Benchmark/Reference Poisson solve": "true",
                "Output/Write VTU": "false"}
    directory = os.path.join(OUT, f"{c_function}-gamma-lin-{gamma}")
    cycles = run(PROGRAM, "estimators-disk-p1.prm", settings, directory, threads=1)["cycles"]
    print(f"  {c_function}, gamma_lin = {gamma}: done", flush=True)
    return [{"c_function": c_function, "gamma_lin": gamma, "cycle": c["cycle"],
             "dofs_per_field": c["dofs_per_field"], "newton": c["newton_iterations"],
             "gmres": c["linear_iterations"], "error_energy": c["error_energy"],
             "eta_lin_over_eta_disc": c["eta_lin"] / c["eta_disc"],
             "effectivity": c["effectivity"], "solve_seconds": c["solve_seconds"],
             "poisson_seconds": poisson_seconds(c)}
            for c in cycles]


def summarise(rows):
    """One row per (C-function, gamma_lin): the steps of every mesh, and
    the sums and ranges over the meshes from SMALLEST unknowns per field."""
    table = []
    for c_function in C_FUNCTIONS:
        for gamma in GAMMAS:
            runs = [r for r in rows if r["c_function"] == c_function and r["gamma_lin"] == gamma]
            large = [r for r in runs if r["dofs_per_field"] >= SMALLEST]
            table.append({
                "c_function": c_function, "gamma_lin": gamma,
                "steps": " ".join(str(r["newton"]) for r in runs),
                "steps_large": sum(r["newton"] for r in large),
                "gmres_large": sum(r["gmres"] for r in large),
                "ratio": (sum(r["solve_seconds"] for r in large)
                          / sum(r["poisson_seconds"] for r in large)),
                "ratio_largest": large[-1]["solve_seconds"] / large[-1]["poisson_seconds"],
                "eta_lin": "{:.3f} - {:.3f}".format(
                    min(r["eta_lin_over_eta_disc"] for r in large),
                    max(r["eta_lin_over_eta_disc"] for r in large)),
                "effectivity": "{:.3f} - {:.3f}".format(min(r["effectivity"] for r in large),
                                                        max(r["effectivity"] for r in large)),
                "effectivity_max": max(r["effectivity"] for r in large)})
    return table


def main():
    if TABLES_ONLY:
        if not os.path.isfile(os.path.join(DATA, STEM + ".csv")):
            sys.exit(f"nested_tolerance.py: no doc/data/{STEM}.csv to write the tables "
                     "from; run the study first")
        rows = read_table(STEM)
    else:
        rows = [r for c_function in C_FUNCTIONS for gamma in GAMMAS
                for r in run_sequence(c_function, gamma)]
        write_csv(STEM, rows)
    table = summarise(rows)
    write_markdown(
        STEM, table,
        ["C-function", "gamma_lin", "Newton steps per mesh, from 768 cells",
         "Newton steps, meshes from 1e4", "GMRES, meshes from 1e4",
         "contact solves / Poisson pairs, meshes from 1e4", "ratio, largest mesh",
         "eta_lin / eta_disc at the stop, meshes from 1e4", "effectivity, meshes from 1e4"],
        [("c_function", "{}"), ("gamma_lin", "{}"), ("steps", "{}"), ("steps_large", "{}"),
         ("gmres_large", "{}"), ("ratio", "{:.2f}"), ("ratio_largest", "{:.2f}"),
         ("eta_lin", "{}"), ("effectivity", "{}")])

    os.makedirs(OUT, exist_ok=True)
    dat = os.path.join(OUT, f"{STEM}.dat")
    write_dat(dat, [(f"{c_function}: gamma_lin, contact solves / Poisson pairs, "
                     "largest effectivity, Newton steps (meshes from 1e4)",
                     [(r["gamma_lin"], r["ratio"], r["effectivity_max"], r["steps_large"])
                      for r in table if r["c_function"] == c_function])
                    for c_function in C_FUNCTIONS])
    curves = []
    for index, (c_function, colour) in enumerate(zip(C_FUNCTIONS, (1, 6))):
        curves.append(f"'{dat}' index {index} using 1:2 axes x1y1 with linespoints lw 2 pt 7 "
                      f"lc {colour} title 'Newton-{c_function}: contact solves / Poisson pairs'")
        curves.append(f"'{dat}' index {index} using 1:3 axes x1y2 with linespoints lw 2 pt 6 "
                      f"dt 2 lc {colour} title 'Newton-{c_function}: largest effectivity'")
    largest = "5e4" if QUICK else "7.9e5"
    plot_png(os.path.join(DATA, STEM + ".png"),
             ["set logscale x", "set xrange [0.015:0.7]",
              f"set xtics ({', '.join(str(g) for g in GAMMAS)})", "set grid",
              "set key below font ',9'",
              "set xlabel 'gamma_lin (Newton stops when eta_lin <= gamma_lin eta_disc)' "
              "noenhanced",
              "set ylabel 'contact solves / two Poisson solves (meshes from 1e4)'",
              "set y2label 'largest effectivity on these meshes'",
              "set ytics nomirror", "set y2tics",
              f'set title "Nested disk meshes from 768 cells to {largest} unknowns per '
              'field\\n(Q1, adaptive inexact Newton, GMRES + AMG, RT_0 fluxes, one thread, '
              'one run each)"'],
             curves, size="900,650", font=11)
    print(f"wrote {os.path.join(DATA, STEM)}.{{csv,md,png}}")


if __name__ == "__main__":
    main()
