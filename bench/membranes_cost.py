#!/usr/bin/env python3
"""What a contact solve costs against a Poisson solve (doc/performance.md).

In one run of step-membranes per configuration, on globally refined meshes
of the unit disk from about 1e4 to 7.9e5 unknowns per field (Q1; 3 fields,
2.4e6 unknowns on the finest mesh), on one process with one thread, on one
process with all cores (deal.II's default: in both solves the cell loops
run on threads, Trilinos' AMG and Krylov solvers on one) and on two
processes:
the contact problem solved by adaptive inexact semismooth Newton-min with
GMRES + AMG and nested iteration (set-up, assembly, Newton, linear solves
and the estimators that stop them), against one CG + AMG Poisson solve of
each membrane on the same mesh (Benchmark/Reference Poisson solve). Both
are timed in the same process, so the ratio is meaningful on a noisy
machine; the absolute times are not. The estimators are the TimerOutput
sections "estimators: ..."; the loads f1, f2 at the quadrature points
(section "assembly: loads") are part of the assembly, which evaluates them
with or without estimators, and are also shown counted with the estimators
(column "(estimators + loads) / rest", the accounting before 2bd68de).
The kernel's CPU time in the contact solve and in the Poisson pair, and
the growth exponent of the program's own CPU time (summary.json
"solve_usage", "reference_poisson" "usage": getrusage, summed over
processes and threads) tell the first touch of memory from the program's
work (doc/performance.md, "Where the time above linear goes").

Writes doc/data/cost.{csv,md} and doc/data/cost.png.
Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/membranes_cost.py [--quick] [--c-function=fischer-burmeister]
                          [--flux-degree=p-1] [--check-interval=N]
                          [--gamma-lin=G] [--coarse-start] [--cycles=N]
                          [--repeat=N] [--huge-pages] [--tables-only]
--quick stops at about 5e4 unknowns per field (a smoke test of the script;
its files are doc/data/<stem as below>-quick.*).
--c-function chooses the C-function of Newton (default min); for another
one the files are doc/data/cost-<name>.{csv,md,png}.
--flux-degree=p-1 reconstructs the fluxes in RT_0 instead of RT_1
(Estimators/Flux degree); the files are then doc/data/cost[-<name>]-flux-p-1.*.
--gamma-lin=G stops Newton when eta_lin <= G eta_disc instead of the
scene's 0.3 (Nonlinear solver/gamma_lin); the files are then
doc/data/cost[-<name>][-flux-p-1][-check-<N>]-gamma-lin-<G>[-coarse-start].*.
--coarse-start starts the nested sequence two refinements coarser (768
cells, about 8e2 unknowns per field), so that the mesh of 1e4 unknowns per
field is reached by nested iteration instead of a cold start; the files
are then doc/data/cost[-<name>][-flux-p-1]-coarse-start.*.
--cycles=N runs N meshes instead of 4 (6 with --coarse-start), each with
four times the unknowns of the one before; the files are then
doc/data/<stem as above>-cycles-<N>[-median-of-<R>].*.
--check-interval=N estimates every N GMRES iterations instead of the
scene's 10 (Linear solver/Check interval); the files are then
doc/data/cost[-<name>][-flux-p-1]-check-<N>[-coarse-start].*.
--repeat=N runs every configuration N times, in rounds; the table then
gives for each mesh the run of the median ratio, with the ranges of the
ratio and of estimators / rest over the N runs beside it (the CSV has
every run); the files are then doc/data/<stem>-median-of-<N>.*.
--huge-pages runs the programs with glibc's heap in huge pages
(GLIBC_TUNABLES=glibc.malloc.hugetlb=1, see README.md); the files are then
doc/data/cost[-<name>]-huge-pages.{csv,md,png}.
--tables-only writes the table and the plot again from the study's
doc/data/<files>.csv (the same other options name the files), without
running it.
The full study takes about 3 minutes (at 1db72e7, 2.6 - 3.3 with the
various options) and 3 - 5 GB of memory (RT_0 - RT_1 fluxes); one mesh
more (--coarse-start --cycles=7, RT_0) about 12 minutes and 11.0 GB.
STEP_MEMBRANES names another binary (e.g. a copy, so that the build tree
can be rebuilt while the study runs).
"""
import itertools
import os
import sys

from vi_bench import (DATA, ROOT, cost_study_settings, estimator_seconds, growth_exponent, option,
                      huge_pages_environment, plot_png, poisson_seconds, program,
                      read_table, run as run_program, write_csv, write_dat,
                      write_markdown, write_table)

