#!/usr/bin/env python3
"""Error against run time (doc/performance.md, "Error against run time").

Each study runs programs over a sequence of globally refined meshes (nested
iteration) and plots the energy error, and the estimate where there is one,
against the cumulative wall time up to that mesh: what a user pays to reach
an accuracy. Wall times are those of one process of a shared 2-core
machine (tens of percent of noise); the shapes of the curves are the
result.

  time-degrees      step-membranes, seed-smooth, FEM Q1..Q4, direct solver
  time-methods      seed-smooth at p = 2: FEM, SIPG, HHO condensed and not
  time-strategies   disk, Q1: exact / inexact / adaptive Newton, GMRES + ILU
                    or AMG, with the estimate

Writes doc/data/<study>.{csv,png}. Usage, from the repository root after
./demo.sh or ./test.sh:
  bench/error_vs_time.py [--quick] [study ...]
--quick runs two meshes fewer (a smoke test of the script); naming studies
runs only those. The whole study takes about 12 minutes. The first two
studies switch the estimators off (the scenes of step-membranes turn them
on; step-hho's are off by default): a scene computes only what it needs.
"""
import os
import sys

from vi_bench import DATA, ROOT, plot_png, program, run as run_program, write_csv, write_dat

OUT = os.path.join(ROOT, "output", "bench-time")
QUICK = "--quick" in sys.argv
ONLY = [a for a in sys.argv[1:] if not a.startswith("--")]
NO_ESTIMATES = {"Estimators/Enabled": "false"}


def run(step, scene, name, settings, cycles):
    """Run step-<step> on parameters/<scene> as run `name`; its rows, with
    the wall time summed over the meshes."""
    settings = {**settings, "Mesh/Cycles": max(cycles - (2 if QUICK else 0), 1),
                "Output/Write VTU": "false"}
    cycles = run_program(program(step), scene, settings, os.path.join(OUT, name))["cycles"]
    print(f"  {name}: done", flush=True)
    rows, elapsed = [], 0.
    for c in cycles:
        elapsed += c["wall_seconds"]
        rows.append({"run": name, "cycle": c["cycle"], "dofs": c["dofs"],
                     "newton": c["newton_iterations"],
                     "linear": c["linear_iterations"],
                     "error_energy": c["error_energy"],
                     "eta": c.get("eta", ""), "seconds": elapsed})
    return rows


def study(name, runs, title, with_estimate=False):
    if ONLY and name not in ONLY:
        return
    rows = []
    for label, args in runs:
        rows += run(*args)
    write_csv(name, rows)

    dat = os.path.join(OUT, name + ".dat")
    write_dat(dat, [(label, [(r["seconds"], r["error_energy"], r["eta"] or "NaN")
                             for r in rows if r["run"] == args[2]])
                    for label, args in runs])
    plots = []
    for i, (label, _) in enumerate(runs):
        plots.append(f"'{dat}' index {i} using 1:2 with linespoints lw 2 pt 7 "
                     f"lc {i + 1} title '{label}'")
        if with_estimate:
            plots.append(f"'{dat}' index {i} using 1:3 with lines lw 1 dt 2 "
                         f"lc {i + 1} notitle")
    estimate = " (points), estimate (dashed)" if with_estimate else ""
    plot_png(os.path.join(DATA, name + ".png"),
             ["set logscale xy", "set grid", "set key outside right",
              "set xlabel 'cumulative wall time (s), one process'",
              f"set ylabel 'energy error{estimate}'", f"set title '{title}'"],
             plots, font=11)


def main():
    os.makedirs(DATA, exist_ok=True)
    os.makedirs(OUT, exist_ok=True)
    membranes = "membranes"

    study("time-degrees",
          [(f"Q{p}", (membranes, "membranes-seed-smooth.prm", f"fem-p{p}",
                      {"Discretization/Polynomial degree": p,
                       "Mesh/Initial refinements": 2, **NO_ESTIMATES}, cycles))
           for p, cycles in ((1, 7), (2, 6), (3, 5), (4, 5))],
          "seed-smooth: FEM of degree p, direct solver, nested iteration")

    study("time-methods",
          [("FEM Q2", (membranes, "membranes-seed-smooth.prm", "method-fem",
                       {"Discretization/Polynomial degree": 2,
                        "Mesh/Initial refinements": 2, **NO_ESTIMATES}, 6)),
           ("SIPG Q2", (membranes, "membranes-seed-smooth.prm", "method-sipg",
                        {"Discretization/Method": "sipg",
                         "Discretization/Polynomial degree": 2,
                         "Mesh/Initial refinements": 2, **NO_ESTIMATES}, 5)),
           ("HHO p = 2, condensed", ("hho", "hho-seed-smooth.prm", "method-hho",
                                     {"Discretization/Polynomial degree": 2,
                                      "Mesh/Initial refinements": 2}, 6)),
           ("HHO p = 2, whole system", ("hho", "hho-seed-smooth.prm",
                                        "method-hho-uncondensed",
                                        {"Discretization/Polynomial degree": 2,
                                         "Discretization/Static condensation": "false",
                                         "Linear solver/Solver": "direct",
                                         "Mesh/Initial refinements": 2}, 5))],
          "seed-smooth at p = 2: conforming, SIPG and HHO")

    strategies = []
    for strategy in ("exact", "inexact", "adaptive"):
        for preconditioner in ("ilu", "amg"):
            strategies.append(
                (f"{strategy}, {preconditioner.upper()}",
                 (membranes, "estimators-disk-p1.prm", f"{strategy}-{preconditioner}",
                  {"Nonlinear solver/Strategy": strategy,
                   "Nonlinear solver/Nested iteration": "true",
                   "Linear solver/Preconditioner": preconditioner,
                   "Estimators/At every check": "false",
                   # (the solve's cost, not that of a sharper final error bar)
                   "Estimators/Sharpen final estimate": "false",
                   "Mesh/Initial refinements": 2}, 5)))
    study("time-strategies", strategies,
          "disk, Q1: Newton strategies and preconditioners (GMRES)",
          with_estimate=True)
    print(f"wrote {DATA}/time-*.{{csv,png}}")


if __name__ == "__main__":
    main()
