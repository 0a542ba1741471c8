#!/usr/bin/env python3
"""The Couplex-Gas / MoMaS benchmark with step-twophase (doc/step-twophase.md).

Runs parameters/twophase-benchmark.prm (1000 cells, dt = 5000 years, to 1e6
years; Newton-min, exact strategy) and writes into doc/data/:
  twophase-benchmark-x0.csv        S_g, P_l, P_g, chi at x = 0 per time step
  twophase-benchmark-profiles.csv  the profiles at the output times
  twophase-benchmark.md            the benchmark quantities and timings
  twophase-regularization.md       the same quantities for four widths of
                                   the regularisation of van Genuchten-Mualem
  twophase-tolerances.md           failed steps with the suite's default
                                   Newton and GMRES tolerances
  twophase-x0.png                  gas saturation and pressures at x = 0
  twophase-profiles.png            profiles at the times of the slides
  twophase-phase-transition.png    the phase-transition estimator at 2500,
                                   12500 and 42500 years (the slides' maps)
The times of gas appearance and disappearance are also measured with
dt = 250 years, and the wall time of the whole benchmark (best of 3 runs).

Usage: bench/twophase_benchmark.py   (from the repository root, after
./demo.sh or ./test.sh has built the programs).
"""
import csv
import json
import os
import subprocess
import time

from vi_bench import DATA, ROOT, gnuplot, program, write_csv, write_md

PROGRAM = program("twophase")
SCENE = os.path.join(ROOT, "parameters", "twophase-benchmark.prm")
GAS = 1e-6  # gas present where S_g exceeds this (as in the program)


def run(name, *settings):
    """Run the benchmark scene with --set overrides; return the output
    directory and the process wall time."""
    out = os.path.join(ROOT, "output", "bench", name)
    command = [PROGRAM, SCENE, "--set", f"Output/Directory={out}",
               "--set", "Output/Progress interval=100000"]
    for setting in settings:
        command += ["--set", setting]
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return out, time.perf_counter() - start


def read_csv(path):
    with open(path) as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def events(x0):
    """Appearance and disappearance of gas at x = 0, as (last time without,
    first time with) and (last time with, first time without)."""
    t = [0.0] + [r["time_years"] for r in x0]
    s = [0.0] + [r["S_g"] for r in x0]
    appear = next(i for i in range(1, len(s)) if s[i] > GAS)
    peak = max(range(len(s)), key=lambda i: s[i])
    vanish = next((i for i in range(peak, len(s)) if s[i] <= GAS), None)
    return ((t[appear - 1], t[appear]),
            (t[vanish - 1], t[vanish]) if vanish else None)


