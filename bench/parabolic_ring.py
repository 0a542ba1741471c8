#!/usr/bin/env python3
"""The ring test of [DMV20p] with step-parabolic (doc/step-parabolic.md):
exact against adaptive inexact semismooth Newton (min and Fischer-Burmeister)
with GMRES + ILU(0), p = 1 (12288 cells) and p = 2 (3072 cells), dt = 1e-3 to
T = 0.3 (parameters/parabolic-ring.prm). Writes into doc/data/:

  parabolic-ring.{csv,md}            cumulative Newton and GMRES counts, the
                                     published numbers beside them, wall time,
                                     the final estimate, and the difference
                                     between the exact and adaptive solutions
  parabolic-ring-onset.md            when contact begins in each ring
  parabolic-ring-steps.csv           per step: time, Newton, GMRES, contact
  parabolic-ring-gmres.png           cumulative GMRES against time
  parabolic-ring-contact.png         nodes in contact per ring against time

Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/parabolic_ring.py [--quick]
--quick runs coarser meshes to T = 0.1 (a smoke test of the script, not the
published setting). The full study takes about 20 minutes on a shared
2-core machine (at 4998727). STEP_PARABOLIC names another binary (e.g. a copy, so that
the build tree can be rebuilt while the study runs).
"""
import os
import sys

from vi_bench import DATA, ROOT, gnuplot, program, run as run_program, write_csv, write_md

PROGRAM = program("parabolic")
OUT = os.path.join(ROOT, "output", "bench-parabolic-ring")
QUICK = "--quick" in sys.argv

# [DMV20p] as quoted in doc/reference.md (exact, adaptive); None where
# the paper gives no number.
PUBLISHED = {
    (1, "min"): {"newton": (None, None), "gmres": (19000, 7000),
                 "note": "Newton about halved"},
    (1, "fischer-burmeister"): {"newton": (1500, 700), "gmres": (27000, 7000),
                                "note": ""},
    (2, None): {"newton": (912, 585), "gmres": (27085, 8760),
                "note": "C-function not stated"},
}


def run(name, settings):
    directory = os.path.join(OUT, name)
    quick = {"Time stepping/Final time": 0.1} if QUICK else {}
    summary = run_program(PROGRAM, "parabolic-ring.prm",
                          {**settings, **quick, "Output/Write VTU": "false"}, directory)
    print(f"  {name}: {summary['totals']['newton_iterations']} Newton, "
          f"{summary['totals']['linear_iterations']} GMRES", flush=True)
    return directory, summary


def onset(summary):
    """First time with contact in each ring (None if never)."""
    times = [None] * 5
    for step in summary["steps"]:
        for ring, nodes in enumerate(step.get("contact_nodes_per_ring", [])):
            if nodes > 0 and times[ring] is None:
                times[ring] = step["time"]
    return times


