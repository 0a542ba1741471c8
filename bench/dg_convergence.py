#!/usr/bin/env python3
"""Discontinuous Galerkin study of step-membranes (doc/step-membranes.md, dG
section).

Runs the seed's tests with SIPG and NIPG for p = 1..4 (direct solver, nested
iteration, estimators on), the conforming method on the same meshes (Newton-min
iterations, effectivity of its estimator), GMRES + ILU(0) for SIPG and NIPG,
and a penalty sweep; writes into doc/data/:
  dg-convergence.csv   one row per (test, method, p, cycle)
  dg-convergence.md    rate, effectivity and Newton tables
  dg-convergence.png   dG energy error against DoFs (gnuplot)
  dg-solvers.md        GMRES iterations, SIPG against NIPG
  dg-penalty.md        SIPG and NIPG against the penalty constant

Usage: bench/dg_convergence.py [--quick] [--penalty]   (from the repository
root, after ./demo.sh or ./test.sh has built the programs). --quick runs
fewer cycles; --penalty only the penalty sweep (a minute). The whole study
takes about five minutes on 2 cores.
"""
import json
import math
import os
import subprocess
import sys

from vi_bench import DATA, ROOT, gnuplot, program, write_csv, write_md

PROGRAM = program("membranes")
QUICK = "--quick" in sys.argv

# (degree, cycles) from 4 x 4 cells on, for both seed tests.
DEGREES = [(1, 5), (2, 4), (3, 4), (4, 3)]
TESTS = ["seed-smooth", "seed-jump"]
METHODS = ["sipg", "nipg"]


def run(name, test, settings):
    """Run one scene; return its cycles, or None if the program failed."""
    out = os.path.join(ROOT, "output", "bench-dg", name)
    command = [PROGRAM, os.path.join(ROOT, "parameters", f"membranes-{test}.prm"),
               "--set", f"Output/Directory={out}",
               "--set", "Nonlinear solver/Maximum iterations=200"]
    for key, value in settings.items():
        command += ["--set", f"{key}={value}"]
    result = subprocess.run(command, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    if result.returncode != 0:
        return None, result.stderr.strip().splitlines()[-1]
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)["cycles"], ""


def rate(previous, current, key="error_energy"):
    # rate in h from the DoF count (d = 2)
    return 2 * math.log(previous[key] / current[key]) / \
        math.log(current["dofs_per_field"] / previous["dofs_per_field"])


def rates(records, key="error_energy"):
    return [rate(records[n - 1], records[n], key) for n in range(1, len(records))]


