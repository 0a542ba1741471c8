#!/usr/bin/env python3
"""Exact, inexact and adaptive semismooth Newton on the Couplex-Gas benchmark
(doc/step-twophase.md), beside the published counts of [BDMV20].

All runs: 1000 cells, dt = 5000 years, to 1e6 years, GMRES + ILU(0) in the
field-wise ordering (in the cell-wise one ILU(0) is the exact LU and GMRES
always takes one iteration). Writes into doc/data/:
  twophase-strategies.csv   one row per run: cumulative Newton and GMRES
                            iterations to 5e5 and 1e6 years, work of
                            rejected steps, time-step cuts, wall time, and
                            the distance of the solution to the exact run
  twophase-strategies.md    the tables quoted in the documentation
  twophase-strategies.png   cumulative Newton and GMRES iterations in time

Usage: bench/twophase_strategies.py   (from the repository root, after the
build).
"""
import csv
import json
import os
import subprocess

from vi_bench import DATA, ROOT, gnuplot, program, write_csv, write_md

PROGRAM = program("twophase")
SCENE = os.path.join(ROOT, "parameters", "twophase-benchmark.prm")

SOLVER = "Nonlinear solver/"


def strategy(name, gamma_alg=None, gamma_lin=None, c_function=None, solver=None,
             watchdog_steps=None):
    """The settings of one run: Nonlinear solver/Strategy = name, the
    stopping parameters of the adaptive strategy, and the C-function, the
    solver and the watchdog where they are not the scene's."""
    settings = {SOLVER + "Solver": solver, SOLVER + "C-function": c_function,
                SOLVER + "Strategy": name, SOLVER + "gamma_alg": gamma_alg,
                SOLVER + "gamma_lin": gamma_lin, SOLVER + "Watchdog steps": watchdog_steps}
    return {key: value for key, value in settings.items() if value is not None}


FB = "fischer-burmeister"

# name, settings, published (Newton, GMRES) to 5e5 years [BDMV20]
RUNS = [
    ("min exact", strategy("exact"), (550, 6000)),
    ("min inexact", strategy("inexact"), (1000, 3000)),
    ("min adaptive (1e-1, 1e-1)", strategy("adaptive", "1e-1", "1e-1"), (100, 366)),
    ("min adaptive (1e-3, 1e-3)", strategy("adaptive", "1e-3", "1e-3"), (113, 427)),
    ("min adaptive (1e-6, 1e-3)", strategy("adaptive", "1e-6", "1e-3"), (108, 967)),
    ("min adaptive (1e-3, 1e-6)", strategy("adaptive", "1e-3", "1e-6"), (351, 1682)),
    ("FB exact", strategy("exact", c_function=FB), (757, 10089)),
    ("FB adaptive (1e-1, 1e-1)", strategy("adaptive", "1e-1", "1e-1", c_function=FB),
     (100, 428)),
    # the Armijo test on every step, as before the watchdog (4998727)
    ("FB exact, no watchdog", strategy("exact", c_function=FB, watchdog_steps="0"),
     (757, 10089)),
    ("FB adaptive (1e-1, 1e-1), no watchdog",
     strategy("adaptive", "1e-1", "1e-1", c_function=FB, watchdog_steps="0"), (100, 428)),
    ("KINSOL FB exact", strategy("exact", c_function=FB, solver="kinsol"), None),
    ("KINSOL FB inexact", strategy("inexact", c_function=FB, solver="kinsol"), None),
]


def run(name, settings):
    out = os.path.join(ROOT, "output", "bench", "twophase-strategies",
                       name.replace(" ", "_").replace("(", "").replace(")", "")
                       .replace(",", ""))
    command = [PROGRAM, SCENE, "--set", f"Output/Directory={out}",
               "--set", "Output/Write VTU=false",
               "--set", "Output/Progress interval=100000",
               "--set", "Linear solver/Ordering=field-wise"]
    for key, value in settings.items():
        command += ["--set", f"{key}={value}"]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    profiles = {}
    for n in range(7):
        path = os.path.join(out, f"profile-{n:03d}.csv")
        with open(path) as f:
            rows = list(csv.DictReader(f))
        profiles[float(rows[0]["time_years"])] = rows
    return summary, profiles


