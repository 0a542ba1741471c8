#!/usr/bin/env python3
"""Convergence study of step-hho (doc/step-hho.md), with step-membranes (FEM)
beside it for the Newton-min iteration counts.

Runs on the seed's meshes (64 ... 16384 cells of the unit square):
  - step-hho, seed-smooth and seed-jump, p = 1..4, nested iteration, five
    meshes: energy rates, the DoF table (with and without static condensation);
  - step-hho and step-membranes, both tests, p = 1..4, from zero and nested,
    the first four meshes (64 ... 4096 cells): Newton-min iterations.
Writes into doc/data/:
  hho-convergence.csv   one row per (program, test, p, start, cycle)
  hho-convergence.md    the tables quoted in doc/step-hho.md
  hho-convergence.png   energy error against the mesh size (gnuplot)

The DoF counts are checked against the formulas of doc/step-hho.md (the
script stops if they differ).

Usage: bench/hho_convergence.py [--quick]   (from the repository root, after
the build; --quick runs fewer meshes for a smoke test).
"""
import math
import os
import sys

from vi_bench import (DATA, ROOT, convergence_rows, gnuplot, program, run as run_program,
                      write_csv, write_dat, write_md)

QUICK = "--quick" in sys.argv
DEGREES = [1, 2, 3, 4]
TESTS = ["seed-smooth", "seed-jump"]
RATE_MESHES = 3 if QUICK else 5     # 64 ... 16384 cells
NEWTON_MESHES = 2 if QUICK else 4   # 64 ... 4096 cells


def run(name, test, degree, cycles, nested):
    """step-<name> (hho or membranes) on parameters/<name>-<test>.prm."""
    settings = {"Mesh/Initial refinements": 3, "Mesh/Cycles": cycles,
                "Discretization/Polynomial degree": degree,
                "Nonlinear solver/Nested iteration": nested,
                # From zero, Newton-min needs O(1/h) iterations.
                "Nonlinear solver/Maximum iterations": 500,
                "Output/Write VTU": "false"}
    return run_program(program(name), f"{name}-{test}.prm", settings,
                       os.path.join(ROOT, "output", "bench",
                                    f"{name}-{test}-p{degree}-nested-{nested}"))["cycles"]


def expected_dofs(cells, degree):
    """The counts of doc/step-hho.md on an N x N mesh of the square."""
    n = round(math.sqrt(cells))
    interior_faces = 2 * n * (n - 1)
    cell_space = (degree + 1) * (degree + 2) // 2
    condensed = 2 * degree * interior_faces
    return 3 * cells * cell_space + condensed, condensed


def rate(previous, current):
    # rate in h (h halves from one mesh to the next)
    return math.log(previous["error_energy"] / current["error_energy"]) / \
        math.log(math.sqrt(current["cells"] / previous["cells"]))


