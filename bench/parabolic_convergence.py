#!/usr/bin/env python3
"""Convergence of step-parabolic on the case with an exact solution
(parameters/parabolic-expression.prm; doc/step-parabolic.md). Writes into
doc/data/:

  parabolic-convergence.{csv,md}  error E = (int_0^T |||u - u_ht|||^2 dt
                                  + |(u - u_h)(T)|^2)^(1/2), the estimate and
                                  the effectivity, (a) against dt on a fine
                                  Q2 mesh, (b) refining h and dt together
                                  with Q1, with the observed orders
  parabolic-convergence.png       E and eta against dt
  parabolic-effectivity.png       E(t), eta(t) and eta / E along one run
  parabolic-adaptive-dt.{csv,md}  adaptive time steps (three targets)
                                  against fixed ones: steps, error, estimate
  parabolic-ring-adaptive-dt.md   the same for the ring test (3072 cells):
  parabolic-ring-dt.png           steps, iterations, estimate, contact onset,
                                  and dt against t

Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/parabolic_convergence.py [--quick]
--quick: coarser meshes and fewer steps (a smoke test of the script). The
full study takes about half an hour on a shared 2-core machine.
STEP_PARABOLIC names another binary.
"""
import math
import os
import sys

from vi_bench import DATA, ROOT, gnuplot, program, run as run_program, write_csv, write_md

PROGRAM = program("parabolic")
OUT = os.path.join(ROOT, "output", "bench-parabolic-convergence")
QUICK = "--quick" in sys.argv
SCENE = "parabolic-expression.prm"


def run(name, settings):
    summary = run_program(PROGRAM, SCENE, {**settings, "Output/Write VTU": "false"},
                          os.path.join(OUT, name))
    t = summary["totals"]
    print(f"  {name}: {t['steps']} steps, error {t['error']:.4e}, "
          f"eta {t['eta']:.4e}", flush=True)
    return summary


def row(study, summary, degree, refinements, dt, adaptive=""):
    t = summary["totals"]
    return {"study": study, "p": degree, "refinements": refinements,
            "cells": summary["mesh"]["cells"],
            "dofs_per_field": summary["mesh"]["dofs_per_field"],
            "dt": dt, "adaptive": adaptive, "steps": t["steps"],
            "rejected": t["rejected_steps"],
            "error": t["error"], "eta": t["eta"],
            "eta_init": t["eta_init"], "eta_disc": t["eta_disc"],
            "effectivity": t["effectivity"]}


def rates(rows, key):
    out = [None]
    for a, b in zip(rows, rows[1:]):
        out.append(math.log(a[key] / b[key]) / math.log(a["dt"] / b["dt"]))
    return out