def main():
    os.makedirs(DATA, exist_ok=True)

    # The benchmark, three times for the wall time.
    walls, internal = [], []
    for _ in range(3):
        out, wall = run("twophase-benchmark")
        walls.append(wall)
        with open(os.path.join(out, "summary.json")) as f:
            summary = json.load(f)
        internal.append(summary["totals"]["wall_seconds"])
    x0 = read_csv(os.path.join(out, "x0.csv"))
    steps = summary["steps"]

    # The same with dt = 250 years, for the times of the events.
    fine_out, _ = run("twophase-benchmark-dt250", "Time stepping/Time step=250")
    x0_fine = read_csv(os.path.join(fine_out, "x0.csv"))

    # Data for doc/data.
    with open(os.path.join(DATA, "twophase-benchmark-x0.csv"), "w") as f:
        with open(os.path.join(out, "x0.csv")) as g:
            f.write(g.read())
    profiles = []
    for n in range(7):
        path = os.path.join(out, f"profile-{n:03d}.csv")
        if os.path.exists(path):
            profiles += read_csv(path)
    write_csv("twophase-benchmark-profiles", profiles)

    def at(rows, t, key):
        return next(r[key] for r in rows if abs(r["time_years"] - t) < 1e-6)

    def maximum(rows, key):
        r = max(rows, key=lambda r: r[key])
        return r[key], r["time_years"]

    def until(t_end, key):
        return sum(s[key] for s in steps if s["time"] <= t_end + 1e-6)

    # Before gas appears, hydrogen only diffuses: with the constant flux F
    # into a half-space, the dissolved concentration at x = 0 is
    # 2 F sqrt(t) / (phi sqrt(pi D)); it reaches the solubility
    # c_s = H P M_h (kg per m^3 of liquid) at t = pi D (phi c_s / 2F)^2.
    phi, D = 0.15, 3e-9 * 365 * 24 * 3600          # D in m^2/yr
    c_s, F = 7.65e-6 * 1e6 * 2e-3, 5.57e-6
    t_diffusion = 3.141592653589793 * D * (phi * c_s / (2 * F)) ** 2

    appear, vanish = events(x0)
    appear_fine, vanish_fine = events(x0_fine)
    sg_max, t_sg = maximum(x0, "S_g")
    pl_max, t_pl = maximum(x0, "P_l")
    pg_max, t_pg = maximum(x0, "P_g")
    sg_fine, t_sg_fine = maximum(x0_fine, "S_g")
    pl_min, t_pl_min = min((r["P_l"], r["time_years"]) for r in x0)
    pl_min_fine, t_pl_min_fine = min((r["P_l"], r["time_years"]) for r in x0_fine)
    pl_fine, t_pl_fine = maximum(x0_fine, "P_l")
    pg_fine, t_pg_fine = maximum(x0_fine, "P_g")
    lines = [
        "| quantity | dt = 5000 yr | dt = 250 yr | published [BDMV20] |",
        "|---|---:|---:|---:|",
        f"| gas appears at x = 0 (yr) | {appear[0]:.0f} - {appear[1]:.0f} | "
        f"{appear_fine[0]:.0f} - {appear_fine[1]:.0f} | about 1.25e4 |",
        f"| (diffusion alone, half-space, analytic) | {t_diffusion:.0f} | | |",
        f"| gas front at 42500 yr (m) | {at(x0, 42500, 'gas_front_m'):.1f} | "
        f"{at(x0_fine, 42500, 'gas_front_m'):.1f} | near 45 (fig) |",
        f"| max S_g(0) (at yr) | {sg_max:.4f} ({t_sg:.0f}) | "
        f"{sg_fine:.4f} ({t_sg_fine:.0f}) | |",
        f"| max P_l(0) (Pa, at yr) | {pl_max:.4e} ({t_pl:.0f}) | "
        f"{pl_fine:.4e} ({t_pl_fine:.0f}) | |",
        f"| max P_g(0) (Pa, at yr) | {pg_max:.4e} ({t_pg:.0f}) | "
        f"{pg_fine:.4e} ({t_pg_fine:.0f}) | |",
        f"| min P_l(0) after the injection (Pa, at yr) | {pl_min:.4e} ({t_pl_min:.0f}) | "
        f"{pl_min_fine:.4e} ({t_pl_min_fine:.0f}) | |",
        f"| gas disappears from x = 0 (yr) | {vanish[0]:.0f} - {vanish[1]:.0f} | "
        f"{vanish_fine[0]:.0f} - {vanish_fine[1]:.0f} | |",
        "",
        "| run (1000 cells, dt = 5000 yr, Newton-min, exact, cell-wise) | value |",
        "|---|---:|",
        f"| time steps to 5e5 / 1e6 yr | "
        f"{sum(1 for s in steps if s['time'] <= 5e5 + 1e-6)} / {len(steps)} |",
        f"| Newton iterations to 5e5 / 1e6 yr | {until(5e5, 'newton_iterations')} / "
        f"{until(1e6, 'newton_iterations')} |",
        f"| time-step cuts | {summary['totals']['time_step_cuts']} |",
        f"| wall time of the process, best of 3 (s) | {min(walls):.2f} |",
        f"| of which the time loop (s) | {min(internal):.2f} |",
        f"| process start-up and parameter parsing, `--help` (s) | "
        f"{startup():.2f} |",
    ]
    write_md("twophase-benchmark", lines, echo=True)

    # The suite's default tolerances (Newton 1e-10, GMRES 1e-12) are below
    # what rounding lets this problem reach: count the failed steps to
    # 1e5 years (the field-wise ordering, where GMRES iterates).
    lines = ["| tolerances (to 1e5 yr, field-wise) | time-step cuts | "
             "first failure |", "|---|---:|---|"]
    for newton_tol, gmres_tol in (("1e-8", "1e-10"), ("1e-10", "1e-10"),
                                  ("1e-8", "1e-12")):
        tol_out, _ = run(f"twophase-tolerance-{newton_tol}-{gmres_tol}",
                         f"Nonlinear solver/Tolerance={newton_tol}",
                         f"Linear solver/Tolerance={gmres_tol}",
                         "Linear solver/Ordering=field-wise",
                         "Time stepping/Final time=1e5",
                         "Time stepping/Output times=1e5",
                         "Output/Write VTU=false")
        with open(os.path.join(tol_out, "summary.json")) as f:
            tol_summary = json.load(f)
        cut_log = tol_summary["time_step_cuts"]
        first = (cut_log[0]["reason"].split(" (")[0] if cut_log else "-")
        lines.append(f"| Newton {newton_tol}, GMRES {gmres_tol} | "
                     f"{len(cut_log)} | {first} |")
    write_md("twophase-tolerances", lines, echo=True)

    # The regularisation width of the van Genuchten-Mualem laws.
    lines = ["| Physics/Regularization | max S_g(0) | P_g(0) at 42500 yr (Pa) | "
             "front at 42500 yr (m) | gas disappears from x = 0 (yr) | "
             "Newton iterations |",
             "|---:|---:|---:|---:|---:|---:|"]
    for eps in ("1e-3", "1e-4", "1e-5", "1e-6"):
        eps_out, _ = run(f"twophase-benchmark-eps{eps}",
                         f"Physics/Regularization={eps}", "Output/Write VTU=false")
        eps_x0 = read_csv(os.path.join(eps_out, "x0.csv"))
        with open(os.path.join(eps_out, "summary.json")) as f:
            newton = json.load(f)["totals"]["newton_iterations"]
        _, (v0, v1) = events(eps_x0)
        lines.append(f"| {eps} | {maximum(eps_x0, 'S_g')[0]:.6f} | "
                     f"{at(eps_x0, 42500, 'P_g'):.6e} | "
                     f"{at(eps_x0, 42500, 'gas_front_m'):.1f} | "
                     f"{v0:.0f} - {v1:.0f} | {newton} |")
    write_md("twophase-regularization", lines, echo=True)

    plot(os.path.join(DATA, "twophase-benchmark-x0.csv"), profiles)
    print(f"wrote {DATA}/twophase-benchmark*.{{csv,md}}, twophase-*.png")