PROGRAM = program("membranes")
OUT = os.path.join(ROOT, "output", "bench-cost")
QUICK = "--quick" in sys.argv
TABLES_ONLY = "--tables-only" in sys.argv
C_FUNCTION = option("c-function", "min")
FLUX_DEGREE = option("flux-degree", "p")
STEM = "cost" if C_FUNCTION == "min" else f"cost-{C_FUNCTION}"
if FLUX_DEGREE != "p":
    STEM += f"-flux-{FLUX_DEGREE}"
# GMRES iterations between two estimates of the adaptive strategy (Linear
# solver/Check interval; the scene's 10 by default)
CHECK_INTERVAL = option("check-interval", kind=int)
if CHECK_INTERVAL:
    STEM += f"-check-{CHECK_INTERVAL}"
# Newton's tolerance relative to the discretisation error (Nonlinear
# solver/gamma_lin; the scene's 0.3 by default)
GAMMA_LIN = option("gamma-lin")
if GAMMA_LIN:
    STEM += f"-gamma-lin-{GAMMA_LIN}"
# Two refinements fewer at the start and two cycles more: the same meshes
# from 1e4 unknowns per field on, each reached by nested iteration.
COARSE_START = 2 if "--coarse-start" in sys.argv else 0
if COARSE_START:
    STEM += "-coarse-start"
# 12288 cells and three refinements (--coarse-start: 768 cells and five):
# 2.4e6 unknowns. Peak memory on one process with RT_0 fluxes at d884e01
# (/usr/bin/time): 3.0 GB; with one mesh more (9.4e6 unknowns), 11.3 GB.
CYCLES = option("cycles", kind=int)
if CYCLES:
    STEM += f"-cycles-{CYCLES}"
else:
    CYCLES = (2 if QUICK else 4) + COARSE_START
# Every configuration run this many times, in rounds (all configurations,
# then again); the table gives, for each mesh, the run of the median ratio
# and the range of the ratio over the runs.
REPEAT = option("repeat", 1, int)
if REPEAT > 1:
    STEM += f"-median-of-{REPEAT}"
if QUICK:
    # (a smoke test must not overwrite a study's files)
    STEM += "-quick"
if "--huge-pages" in sys.argv:
    # (the programs inherit the environment, vi_bench.run)
    os.environ.update(huge_pages_environment())
    STEM += "-huge-pages"
# (processes, threads per process; None: deal.II's default, all cores)
CONFIGURATIONS = [(1, 1), (1, None), (2, None)]


def run(np, threads, repeat):
    settings = {**cost_study_settings(C_FUNCTION, FLUX_DEGREE, 5 - COARSE_START),
                "Mesh/Cycles": CYCLES,
                "Benchmark/Reference Poisson solve": "true",
                "Output/Write VTU": "false"}
    if CHECK_INTERVAL:
        settings["Linear solver/Check interval"] = CHECK_INTERVAL
    if GAMMA_LIN:
        settings["Nonlinear solver/gamma_lin"] = GAMMA_LIN
    summary = run_program(PROGRAM, "estimators-disk-p1.prm", settings,
                          os.path.join(OUT, f"{STEM}-np{np}-threads{threads or 'all'}"
                                            + (f"-run{repeat}" if REPEAT > 1 else "")),
                          np, threads)
    n_threads = summary["threads_per_rank"]
    print(f"  np = {np} x {n_threads} thread(s): done", flush=True)
    return n_threads, summary["cycles"]


def read_rows():
    """The rows of an earlier run of this study, from doc/data/<STEM>.csv."""
    if not os.path.isfile(os.path.join(DATA, STEM + ".csv")):
        sys.exit(f"membranes_cost.py: no doc/data/{STEM}.csv to write the tables from; "
                 "run the study first")
    return read_table(STEM)