def main():
    os.makedirs(DATA, exist_ok=True)
    rows, onsets, step_rows = [], [], []
    for degree, refinements in ((1, 5), (2, 4)):
        if QUICK:
            refinements -= 2
        for c_function in ("min", "fischer-burmeister"):
            runs = {}
            for strategy in ("exact", "adaptive"):
                name = f"p{degree}-{c_function}-{strategy}"
                settings = {"Discretization/Polynomial degree": degree,
                            "Mesh/Initial refinements": refinements,
                            "Nonlinear solver/C-function": c_function,
                            "Nonlinear solver/Strategy": strategy}
                if strategy == "adaptive":
                    settings["Output/Compare with"] = runs["exact"][0]
                runs[strategy] = run(name, settings)
            exact, adaptive = runs["exact"][1], runs["adaptive"][1]
            published = PUBLISHED.get((degree, c_function), PUBLISHED.get((degree, None)))
            row = {
                "p": degree,
                "c_function": c_function,
                "cells": exact["mesh"]["cells"],
                "unknowns": exact["mesh"]["dofs"],
                "newton_exact": exact["totals"]["newton_iterations"],
                "newton_adaptive": adaptive["totals"]["newton_iterations"],
                "gmres_exact": exact["totals"]["linear_iterations"],
                "gmres_adaptive": adaptive["totals"]["linear_iterations"],
                "published_newton_exact": published["newton"][0],
                "published_newton_adaptive": published["newton"][1],
                "published_gmres_exact": published["gmres"][0],
                "published_gmres_adaptive": published["gmres"][1],
                "eta_exact": exact["totals"]["eta"],
                "eta_adaptive": adaptive["totals"]["eta"],
                "difference_energy": adaptive["compared_with"]["difference_energy"],
                "difference_l2": adaptive["compared_with"]["difference_l2"],
                "wall_exact": sum(s["wall_seconds"] for s in exact["steps"]),
                "wall_adaptive": sum(s["wall_seconds"] for s in adaptive["steps"]),
            }
            rows.append(row)
            for strategy, (_, s) in runs.items():
                onsets.append({"p": degree, "c_function": c_function,
                               "strategy": strategy,
                               "onset": onset(s)})
                cumulative = 0
                for step in s["steps"]:
                    cumulative += step["linear_iterations"]
                    step_rows.append({
                        "p": degree, "c_function": c_function,
                        "strategy": strategy, "step": step["step"],
                        "time": step["time"],
                        "newton": step["newton_iterations"],
                        "gmres": step["linear_iterations"],
                        "cumulative_gmres": cumulative,
                        "contact": step["contact_nodes"],
                        **{f"contact_ring_{k}": n for k, n in
                           enumerate(step.get("contact_nodes_per_ring", []))},
                        "eta_step": step["estimate"]["eta"],
                        "eta_time": step["estimate"]["eta_time"]})

    write_csv("parabolic-ring", rows)
    write_csv("parabolic-ring-steps", step_rows)

    def published(value):
        return "-" if value is None else f"{value}"

    lines = ["| p | C-function | cells (unknowns) | Newton exact / adaptive | published | "
             "GMRES exact / adaptive | published | exact - adaptive (energy) | "
             "eta exact / adaptive | wall s exact / adaptive |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['p']} | {r['c_function']} | {r['cells']} ({r['unknowns']}) | "
            f"{r['newton_exact']} / {r['newton_adaptive']} | "
            f"{published(r['published_newton_exact'])} / "
            f"{published(r['published_newton_adaptive'])} | "
            f"{r['gmres_exact']} / {r['gmres_adaptive']} | "
            f"{published(r['published_gmres_exact'])} / "
            f"{published(r['published_gmres_adaptive'])} | "
            f"{r['difference_energy']:.2e} | "
            f"{r['eta_exact']:.4e} / {r['eta_adaptive']:.4e} | "
            f"{r['wall_exact']:.0f} / {r['wall_adaptive']:.0f} |")
    write_md("parabolic-ring", lines)

    lines = ["| p | C-function | strategy | " +
             " | ".join(f"ring {k + 1}" for k in range(5)) + " |",
             "|---|---|---|" + "---|" * 5]
    for o in onsets:
        lines.append(f"| {o['p']} | {o['c_function']} | {o['strategy']} | " +
                     " | ".join("-" if t is None else f"{t:.3f}" for t in o["onset"])
                     + " |")
    write_md("parabolic-ring-onset", lines)

    # Plots from the per-step CSV.
    steps_csv = os.path.join(DATA, "parabolic-ring-steps.csv")
    columns = {key: i + 1 for i, key in enumerate(step_rows[0].keys())}

    def select(p, c, s):
        return (f"'< grep \"^{p},{c},{s},\" {steps_csv}'")
    plots = []
    for p in (1, 2):
        for c in ("min", "fischer-burmeister"):
            for s in ("exact", "adaptive"):
                plots.append(f"{select(p, c, s)} using {columns['time']}:"
                             f"{columns['cumulative_gmres']} with lines "
                             f"title 'p = {p}, {c}, {s}'")
    gnuplot(f"""set terminal pngcairo size 900,600 noenhanced
set output '{os.path.join(DATA, "parabolic-ring-gmres.png")}'
set datafile separator ','
set key left top
set xlabel 't'
set ylabel 'cumulative GMRES iterations'
set grid
plot {", ".join(plots)}
""")
    ring_columns = [columns.get(f"contact_ring_{k}") for k in range(5)]
    if all(ring_columns):
        plots = [f"{select(1, 'min', 'adaptive')} using {columns['time']}:"
                 f"{ring_columns[k]} with lines title 'ring {k + 1}'"
                 for k in range(5)]
        gnuplot(f"""set terminal pngcairo size 900,600 noenhanced
set output '{os.path.join(DATA, "parabolic-ring-contact.png")}'
set datafile separator ','
set key left top
set xlabel 't'
set ylabel 'nodes in contact (p = 1, Newton-min, adaptive)'
set grid
plot {", ".join(plots)}
""")
    print("written doc/data/parabolic-ring*.{csv,md,png}")


if __name__ == "__main__":
    main()