def startup():
    """Wall time of a run that only starts and stops (MPI, libraries)."""
    best = 1e9
    for _ in range(3):
        start = time.perf_counter()
        subprocess.run([PROGRAM, "--help"], check=True, stdout=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - start)
    return best


def plot(x0_csv, profiles):
    def block(rows, t, columns):
        return "\n".join(" ".join(str(r[c]) for c in columns)
                         for r in rows if abs(r["time_years"] - t) < 1e-6)

    dat = os.path.join(DATA, "twophase-profiles.dat")
    times = [105000, 350000]
    with open(dat, "w") as f:
        for t in times:
            f.write(block(profiles, t, ["x", "S_g", "P_l", "P_g"]) + "\n\n\n")
    estimator_dat = os.path.join(DATA, "twophase-phase-transition.dat")
    estimator_times = [2500, 12500, 42500]
    with open(estimator_dat, "w") as f:
        for t in estimator_times:
            f.write(block(profiles, t, ["x", "eta_phase_transition", "eta_flux"])
                    + "\n\n\n")

    script = f"""set terminal pngcairo size 1000,700 font ',12'
set datafile separator ','
set output '{os.path.join(DATA, "twophase-x0.png")}'
set multiplot layout 2,1 title 'step-twophase: Couplex-Gas benchmark at x = 0 (1000 cells, dt = 5000 years)'
set xlabel 'time (years)'
set format x '%.0e'
set grid
set ylabel 'gas saturation S_g'
plot '{x0_csv}' using 1:3 with lines lw 2 title 'S_g(0, t)'
set ylabel 'pressure (Pa)'
set format y '%.2e'
plot '{x0_csv}' using 1:4 with lines lw 2 title 'P_l(0, t)', \\
     '{x0_csv}' using 1:5 with lines lw 2 title 'P_g(0, t)'
unset multiplot
set datafile separator whitespace
set format y '%g'
set output '{os.path.join(DATA, "twophase-profiles.png")}'
set multiplot layout 2,1 title 'profiles at 1.05e5 and 3.5e5 years'
set xlabel 'x (m)'
set format x '%g'
set ylabel 'gas saturation S_g'
plot '{dat}' index 0 using 1:2 with lines lw 2 title 't = 1.05e5 yr', \\
     '{dat}' index 1 using 1:2 with lines lw 2 title 't = 3.5e5 yr'
set ylabel 'pressure (Pa)'
set format y '%.2e'
plot '{dat}' index 0 using 1:3 with lines lw 2 title 'P_l, 1.05e5 yr', \\
     '{dat}' index 0 using 1:4 with lines lw 2 dt 2 title 'P_g, 1.05e5 yr', \\
     '{dat}' index 1 using 1:3 with lines lw 2 title 'P_l, 3.5e5 yr', \\
     '{dat}' index 1 using 1:4 with lines lw 2 dt 2 title 'P_g, 3.5e5 yr'
unset multiplot
set terminal pngcairo size 1200,700 font ',11'
set output '{os.path.join(DATA, "twophase-phase-transition.png")}'
set multiplot layout 2,3 title 'cell indicators: phase-transition estimator (top, m yr) and flux estimator (bottom, scaled units)'
set xlabel 'x (m)'
set xrange [0:80]
set format y '%.1e'
set ylabel ''
"""
    for row, column in ((0, 2), (1, 3)):
        for index, t in enumerate(estimator_times):
            values = [r[["eta_phase_transition", "eta_flux"][row]]
                      for r in profiles if abs(r["time_years"] - t) < 1e-6]
            top = max(values)
            script += (f"set title 't = {t} years'\n"
                       + (f"set yrange [0:*]\n" if top > 0 else
                          "set yrange [0:1]\n")
                       + f"plot '{estimator_dat}' index {index} using 1:{column} "
                       f"with impulses lw 2 notitle\n")
    script += "unset multiplot\n"
    gnuplot(script)
    os.remove(dat)
    os.remove(estimator_dat)


if __name__ == "__main__":
    main()