def run_study():
    rows = []
    for repeat, (k, (np, threads)) in itertools.product(range(REPEAT),
                                                        enumerate(CONFIGURATIONS)):
        previous = None
        n_threads, cycles = run(np, threads, repeat)
        for c in cycles:
            poisson = poisson_seconds(c)
            estimators = estimator_seconds(c["timing"])
            # the tabulated f1, f2, part of the assembly since 2bd68de (with
            # or without estimators; before, counted with the estimators)
            loads = c["timing"].get("assembly: loads", float("nan"))
            row = {"repeat": repeat, "configuration": k, "np": np, "threads": n_threads,
                   "cycle": c["cycle"], "cells": c["cells"],
                   "dofs_per_field": c["dofs_per_field"], "unknowns": c["dofs"],
                   "newton": c["newton_iterations"], "gmres": c["linear_iterations"],
                   # Newton steps that ended without fluxes (Estimators/Defer fluxes)
                   "without_fluxes": sum(1 for it in c["iterations"]
                                         if it["accepted"] and not it.get("fluxes", True)),
                   "poisson_cg": "/".join(str(m["iterations"]) for m in c["reference_poisson"]),
                   "error_energy": c["error_energy"], "effectivity": c["effectivity"],
                   "solve_seconds": c["solve_seconds"], "estimator_seconds": estimators,
                   "poisson_seconds": poisson,
                   "ratio": c["solve_seconds"] / poisson,
                   "ratio_without_estimators": (c["solve_seconds"] - estimators) / poisson,
                   "estimator_fraction": estimators / (c["solve_seconds"] - estimators),
                   "loads_seconds": loads,
                   "estimator_fraction_with_loads":
                       (estimators + loads) / (c["solve_seconds"] - estimators - loads),
                   "growth": (growth_exponent(c["solve_seconds"], previous["solve_seconds"],
                                              c["dofs_per_field"], previous["dofs_per_field"])
                              if previous else float("nan"))}
            if "solve_usage" in c:
                # CPU seconds in the kernel (mostly the first touch of
                # memory) and in the program, summed over processes and
                # threads (since a35f4ae)
                row["solve_system_seconds"] = c["solve_usage"]["system_seconds"]
                row["poisson_system_seconds"] = sum(m["usage"]["system_seconds"]
                                                    for m in c["reference_poisson"])
                row["solve_user_seconds"] = c["solve_usage"]["user_seconds"]
                row["growth_user"] = (
                    growth_exponent(c["solve_usage"]["user_seconds"],
                                    previous["solve_usage"]["user_seconds"],
                                    c["dofs_per_field"], previous["dofs_per_field"])
                    if previous else float("nan"))
            rows.append(row)
            previous = c
    for row in rows:
        serial = next(r for r in rows if r["repeat"] == row["repeat"] and r["np"] == 1
                      and r["threads"] == 1 and r["cycle"] == row["cycle"])
        row["speedup"] = serial["solve_seconds"] / row["solve_seconds"]
    return rows