def main():
    os.makedirs(DATA, exist_ok=True)
    rows, sections = [], []
    results, fem = {}, {}
    for test in TESTS:
        for degree, cycles in DEGREES:
            if QUICK:
                cycles = min(cycles, 3)
            base = {"Discretization/Polynomial degree": degree,
                    "Mesh/Cycles": cycles}
            for method in METHODS:
                records, error = run(f"{test}-{method}-p{degree}", test,
                                     dict(base, **{"Discretization/Method": method}))
                if records is None:
                    sys.exit(f"{test} {method} p={degree} failed: {error}")
                results[test, method, degree] = records
                for c in records:
                    rows.append({"test": test, "method": method, "p": degree,
                                 "cycle": c["cycle"], "cells": c["cells"],
                                 "dofs_per_field": c["dofs_per_field"],
                                 "newton": c["newton_iterations"],
                                 "error_energy": c["error_energy"],
                                 "error_broken": c["error_broken"],
                                 "error_jump": c["error_jump"],
                                 "error_lambda_l2": c.get("error_lambda_l2", ""),
                                 "eta": c["eta"],
                                 "effectivity": c["effectivity"],
                                 "effectivity_broken": c["effectivity_broken"],
                                 "wall_seconds": c["wall_seconds"]})
            records, error = run(f"{test}-fem-p{degree}", test,
                                 dict(base, **{"Discretization/Method": "fem"}))
            if records is None:
                sys.exit(f"{test} fem p={degree} failed: {error}")
            fem[test, degree] = records
            print(f"{test} p={degree}: done", flush=True)

    # Rates and effectivity.
    for test in TESTS:
        lines = [f"#### {test}: dG energy error |||u - u_h|||_dG, rates in h",
                 "",
                 "| method | p | DoFs per field (finest) | energy error (finest) | "
                 "rates over the meshes | effectivity eta / error (per mesh) | "
                 "broken part eta_h / error_h (finest) |",
                 "|---|---:|---:|---:|---|---|---:|"]
        for degree, _ in DEGREES:
            records = fem[test, degree]
            last = records[-1]
            lines.append(
                f"| FEM | {degree} | {last['dofs_per_field']} | "
                f"{last['error_energy']:.3e} | "
                + ", ".join(f"{r:.2f}" for r in rates(records)) + " | "
                + ", ".join(f"{c['effectivity']:.2f}" for c in records) + " | - |")
        for method in METHODS:
            for degree, _ in DEGREES:
                records = results[test, method, degree]
                last = records[-1]
                lines.append(
                    f"| {method.upper()} | {degree} | {last['dofs_per_field']} | "
                    f"{last['error_energy']:.3e} | "
                    + ", ".join(f"{r:.2f}" for r in rates(records)) + " | "
                    + ", ".join(f"{c['effectivity']:.2f}" for c in records) + " | "
                    f"{last['effectivity_broken']:.2f} |")
        sections.append("\n".join(lines))

    # Newton-min iterations per mesh (nested iteration), dG beside FEM.
    for test in TESTS:
        lines = [f"#### {test}: Newton-min iterations per mesh (nested iteration)",
                 "",
                 "| p | cells | FEM | SIPG | NIPG |", "|---:|---:|---:|---:|---:|"]
        for degree, _ in DEGREES:
            for n, c in enumerate(results[test, "sipg", degree]):
                lines.append(
                    f"| {degree} | {c['cells']} | "
                    f"{fem[test, degree][n]['newton_iterations']} | "
                    f"{c['newton_iterations']} | "
                    f"{results[test, 'nipg', degree][n]['newton_iterations']} |")
        sections.append("\n".join(lines))

    write_csv("dg-convergence", rows)
    write_md("dg-convergence", sections, separator="\n\n")

    # gnuplot: dG energy error against DoFs per field.
    dat = os.path.join(DATA, "dg-convergence.dat")
    curves = []
    with open(dat, "w") as f:
        for test in TESTS:
            for method in METHODS:
                for degree, _ in DEGREES:
                    f.write(f"# {test} {method} p={degree}\n")
                    for c in results[test, method, degree]:
                        f.write(f"{c['dofs_per_field']} {c['error_energy']}\n")
                    f.write("\n\n")
                    curves.append((test, method, degree))
    plots = []
    for index, (test, method, degree) in enumerate(curves):
        style = "lines dt 2" if method == "nipg" else f"linespoints pt {degree + 3}"
        colour = (degree - 1) + (4 if test == "seed-jump" else 0)
        plots.append(f"'{dat}' index {index} with {style} lw 2 lc {colour + 1} "
                     f"title '{test} {method.upper()} p={degree}'")
    script = f"""set terminal pngcairo size 1000,700 font ',11'
set output '{os.path.join(DATA, "dg-convergence.png")}'
set logscale xy
set format y '10^{{%L}}'
set xlabel 'DoFs per field'
set ylabel 'dG energy error'
set title 'step-membranes, interior penalty dG (solid: SIPG, dashed: NIPG)'
set key outside right
set grid
plot {', '.join(plots)}
"""
    gnuplot(script)
    os.remove(dat)

    # GMRES + ILU(0): SIPG against NIPG (seed-smooth, exact strategy).
    lines = ["#### GMRES + ILU(0) iterations, seed-smooth, exact Newton "
             "(linear tolerance 1e-12), nested iteration",
             "",
             "| p | cells | SIPG: Newton | SIPG: GMRES (total) | SIPG: GMRES per Newton step "
             "| NIPG: Newton | NIPG: GMRES (total) | NIPG: GMRES per Newton step |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    gmres = {}
    for degree in (1, 2, 3):
        for method in METHODS:
            records, error = run(f"gmres-{method}-p{degree}", "seed-smooth",
                                 {"Discretization/Method": method,
                                  "Discretization/Polynomial degree": degree,
                                  "Mesh/Cycles": 3 if QUICK else 4,
                                  "Linear solver/Solver": "gmres",
                                  "Linear solver/Preconditioner": "ilu",
                                  "Estimators/Enabled": "false"})
            if records is None:
                sys.exit(f"GMRES {method} p={degree} failed: {error}")
            gmres[method, degree] = records
        for n, s in enumerate(gmres["sipg", degree]):
            t = gmres["nipg", degree][n]
            lines.append(
                f"| {degree} | {s['cells']} | {s['newton_iterations']} | "
                f"{s['linear_iterations']} | "
                f"{s['linear_iterations'] / max(s['newton_iterations'], 1):.0f} | "
                f"{t['newton_iterations']} | {t['linear_iterations']} | "
                f"{t['linear_iterations'] / max(t['newton_iterations'], 1):.0f} |")
        print(f"GMRES p={degree}: done", flush=True)
    solver_sections = ["\n".join(lines)]

    write_md("dg-solvers", solver_sections, separator="\n\n")
    print(f"wrote {DATA}/dg-convergence.{{csv,md,png}} and dg-solvers.md")


def penalty_sweep():
    """SIPG and NIPG against the penalty constant C: Q2, 16 x 16 cells,
    seed-smooth, from zero, with the direct solver and with GMRES + ILU(0);
    writes dg-penalty.md."""
    lines = ["#### Penalty sweep: Q2, 16 x 16 cells, seed-smooth, Newton-min from zero",
             "",
             "| C | SIPG, direct: broken error | Newton | SIPG, GMRES + ILU(0): Newton | "
             "GMRES | NIPG, direct: broken error | Newton | NIPG, GMRES + ILU(0): Newton "
             "| GMRES |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for C in (0.05, 0.2, 0.5, 1, 2, 8, 32):
        cells = []
        for method in METHODS:
            for solver in ("direct", "gmres"):
                records, error = run(f"penalty-{method}-{solver}-{C}", "seed-smooth",
                                     {"Discretization/Method": method,
                                      "Discretization/Polynomial degree": 2,
                                      "Discretization/Penalty": C,
                                      "Mesh/Cycles": 1,
                                      "Mesh/Initial refinements": 4,
                                      "Nonlinear solver/Maximum iterations": 50,
                                      "Linear solver/Solver": solver,
                                      "Linear solver/Preconditioner": "ilu",
                                      "Estimators/Enabled": "false"})
                if records is None:
                    # "Solver failure: <solver>: no convergence in ... (details)"
                    reason = error.split("Solver failure: ")[-1].split(" (")[0]
                    cells += [f"fails: {reason}", "-"]
                    continue
                c = records[-1]
                if solver == "direct":
                    cells += [f"{c['error_broken']:.3e}", str(c["newton_iterations"])]
                else:
                    cells += [str(c["newton_iterations"]), str(c["linear_iterations"])]
        lines.append(f"| {C} | " + " | ".join(cells) + " |")
    write_md("dg-penalty", lines)
    print(f"wrote {DATA}/dg-penalty.md")


if __name__ == "__main__":
    if "--penalty" not in sys.argv:
        main()
    penalty_sweep()