def main():
    os.makedirs(DATA, exist_ok=True)
    results = {}
    for name, settings, _ in RUNS:
        results[name] = run(name, settings)
        print(f"{name}: done", flush=True)

    reference_steps = results["min exact"][0]["steps"]
    reference_profiles = results["min exact"][1]
    rows = []
    for name, _, published in RUNS:
        summary, profiles = results[name]
        steps = summary["steps"]

        def total(key, t_end):
            return sum(s[key] for s in steps if s["time"] <= t_end + 1e-6)

        # Distance to the exact run: the x = 0 curves at the common times,
        # the gas saturation profiles at 1.05e5 and 3.5e5 years.
        reference = {round(s["time"], 6): s for s in reference_steps}
        common = [(s, reference[round(s["time"], 6)]) for s in steps
                  if round(s["time"], 6) in reference]
        d_sg = max(abs(s["gas_saturation_x0"] - r["gas_saturation_x0"])
                   for s, r in common)
        d_pg = max(abs(s["gas_pressure_x0"] - r["gas_pressure_x0"])
                   for s, r in common)
        d_profile = max(abs(float(a["S_g"]) - float(b["S_g"]))
                        for t in (105000.0, 350000.0)
                        for a, b in zip(profiles[t], reference_profiles[t]))
        rows.append({
            "run": name,
            "newton_5e5": total("newton_iterations", 5e5),
            "gmres_5e5": total("linear_iterations", 5e5),
            "newton_1e6": total("newton_iterations", 1e6),
            "gmres_1e6": total("linear_iterations", 1e6),
            "rejected_newton": summary["totals"]["rejected_newton_iterations"],
            "rejected_gmres": summary["totals"]["rejected_linear_iterations"],
            "time_step_cuts": summary["totals"]["time_step_cuts"],
            "wall_seconds": summary["totals"]["wall_seconds"],
            "max_diff_S_g_x0": d_sg,
            "max_diff_P_g_x0": d_pg,
            "max_diff_S_g_profiles": d_profile,
            "published_newton_5e5": published[0] if published else "",
            "published_gmres_5e5": published[1] if published else "",
        })

    write_csv("twophase-strategies", rows)

    lines = ["| run | Newton to 5e5 yr | GMRES to 5e5 yr | published Newton / GMRES "
             "| Newton to 1e6 yr | GMRES to 1e6 yr | cuts (rejected Newton) | "
             "max diff S_g(0) | max diff P_g(0) (Pa) | time loop (s) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        published = (f"{r['published_newton_5e5']} / {r['published_gmres_5e5']}"
                     if r["published_newton_5e5"] != "" else "-")
        lines.append(
            f"| {r['run']} | {r['newton_5e5']} | {r['gmres_5e5']} | {published} | "
            f"{r['newton_1e6']} | {r['gmres_1e6']} | {r['time_step_cuts']} "
            f"({r['rejected_newton']}) | {r['max_diff_S_g_x0']:.1e} | "
            f"{r['max_diff_P_g_x0']:.1e} | {r['wall_seconds']:.2f} |")
    # What the text says about the runs: the damping of FB's line search
    # (length 0: the watchdog went back to its reference iterate), from when
    # on the adaptive runs need one Newton iteration per step, and the
    # residuals of Newton-min in a step while the gas front advances.
    lines.append("")
    for name in ("FB exact", "FB adaptive (1e-1, 1e-1)", "FB exact, no watchdog",
                 "FB adaptive (1e-1, 1e-1), no watchdog"):
        lengths = sorted(it["step_length"] for s in results[name][0]["steps"]
                         for it in s["iterations"])
        damped = [t for t in lengths if 0 < t < 1]
        returns = sum(1 for t in lengths if t == 0)
        median = (f", median damped length {damped[len(damped) // 2]:g}"
                  if damped else "")
        lines.append(f"- {name}: {100 * len(damped) / len(lengths):.0f} % of the "
                     f"{len(lengths)} Newton steps damped by the line search"
                     f"{median}; {returns} returns to the watchdog's reference "
                     "iterate.")
    for name, _, _ in RUNS:
        if "min adaptive" not in name:
            continue
        steps = [s for s in results[name][0]["steps"] if s["time"] <= 5e5 + 1e-6]
        ones = [s["time"] for s in steps if s["newton_iterations"] == 1]
        gas = [s for s in steps if s["gas_saturation_x0"] > 1e-6]
        lines.append(f"- {name}: {len(ones)} of the {len(steps)} steps to 5e5 "
                     f"years need one Newton iteration ({sum(1 for s in gas if s['newton_iterations'] == 1)} "
                     f"of the {len(gas)} with gas at x = 0); the steps with gas "
                     f"need {sum(s['newton_iterations'] for s in gas) / len(gas):.1f} "
                     f"on average.")
    step = next(s for s in results["min exact"][0]["steps"]
                if abs(s["time"] - 27500) < 1e-6)
    lines.append("- min exact, step to 27500 years: scaled balance residuals "
                 + ", ".join(f"{it['residual_equations']:.1e}"
                             for it in step["iterations"])
                 + " after the Newton iterations.")
    write_md("twophase-strategies", lines, echo=True)

    # Cumulative iterations in time (the slides' "overall performance").
    dat = os.path.join(DATA, "twophase-strategies.dat")
    shown = ["min exact", "min inexact", "min adaptive (1e-3, 1e-3)"]
    with open(dat, "w") as f:
        for name in shown:
            newton = gmres = 0
            f.write(f"# {name}\n0 0 0\n")
            for s in results[name][0]["steps"]:
                newton += s["newton_iterations"]
                gmres += s["linear_iterations"]
                f.write(f"{s['time']} {newton} {gmres}\n")
            f.write("\n\n")
    plots_newton = ", ".join(f"'{dat}' index {i} using 1:2 with lines lw 2 "
                             f"title '{name}'" for i, name in enumerate(shown))
    plots_gmres = ", ".join(f"'{dat}' index {i} using 1:3 with lines lw 2 "
                            f"title '{name}'" for i, name in enumerate(shown))
    script = f"""set terminal pngcairo size 1000,450 font ',12'
set output '{os.path.join(DATA, "twophase-strategies.png")}'
set multiplot layout 1,2 title 'cumulative iterations, field-wise ILU(0), 1000 cells, dt = 5000 years'
set xlabel 'time (years)'
set format x '%.0e'
set xtics 2e5
set grid
set key top left
set ylabel 'Newton iterations'
plot {plots_newton}
set ylabel 'GMRES iterations'
plot {plots_gmres}
unset multiplot
"""
    gnuplot(script)
    os.remove(dat)
    print(f"wrote {DATA}/twophase-strategies.{{csv,md,png}}")


if __name__ == "__main__":
    main()