def median_runs(rows):
    """For each configuration and mesh, the row of the run whose ratio is
    the median of the runs' (for an even number of runs the lower of the
    two middle ones), with the range of the ratio and of estimators / rest
    over the runs; says so where the runs' counts or errors differ."""
    medians = []
    for key in dict.fromkeys((r["configuration"], r["cycle"]) for r in rows):
        runs = sorted((r for r in rows if (r["configuration"], r["cycle"]) == key),
                      key=lambda r: r["ratio"])
        row = dict(runs[(len(runs) - 1) // 2])
        row["ratio_range"] = f"{runs[0]['ratio']:.1f} - {runs[-1]['ratio']:.1f}"
        fractions = [r["estimator_fraction"] for r in runs]
        row["estimator_fraction_range"] = f"{min(fractions):.2f} - {max(fractions):.2f}"
        if len({(r["newton"], r["gmres"], r["error_energy"]) for r in runs}) > 1:
            print(f"warning: the runs of np = {row['np']} x {row['threads']}, "
                  f"{row['dofs_per_field']} DoFs per field differ in counts or errors")
        medians.append(row)
    return medians


def main():
    rows = read_rows() if TABLES_ONLY else run_study()
    if REPEAT > 1:
        write_csv(STEM, rows)
        rows = median_runs(rows)

    header = ["np", "threads", "DoFs per field", "unknowns", "Newton",
              "of which without fluxes", "GMRES", "Poisson CG",
              "contact solve (s)", "estimators (s)", "2 Poisson (s)", "ratio",
              "ratio without estimators", "estimators / rest",
              "(estimators + loads) / rest", "growth exponent", "speed-up", "effectivity"]
    formats = [("np", "{}"), ("threads", "{}"), ("dofs_per_field", "{}"), ("unknowns", "{}"),
               ("newton", "{}"), ("without_fluxes", "{}"), ("gmres", "{}"),
               ("poisson_cg", "{}"),
               ("solve_seconds", "{:.2f}"), ("estimator_seconds", "{:.2f}"),
               ("poisson_seconds", "{:.2f}"), ("ratio", "{:.1f}"),
               ("ratio_without_estimators", "{:.1f}"), ("estimator_fraction", "{:.2f}"),
               ("estimator_fraction_with_loads", "{:.2f}"),
               ("growth", "{:.2f}"), ("speedup", "{:.2f}"), ("effectivity", "{:.3f}")]
    if "solve_system_seconds" in rows[0]:
        # where the time goes that is not the program's (studies since
        # a35f4ae)
        for after, key, title, fmt in (
                ("2 Poisson (s)", "solve_system_seconds", "kernel CPU, solve (s)", "{:.2f}"),
                ("kernel CPU, solve (s)", "poisson_system_seconds",
                 "kernel CPU, 2 Poisson (s)", "{:.2f}"),
                ("growth exponent", "growth_user", "growth exponent, program CPU", "{:.2f}")):
            position = header.index(after) + 1
            header.insert(position, title)
            formats.insert(position, (key, fmt))
    if REPEAT > 1:
        # the median run's columns, and the ranges over all runs beside them
        for after, key, title in (("ratio", "ratio_range", f"ratio, {REPEAT} runs"),
                                  ("estimators / rest", "estimator_fraction_range",
                                   f"estimators / rest, {REPEAT} runs")):
            position = header.index(after) + 1
            header.insert(position, title)
            formats.insert(position, (key, "{}"))
        write_markdown(STEM, rows, header, formats)
    else:
        write_table(STEM, rows, header, formats)

    os.makedirs(OUT, exist_ok=True)
    dat = os.path.join(OUT, f"{STEM}.dat")
    groups = []  # (np, threads, index in the .dat file)
    blocks = []
    for k in sorted({r["configuration"] for r in rows}):
        group = [r for r in rows if r["configuration"] == k]
        np, n_threads = group[0]["np"], group[0]["threads"]
        groups.append((np, n_threads, k))
        blocks.append((f"np = {np} x {n_threads} thread(s): DoFs per field, "
                       "contact solve, estimators, 2 Poisson",
                       [(row["dofs_per_field"], row["solve_seconds"],
                         row["estimator_seconds"], row["poisson_seconds"]) for row in group]))
    write_dat(dat, blocks)
    # the line of linear growth through the first mesh of 1e4 unknowns per
    # field or more (with --coarse-start the study's smaller meshes come
    # first, and a line through them would lie far above the curves)
    anchor = next((r for r in rows if r["dofs_per_field"] >= 10000), rows[0])
    # the Raviart-Thomas space of the fluxes, named when it is not RT_p
    FLUXES = "" if FLUX_DEGREE == "p" else f", Flux degree = {FLUX_DEGREE}"
    # and the start of the nested sequence, when it is not the default's
    START = ", from 768 cells" if COARSE_START else ""
    START += f", Check interval = {CHECK_INTERVAL}" if CHECK_INTERVAL else ""
    START += f", gamma_lin = {GAMMA_LIN}" if GAMMA_LIN else ""
    START += f", the median of {REPEAT} runs" if REPEAT > 1 else ""
    curves = []
    for (np, n_threads, index), colour in zip(groups, (1, 4, 6)):
        label = f"np = {np} x {n_threads} thread{'s' if n_threads > 1 else ''}"
        curves.append(f"'{dat}' index {index} using 1:2 with linespoints lw 2 pt 7 "
                      f"lc {colour} title 'contact solve, {label}'")
        curves.append(f"'{dat}' index {index} using 1:3 with linespoints lw 1 pt 6 "
                      f"lc {colour} dt 2 title 'of which estimators, {label}'")
        if n_threads == 1:
            curves.append(f"'{dat}' index {index} using 1:4 with linespoints lw 2 pt 5 "
                          f"lc {colour + 1} title '2 Poisson solves, np = {np}'")
    curves.append(f"{anchor['solve_seconds']}*x/{anchor['dofs_per_field']} with lines "
                  "lc rgb 'gray' dt 3 title 'linear growth'")
    plot_png(os.path.join(DATA, STEM + ".png"),
             ["set logscale xy", "set grid", "set key left top font ',9'",
              "set xlabel 'unknowns per field'", "set ylabel 'wall time (s)'",
              f'set title "Contact solve (adaptive inexact Newton-{C_FUNCTION}, '
              f'GMRES + AMG{FLUXES}{START})\\nagainst two Poisson solves (CG + AMG)"'],
             curves, size="900,650", font=11)
    print(f"wrote {os.path.join(DATA, STEM)}.{{csv,md,png}}")


if __name__ == "__main__":
    main()
