#!/usr/bin/env python3
"""Convergence of step-twophase under refinement in space and time
(doc/step-twophase.md): the Couplex-Gas benchmark on 250, 500, 1000 and
2000 cells with dt = 20000, 10000, 5000 and 2500 years (h and dt halved
together), against a reference run on 4000 cells with dt = 1250 years.
Newton-min, exact strategy, cell-wise ordering. Writes into doc/data/:
  twophase-convergence.csv   per level: the distances of the curves at x = 0
                             (leftmost cell) to the reference, maximum over
                             the times multiple of 20000 years, the times of
                             the events, iteration counts
  twophase-convergence.md    the table quoted in the documentation
  twophase-convergence.png   S_g and P_g at x = 0 for every level

Usage: bench/twophase_convergence.py   (from the repository root, after the
build).
"""
import csv
import math
import os

from vi_bench import DATA, ROOT, gnuplot, program, run as run_program, write_csv, write_md

PROGRAM = program("twophase")
SCENE = "twophase-benchmark.prm"
LEVELS = [(250, 20000), (500, 10000), (1000, 5000), (2000, 2500)]
REFERENCE = (4000, 1250)
GAS = 1e-6


def run(cells, dt):
    out = os.path.join(ROOT, "output", "bench", "twophase-convergence",
                       f"{cells}-cells")
    totals = run_program(PROGRAM, SCENE,
                         {"Output/Write VTU": "false",
                          "Output/Progress interval": 100000,
                          "Mesh/Number of cells": cells, "Time stepping/Time step": dt,
                          "Time stepping/Output times": 1000000}, out)["totals"]
    with open(os.path.join(out, "x0.csv")) as f:
        x0 = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]
    return x0, totals


def on_grid(x0, step=20000):
    return {round(r["time_years"]): r for r in x0
            if abs(r["time_years"] / step - round(r["time_years"] / step)) < 1e-9}


def event_times(x0):
    t = [0.0] + [r["time_years"] for r in x0]
    s = [0.0] + [r["S_g"] for r in x0]
    appear = next(i for i in range(1, len(s)) if s[i] > GAS)
    peak = max(range(len(s)), key=lambda i: s[i])
    vanish = next(i for i in range(peak, len(s)) if s[i] <= GAS)
    return (t[appear - 1], t[appear]), (t[vanish - 1], t[vanish])


def main():
    os.makedirs(DATA, exist_ok=True)
    reference, _ = run(*REFERENCE)
    ref = on_grid(reference)
    results = []
    for cells, dt in LEVELS:
        x0, totals = run(cells, dt)
        results.append((cells, dt, x0, totals))
        print(f"{cells} cells: done", flush=True)

    rows = []
    for cells, dt, x0, totals in results + [(*REFERENCE, reference, None)]:
        grid = on_grid(x0)
        times = sorted(set(grid) & set(ref))
        distance = {key: max(abs(grid[t][key] - ref[t][key]) for t in times)
                    for key in ("S_g", "P_l", "P_g", "chi")}
        (a0, a1), (v0, v1) = event_times(x0)
        rows.append({"cells": cells, "dt_years": dt,
                     "max_diff_S_g": distance["S_g"],
                     "max_diff_P_l": distance["P_l"],
                     "max_diff_P_g": distance["P_g"],
                     "max_diff_chi": distance["chi"],
                     "max_S_g": max(r["S_g"] for r in x0),
                     "max_P_g": max(r["P_g"] for r in x0),
                     "front_at_40000": grid[40000]["gas_front_m"],
                     "appearance_from": a0, "appearance_to": a1,
                     "disappearance_from": v0, "disappearance_to": v1,
                     "newton": totals["newton_iterations"] if totals else "",
                     "cuts": totals["time_step_cuts"] if totals else ""})

    write_csv("twophase-convergence", rows)

    def rate(n, key):
        if n == 0 or n >= len(LEVELS):
            return "-"
        return f"{math.log2(rows[n - 1][key] / rows[n][key]):.2f}"

    lines = ["| cells | dt (yr) | max diff S_g(0) | rate | max diff P_l(0) (Pa) | "
             "rate | max diff P_g(0) (Pa) | rate | max diff chi(0) | rate | "
             "front at 40000 yr (m) | gas appears (yr) | gas disappears (yr) "
             "| Newton |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for n, r in enumerate(rows):
        if n == len(LEVELS):
            lines.append(
                f"| {r['cells']} (reference) | {r['dt_years']} | | | | | | | | | "
                f"{r['front_at_40000']:.1f} | {r['appearance_from']:.0f} - "
                f"{r['appearance_to']:.0f} | {r['disappearance_from']:.0f} - "
                f"{r['disappearance_to']:.0f} | |")
            continue
        lines.append(
            f"| {r['cells']} | {r['dt_years']} | {r['max_diff_S_g']:.2e} | "
            f"{rate(n, 'max_diff_S_g')} | {r['max_diff_P_l']:.2e} | "
            f"{rate(n, 'max_diff_P_l')} | {r['max_diff_P_g']:.2e} | "
            f"{rate(n, 'max_diff_P_g')} | {r['max_diff_chi']:.2e} | "
            f"{rate(n, 'max_diff_chi')} | {r['front_at_40000']:.1f} | "
            f"{r['appearance_from']:.0f} - {r['appearance_to']:.0f} | "
            f"{r['disappearance_from']:.0f} - {r['disappearance_to']:.0f} | "
            f"{r['newton']} |")
    write_md("twophase-convergence", lines, echo=True)

    dat = os.path.join(DATA, "twophase-convergence.dat")
    labels = []
    with open(dat, "w") as f:
        for cells, dt, x0, _ in results + [(*REFERENCE, reference, None)]:
            labels.append(f"{cells} cells, dt = {dt} yr")
            for r in x0:
                f.write(f"{r['time_years']} {r['S_g']} {r['P_g']}\n")
            f.write("\n\n")
    sg = ", ".join(f"'{dat}' index {i} using 1:2 with lines lw 2 title '{label}'"
                   for i, label in enumerate(labels))
    pg = ", ".join(f"'{dat}' index {i} using 1:3 with lines lw 2 title '{label}'"
                   for i, label in enumerate(labels))
    script = f"""set terminal pngcairo size 1000,700 font ',12'
set output '{os.path.join(DATA, "twophase-convergence.png")}'
set multiplot layout 2,1 title 'x = 0 under refinement of h and dt together'
set xlabel 'time (years)'
set format x '%.0e'
set grid
set key top right
set ylabel 'S_g(0, t)'
plot {sg}
set ylabel 'P_g(0, t) (Pa)'
set format y '%.2e'
plot {pg}
unset multiplot
"""
    gnuplot(script)
    os.remove(dat)
    print(f"wrote {DATA}/twophase-convergence.{{csv,md,png}}")


if __name__ == "__main__":
    main()