def main():
    os.makedirs(DATA, exist_ok=True)
    base = {"Nonlinear solver/Strategy": "exact", "Linear solver/Solver": "direct",
            "Time stepping/Final time": 0.5}

    # (a) dt -> 0 on a fixed fine mesh, Q2.
    time_rows = []
    fine = 3 if QUICK else 4
    levels = 3 if QUICK else 6
    for k in range(levels):
        dt = 0.1 / 2 ** k
        s = run(f"time-p2-dt{k}", {**base, "Discretization/Polynomial degree": 2,
                                   "Mesh/Initial refinements": fine,
                                   "Time stepping/Time step": dt})
        time_rows.append(row("dt", s, 2, fine, dt))
        if k == levels - 1:
            along = s
    # (b) h and dt together, Q1.
    joint_rows = []
    for k in range(3 if QUICK else 4):
        dt = 0.1 / 2 ** k
        s = run(f"joint-p1-{k}", {**base, "Discretization/Polynomial degree": 1,
                                  "Mesh/Initial refinements": 2 + k,
                                  "Time stepping/Time step": dt})
        joint_rows.append(row("h and dt", s, 1, 2 + k, dt))

    for rows in (time_rows, joint_rows):
        for r, e, n in zip(rows, rates(rows, "error"), rates(rows, "eta")):
            r["rate_error"], r["rate_eta"] = e, n

    # Adaptive time steps against fixed ones, Q1 on 3072 cells.
    adaptive_rows = []
    medium = 3 if QUICK else 4
    for k in range(4):
        dt = 0.1 / 2 ** k
        s = run(f"fixed-p1-dt{k}", {**base, "Mesh/Initial refinements": medium,
                                    "Time stepping/Time step": dt})
        adaptive_rows.append(row("fixed", s, 1, medium, dt))
    for ratio in (1, 0.5, 0.25):
        s = run(f"adaptive-p1-{ratio}",
                {**base, "Mesh/Initial refinements": medium,
                 "Time stepping/Time step": 0.01,
                 "Time stepping/Adaptive": "true",
                 "Time stepping/Time-space ratio": ratio,
                 "Time stepping/Maximal time step": 0.1})
        adaptive_rows.append(row("adaptive", s, 1, medium, None, ratio))

    write_csv("parabolic-convergence", time_rows + joint_rows)
    write_csv("parabolic-adaptive-dt", adaptive_rows)

    def fmt_rate(x):
        return "-" if x is None else f"{x:.2f}"

    lines = []
    for title, rows in (("(a) dt -> 0, Q2, %d cells" % time_rows[0]["cells"], time_rows),
                        ("(b) h and dt halved together, Q1", joint_rows)):
        lines += [f"**{title}**", "",
                  "| cells | dt | steps | error E | rate | eta | rate | effectivity |",
                  "|---|---|---|---|---|---|---|---|"]
        for r in rows:
            lines.append(f"| {r['cells']} | {r['dt']:.5g} | {r['steps']} | "
                         f"{r['error']:.4e} | {fmt_rate(r['rate_error'])} | "
                         f"{r['eta']:.4e} | {fmt_rate(r['rate_eta'])} | "
                         f"{r['effectivity']:.3f} |")
        lines.append("")
    with open(os.path.join(DATA, "parabolic-convergence.md"), "w") as f:
        f.write("\n".join(lines))

    lines = ["| time steps | target ratio | steps (rejected) | error E | eta | effectivity |",
             "|---|---|---|---|---|---|"]
    for r in adaptive_rows:
        label = f"fixed dt = {r['dt']:.5g}" if r["study"] == "fixed" else "adaptive"
        ratio = "-" if r["study"] == "fixed" else f"{r['adaptive']}"
        lines.append(f"| {label} | {ratio} | {r['steps']} ({r['rejected']}) | "
                     f"{r['error']:.4e} | {r['eta']:.4e} | {r['effectivity']:.3f} |")
    write_md("parabolic-adaptive-dt", lines)

    # Plots.
    table = os.path.join(OUT, "convergence-plot.dat")
    with open(table, "w") as f:
        for rows in (time_rows, joint_rows):
            for r in rows:
                f.write(f"{r['dt']} {r['error']} {r['eta']}\n")
            f.write("\n\n")
    gnuplot(f"""set terminal pngcairo size 900,600 noenhanced
set output '{os.path.join(DATA, "parabolic-convergence.png")}'
set logscale xy
set key left top
set xlabel 'dt'
set ylabel 'error E and estimate eta'
set grid
plot '{table}' index 0 using 1:2 with linespoints title 'error, Q2, fixed mesh', \\
     '{table}' index 0 using 1:3 with linespoints title 'eta, Q2, fixed mesh', \\
     '{table}' index 1 using 1:2 with linespoints title 'error, Q1, h ~ dt', \\
     '{table}' index 1 using 1:3 with linespoints title 'eta, Q1, h ~ dt', \\
     x * {time_rows[0]['error'] / time_rows[0]['dt']} dashtype 2 title 'order 1'
""")
    series = os.path.join(OUT, "effectivity-plot.dat")
    with open(series, "w") as f:
        for step in along["steps"]:
            f.write(f"{step['time']} {step['error']} {step['eta']} {step['effectivity']}\n")
    gnuplot(f"""set terminal pngcairo size 900,600 noenhanced
set output '{os.path.join(DATA, "parabolic-effectivity.png")}'
set key left top
set xlabel 't'
set ylabel 'E(t), eta(t)'
set y2label 'eta / E'
set y2tics
set ytics nomirror
set grid
plot '{series}' using 1:2 with lines title 'error E(t)', \\
     '{series}' using 1:3 with lines title 'estimate eta(t)', \\
     '{series}' using 1:4 axes x1y2 with lines title 'effectivity (right axis)'
""")
    ring_adaptive_dt()
    print("written doc/data/parabolic-{convergence,effectivity,adaptive-dt,ring-adaptive-dt,ring-dt}.*")


def ring_adaptive_dt():
    """The ring test (p = 1, 3072 cells) with dt = 1e-3 fixed and adaptive."""
    final_time = 0.1 if QUICK else 0.3
    runs = []
    for label, settings in (("fixed dt = 1e-3", {}),
                            ("adaptive, target 1", {"Time stepping/Adaptive": "true",
                                                    "Time stepping/Time-space ratio": 1}),
                            ("adaptive, target 0.25", {"Time stepping/Adaptive": "true",
                                                       "Time stepping/Time-space ratio": 0.25})):
        name = "ring-" + label.replace(" ", "").replace(",", "-").replace("=", "")
        directory = os.path.join(OUT, name)
        s = run_program(PROGRAM, "parabolic-ring.prm",
                        {"Mesh/Initial refinements": 4, "Time stepping/Final time": final_time,
                         "Time stepping/Maximal time step": 0.02,
                         "Output/Write VTU": "false", **settings}, directory)
        onset = [None] * 5
        for step in s["steps"]:
            for ring, nodes in enumerate(step["contact_nodes_per_ring"]):
                if nodes > 0 and onset[ring] is None:
                    onset[ring] = step["time"]
        runs.append((label, s, onset, directory))
        print(f"  ring {label}: {s['totals']['steps']} steps", flush=True)

    lines = ["| time steps | steps (rejected) | Newton | GMRES | eta(T) | "
             "contact begins (rings 1, 2, 3) |", "|---|---|---|---|---|---|"]
    for label, s, onset, _ in runs:
        t = s["totals"]
        lines.append(f"| {label} | {t['steps']} ({t['rejected_steps']}) | "
                     f"{t['newton_iterations']} | {t['linear_iterations']} | "
                     f"{t['eta']:.4e} | " +
                     ", ".join("-" if x is None else f"{x:.4f}" for x in onset[:3]) + " |")
    write_md("parabolic-ring-adaptive-dt", lines)
    plots = []
    for label, s, _, directory in runs:
        series = os.path.join(directory, "dt.dat")
        with open(series, "w") as f:
            for step in s["steps"]:
                f.write(f"{step['time']} {step['dt']}\n")
        plots.append(f"'{series}' using 1:2 with steps title '{label}'")
    gnuplot(f"""set terminal pngcairo size 900,600 noenhanced
set output '{os.path.join(DATA, "parabolic-ring-dt.png")}'
set logscale y
set key right bottom
set xlabel 't'
set ylabel 'dt'
set grid
plot {", ".join(plots)}
""")


if __name__ == "__main__":
    main()