def main():
    os.makedirs(DATA, exist_ok=True)
    rows, results = [], {}
    for test in TESTS:
        for degree in DEGREES:
            runs = {("hho", "true"): run("hho", test, degree, RATE_MESHES, "true"),
                    ("hho", "false"): run("hho", test, degree, NEWTON_MESHES, "false"),
                    ("fem", "true"): run("membranes", test, degree, NEWTON_MESHES, "true"),
                    ("fem", "false"): run("membranes", test, degree, NEWTON_MESHES, "false")}
            results[(test, degree)] = runs
            print(f"{test} p={degree}: done", flush=True)
            for (method, nested), records in runs.items():
                rows += convergence_rows(
                    records, rate,
                    {"program": method, "test": test, "p": degree, "nested": nested},
                    lambda c: {"dofs": c["dofs"],
                               "dofs_condensed": c.get("dofs_condensed", ""),
                               "newton": c["newton_iterations"],
                               "linear": c["linear_iterations"]})

    # The DoF table, checked against the formulas.
    lines = ["| cells | " + " | ".join(f"P{p} no SC | P{p} SC" for p in DEGREES) + " |",
             "|---:|" + "---:|---:|" * len(DEGREES)]
    for n, c in enumerate(results[("seed-smooth", 1)][("hho", "true")]):
        line = f"| {c['cells']} |"
        for degree in DEGREES:
            record = results[("seed-smooth", degree)][("hho", "true")][n]
            expected = expected_dofs(record["cells"], degree)
            if (record["dofs"], record["dofs_condensed"]) != expected:
                sys.exit(f"DoF count of p={degree}, {record['cells']} cells: "
                         f"{record['dofs']}, {record['dofs_condensed']} from the "
                         f"program, {expected} from the formula")
            line += f" {record['dofs']} | {record['dofs_condensed']} |"
        lines.append(line)
    tables = ["\n".join(["#### HHO unknowns without and with static "
                          "condensation (equal to the formulas)", ""] + lines)]

    # Energy errors and rates, nested iteration.
    for test in TESTS:
        lines = [f"#### {test}: energy error and rate (HHO, nested iteration)", "",
                 "| cells | " + " | ".join(f"P{p} error | rate" for p in DEGREES) + " |",
                 "|---:|" + "---:|---:|" * len(DEGREES)]
        for n in range(RATE_MESHES):
            cells = results[(test, 1)][("hho", "true")][n]["cells"]
            line = f"| {cells} |"
            for degree in DEGREES:
                records = results[(test, degree)][("hho", "true")]
                line += f" {records[n]['error_energy']:.3e} |"
                line += f" {rate(records[n - 1], records[n]):.2f} |" if n else " - |"
            lines.append(line)
        tables.append("\n".join(lines))

    # Rates of HHO beside those of FEM (Q_p, step-membranes) on the same
    # meshes (the FEM runs have four meshes), nested iteration.
    for test in TESTS:
        lines = [f"#### {test}: energy rates of HHO (P_p cells) and FEM (Q_p), "
                 "same meshes, nested iteration", "",
                 "| cells | " + " | ".join(f"P{p} HHO | Q{p} FEM" for p in DEGREES)
                 + " |", "|---:|" + "---:|---:|" * len(DEGREES)]
        for n in range(1, NEWTON_MESHES):
            cells = results[(test, 1)][("hho", "true")][n]["cells"]
            line = f"| {cells} |"
            for degree in DEGREES:
                for program in ["hho", "fem"]:
                    records = results[(test, degree)][(program, "true")]
                    line += f" {rate(records[n - 1], records[n]):.2f} |"
            lines.append(line)
        last = NEWTON_MESHES - 1
        cells = results[(test, 1)][("hho", "true")][last]["cells"]
        lines.append(f"| error at {cells} |" + "".join(
            f" {results[(test, p)][(program, 'true')][last]['error_energy']:.2e} |"
            for p in DEGREES for program in ["hho", "fem"]))
        lines.append(f"| unknowns at {cells} |" + "".join(
            f" {results[(test, p)][(program, 'true')][last]['dofs']} |"
            for p in DEGREES for program in ["hho", "fem"]))
        tables.append("\n".join(lines))

    # Newton-min iterations, HHO beside FEM.
    for test in TESTS:
        for nested in ["false", "true"]:
            start = "nested iteration" if nested == "true" else "from zero"
            lines = [f"#### {test}: Newton-min iterations per mesh, {start} "
                     "(HHO / FEM)", "",
                     "| cells | " + " | ".join(f"P{p} HHO | P{p} FEM" for p in DEGREES)
                     + " |", "|---:|" + "---:|---:|" * len(DEGREES)]
            totals = {p: [0, 0] for p in DEGREES}
            for n in range(NEWTON_MESHES):
                cells = results[(test, 1)][("hho", nested)][n]["cells"]
                line = f"| {cells} |"
                for degree in DEGREES:
                    h = results[(test, degree)][("hho", nested)][n]["newton_iterations"]
                    f = results[(test, degree)][("fem", nested)][n]["newton_iterations"]
                    totals[degree][0] += h
                    totals[degree][1] += f
                    line += f" {h} | {f} |"
                lines.append(line)
            lines.append("| total |" + "".join(
                f" {totals[p][0]} | {totals[p][1]} |" for p in DEGREES))
            lines.append("| FEM / HHO |" + "".join(
                f" {totals[p][1] / totals[p][0]:.2f} | |" for p in DEGREES))
            tables.append("\n".join(lines))

    write_csv("hho-convergence", rows)
    write_md("hho-convergence", tables, separator="\n\n")

    # gnuplot: energy error against 1/h, both tests, HHO nested.
    dat = os.path.join(DATA, "hho-convergence.dat")
    write_dat(dat, [(f"{test} p={degree}",
                     [(math.sqrt(c["cells"]), c["error_energy"])
                      for c in results[(test, degree)][("hho", "true")]])
                    for test in TESTS for degree in DEGREES])
    # Reference slopes through the first point of each curve: h^p for the
    # smooth test; h and h^1.5 (u1 in H^(5/2 - eps)) for the jump.
    panels = []
    for t, test in enumerate(TESTS):
        plots = [f"'{dat}' index {t * len(DEGREES) + k} with linespoints lw 2 "
                 f"pt {k + 4} title 'P{p}'" for k, p in enumerate(DEGREES)]
        for p in DEGREES:
            first = results[(test, p)][("hho", "true")][0]
            x0, e0 = math.sqrt(first["cells"]), first["error_energy"]
            slope = p if test == "seed-smooth" else min(p, 1.5)
            plots.append(f"{e0}*({x0}/x)**{slope} dt 2 lc rgb 'gray' notitle")
        references = "h^p" if test == "seed-smooth" else "h, h^{1.5}"
        panels.append(f"set title 'step-hho, {test} (dashed: {references})'\n"
                      f"plot {', '.join(plots)}")
    script = f"""set terminal pngcairo size 1300,600 font ',12'
set output '{os.path.join(DATA, "hho-convergence.png")}'
set multiplot layout 1,2
set logscale xy
set xrange [6:180]
set format y '10^{{%L}}'
set xlabel '1/h (cells per side)'
set ylabel 'energy error |||u - u_h|||'
set key bottom left
set grid
{panels[0]}
{panels[1]}
unset multiplot
"""
    gnuplot(script)
    os.remove(dat)
    print(f"wrote {DATA}/hho-convergence.{{csv,md,png}}")


if __name__ == "__main__":
    main()
