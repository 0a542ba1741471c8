#!/usr/bin/env python3
"""A posteriori estimators and adaptive inexact semismooth Newton
(doc/estimators.md): the published comparisons of [DMV20], run by
step-membranes, with the data and figures written to doc/data/:

  estimators-comparison.{csv,md}   exact / inexact / adaptive, p = 1 and 2
  estimators-gamma.{csv,md}        the (gamma_alg, gamma_lin) table, p = 1
  estimators-effectivity.{csv,md}  effectivity on nested meshes
  estimators-p1-iterations.png     estimator components against GMRES iterations
  estimators-p1-newton.png         ... against Newton iterations
  estimators-effectivity.png       effectivity against DoFs
  estimators-dual-norms.{csv,md}   adaptive runs with the dual norms bounded
                                   by equilibration (part dual-norms, not
                                   run by default; needs the comparison's
                                   csv for the exact runs)
  estimators-floor.{csv,md}        seed-jump Q2: the bound with a perfect
                                   flux reconstruction (part floor, not run
                                   by default; a minute)

Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/estimators_comparison.py [--quick] [comparison] [gamma] [effectivity] [dual-norms]
                                 [floor]
--quick runs coarser meshes (a smoke test of the script, not the published
setting); naming parts runs only those (default: the first three). The full
run takes 20 - 60 minutes on a 2-core machine (effectivity alone: a few,
dual-norms about 5).
"""
import csv
import math
import os
import sys

from vi_bench import DATA, ROOT, gnuplot, program, run as run_program, write_table

PROGRAM = program("membranes")
OUT = os.path.join(ROOT, "output", "bench-estimators")
QUICK = "--quick" in sys.argv


def run(scene, name, settings):
    quick = {"Mesh/Initial refinements": 3} if QUICK else {}
    summary = run_program(PROGRAM, scene,
                          {**settings, **quick, "Output/Write VTU": "false"},
                          os.path.join(OUT, name))
    print(f"  {name}: done", flush=True)
    return summary


def comparison():
    """Exact vs inexact vs adaptive on one fine mesh, p = 1 and 2."""
    rows, summaries = [], {}
    for p in (1, 2):
        for strategy in ("exact", "inexact", "adaptive"):
            # The figures need the estimates at every check of the exact
            # run for p = 1 only (they cost an estimate every 10 iterations).
            every_check = "true" if (p == 1 or strategy == "adaptive") else "false"
            s = run(f"estimators-disk-p{p}.prm", f"disk-p{p}-{strategy}",
                    {"Nonlinear solver/Strategy": strategy,
                     "Estimators/At every check": every_check})
            c = s["cycles"][-1]
            summaries[(p, strategy)] = s
            rows.append({"p": p, "strategy": strategy, "dofs_per_field": c["dofs_per_field"],
                         "newton": c["newton_iterations"], "gmres": c["linear_iterations"],
                         "error_energy": c["error_energy"], "eta": c["eta"],
                         "eta_disc": c["eta_disc"], "eta_lin": c["eta_lin"],
                         "eta_alg": c["eta_alg"], "effectivity": c["effectivity"],
                         "wall_seconds": c["wall_seconds"]})
    for row in rows:
        exact = next(r for r in rows if r["p"] == row["p"] and r["strategy"] == "exact")
        row["gmres_saving"] = exact["gmres"] / row["gmres"]
        row["error_vs_exact"] = row["error_energy"] / exact["error_energy"]
    write_table("estimators-comparison", rows,
                ["p", "strategy", "DoFs per field", "Newton", "GMRES", "GMRES saving",
                 "energy error", "error / exact", "eta", "effectivity", "wall (s)"],
                [("p", "{}"), ("strategy", "{}"), ("dofs_per_field", "{}"),
                 ("newton", "{}"), ("gmres", "{}"), ("gmres_saving", "x{:.1f}"),
                 ("error_energy", "{:.4e}"), ("error_vs_exact", "{:.5f}"),
                 ("eta", "{:.4e}"), ("effectivity", "{:.3f}"),
                 ("wall_seconds", "{:.1f}")])
    # The figures show every component at every check. The adaptive run
    # skips the fluxes of checks whose flux-free terms decide them
    # (Estimators/Defer fluxes), which leaves eta_disc unknown there: the
    # figures take a rerun with every check's fluxes, whose decisions must
    # be the same.
    s = run("estimators-disk-p1.prm", "disk-p1-adaptive-all-fluxes",
            {"Nonlinear solver/Strategy": "adaptive", "Estimators/Defer fluxes": "false"})
    default, rerun = summaries[(1, "adaptive")]["cycles"][-1], s["cycles"][-1]
    for key in ("newton_iterations", "linear_iterations", "eta", "error_energy"):
        if default[key] != rerun[key]:
            sys.exit(f"deferred fluxes changed {key}: {default[key]} against {rerun[key]}")
    summaries[(1, "adaptive-all-fluxes")] = s
    return summaries


def iteration_figures(summaries):
    """Estimator components against (cumulative) GMRES and Newton iterations."""
    series = {}
    for strategy in ("exact", "adaptive"):
        key = (1, "adaptive-all-fluxes" if strategy == "adaptive" else strategy)
        cycle = summaries[key]["cycles"][-1]
        offsets, total = {}, 0
        for step in cycle["newton_steps"]:
            offsets[step["k"]] = total
            total += step["linear_iterations"]
        inner = [(offsets[r["k"]] + r["i"], r) for r in cycle["iterations"]
                 if not r["accepted"]]
        newton = [r for r in cycle["iterations"] if r["accepted"]]
        series[strategy] = (sorted(inner, key=lambda x: x[0]), newton)

    dat = os.path.join(DATA, "estimators-p1.dat")
    with open(dat, "w") as f:
        for strategy in ("exact", "adaptive"):
            f.write(f"# {strategy}: cumulative GMRES, eta_disc, eta_lin, eta_alg\n")
            for i, r in series[strategy][0]:
                f.write(f"{i} {r['eta_disc']} {r['eta_lin']} {max(r['eta_alg'], 1e-300)}\n")
            f.write("\n\n")
        for strategy in ("exact", "adaptive"):
            f.write(f"# {strategy}: Newton step, eta_disc, eta_lin, eta_alg\n")
            for r in series[strategy][1]:
                f.write(f"{r['k']} {r['eta_disc']} {r['eta_lin']} {max(r['eta_alg'], 1e-300)}\n")
            f.write("\n\n")
    common = """set terminal pngcairo size 900,600 font ',12'
set logscale y
set format y '10^{%L}'
set key top right
set grid
"""
    gnuplot(common + f"""set output '{DATA}/estimators-p1-iterations.png'
set xlabel 'cumulative GMRES iterations'
set ylabel 'estimators'
set title 'Q1, unit disk: estimators of the iterates every 10 GMRES iterations'
plot '{dat}' index 1 using 1:2 with linespoints pt 7 ps 0.6 lc rgb '#0072b2' title 'eta_{{disc}}, adaptive', \\
     '{dat}' index 1 using 1:3 with linespoints pt 7 ps 0.6 lc rgb '#d55e00' title 'eta_{{lin}}, adaptive', \\
     '{dat}' index 1 using 1:4 with linespoints pt 7 ps 0.6 lc rgb '#009e73' title 'eta_{{alg}}, adaptive', \\
     '{dat}' index 0 using 1:2 with lines dt 2 lc rgb '#0072b2' title 'eta_{{disc}}, exact', \\
     '{dat}' index 0 using 1:3 with lines dt 2 lc rgb '#d55e00' title 'eta_{{lin}}, exact', \\
     '{dat}' index 0 using 1:4 with lines dt 2 lc rgb '#009e73' title 'eta_{{alg}}, exact'
""")
    gnuplot(common + f"""set output '{DATA}/estimators-p1-newton.png'
set xlabel 'Newton iteration'
set ylabel 'estimators of the accepted iterate'
set title 'Q1, unit disk: estimators against Newton iterations'
plot '{dat}' index 3 using 1:2 with linespoints pt 7 lc rgb '#0072b2' title 'eta_{{disc}}, adaptive', \\
     '{dat}' index 3 using 1:3 with linespoints pt 7 lc rgb '#d55e00' title 'eta_{{lin}}, adaptive', \\
     '{dat}' index 3 using 1:4 with linespoints pt 7 lc rgb '#009e73' title 'eta_{{alg}}, adaptive', \\
     '{dat}' index 2 using 1:2 with linespoints dt 2 pt 6 lc rgb '#0072b2' title 'eta_{{disc}}, exact', \\
     '{dat}' index 2 using 1:3 with linespoints dt 2 pt 6 lc rgb '#d55e00' title 'eta_{{lin}}, exact', \\
     '{dat}' index 2 using 1:4 with linespoints dt 2 pt 6 lc rgb '#009e73' title 'eta_{{alg}}, exact'
""")
    os.remove(dat)


def gamma_table():
    """The (gamma_alg, gamma_lin) table of [DMV20], p = 1."""
    rows = []
    for g_alg, g_lin in ((0.3, 0.3), (0.03, 0.3), (0.3, 0.03), (0.03, 0.03)):
        s = run("estimators-disk-p1.prm", f"gamma-{g_alg}-{g_lin}",
                {"Nonlinear solver/gamma_alg": g_alg, "Nonlinear solver/gamma_lin": g_lin,
                 "Estimators/At every check": "false"})
        c = s["cycles"][-1]
        rows.append({"gamma_alg": g_alg, "gamma_lin": g_lin,
                     "newton": c["newton_iterations"], "gmres": c["linear_iterations"],
                     "error_energy": c["error_energy"], "effectivity": c["effectivity"]})
    write_table("estimators-gamma", rows,
                ["gamma_alg", "gamma_lin", "Newton", "GMRES", "energy error", "effectivity"],
                [("gamma_alg", "{}"), ("gamma_lin", "{}"), ("newton", "{}"),
                 ("gmres", "{}"), ("error_energy", "{:.4e}"), ("effectivity", "{:.3f}")])


def effectivity_on_nested_meshes():
    """Effectivity against the mesh: exact (direct) and adaptive (GMRES),
    the latter with the published gamma_lin = 0.3 and with 0.1 (the bound
    keeps up to gamma_lin eta_disc of linearisation error)."""
    runs = [("seed-smooth", 1, "exact"), ("seed-smooth", 2, "exact"),
            ("seed-smooth", 3, "exact"), ("seed-jump", 1, "exact"),
            ("seed-jump", 2, "exact"), ("seed-smooth", 1, "adaptive"),
            ("seed-smooth", 2, "adaptive"),
            ("seed-smooth", 1, "adaptive, gamma_lin 0.1"),
            ("seed-smooth", 2, "adaptive, gamma_lin 0.1"),
            ("seed-smooth", 1, "adaptive, sharpened"),
            ("seed-smooth", 2, "adaptive, sharpened")]
    rows = []
    for test, p, strategy in runs:
        settings = {"Discretization/Polynomial degree": p,
                    "Mesh/Cycles": 5 if p < 3 else 4,
                    "Nonlinear solver/Strategy": strategy.split(",")[0],
                    "Estimators/At every check": "false"}
        if strategy.startswith("adaptive"):
            settings["Linear solver/Solver"] = "gmres"
        if "gamma_lin" in strategy:
            settings["Nonlinear solver/gamma_lin"] = strategy.split()[-1]
        if "sharpened" in strategy:
            settings["Estimators/Sharpen final estimate"] = "true"
        if QUICK:
            settings["Mesh/Cycles"] = 3
        name = "-".join([test, f"p{p}"] + strategy.replace(",", "").split())
        s = run(f"membranes-{test}.prm", f"effectivity-{name}", settings)
        for c in s["cycles"]:
            rows.append({"test": test, "p": p, "strategy": strategy,
                         "cycle": c["cycle"], "dofs_per_field": c["dofs_per_field"],
                         "error_energy": c["error_energy"], "eta": c["eta"],
                         "effectivity": c["effectivity"]})
    write_table("estimators-effectivity", rows,
                ["test", "p", "strategy", "cycle", "DoFs per field", "energy error", "eta",
                 "effectivity"],
                [("test", "{}"), ("p", "{}"), ("strategy", "{}"), ("cycle", "{}"),
                 ("dofs_per_field", "{}"), ("error_energy", "{:.4e}"), ("eta", "{:.4e}"),
                 ("effectivity", "{:.3f}")])
    dat = os.path.join(DATA, "estimators-effectivity.dat")
    with open(dat, "w") as f:
        for test, p, strategy in runs:
            f.write(f"# {test} p={p} {strategy}\n")
            for r in rows:
                if (r["test"], r["p"], r["strategy"]) == (test, p, strategy):
                    f.write(f"{r['dofs_per_field']} {r['effectivity']}\n")
            f.write("\n\n")
    def style(n, p, strategy):
        # the gamma_lin = 0.1 runs dashed and the sharpened ones dotted, in
        # the colour family of their p
        if "gamma" in strategy:
            return f"lw 2 pt {n + 4} dt 2 lc rgb '{'#444444' if p == 1 else '#cc0000'}'"
        if "sharpened" in strategy:
            return f"lw 2 pt {n + 4} dt 3 lc rgb '{'#0072b2' if p == 1 else '#e69f00'}'"
        return f"lw 2 pt {n + 4}"
    plots = [f"'{dat}' index {n} with linespoints {style(n, p, s)} "
             f"title '{t}, Q{p}, {s.replace('gamma_lin', '{/Symbol g}_{lin}')}'"
             for n, (t, p, s) in enumerate(runs)]
    gnuplot(f"""set terminal pngcairo size 900,600 font ',12'
set output '{DATA}/estimators-effectivity.png'
set logscale x
set xlabel 'DoFs per field'
set ylabel 'effectivity eta / |||u - u_h|||'
set title 'Effectivity of the guaranteed bound (uniform refinement)'
set yrange [0.9:*]
set arrow from graph 0, first 1 to graph 1, first 1 nohead dt 2 lc rgb 'black'
set key top right
set grid
plot {', '.join(plots)}
""")
    os.remove(dat)


def dual_norms():
    """The adaptive runs of the comparison with the undershoots and / or
    the algebraic remainder bounded in the dual norm by equilibration
    (Estimators/Equilibrated dual norms), against the exact runs of
    estimators-comparison.csv (the option does not change exact Newton)."""
    with open(os.path.join(DATA, "estimators-comparison.csv")) as f:
        exact = {int(r["p"]): r for r in csv.DictReader(f) if r["strategy"] == "exact"}
    choices = {1: ("", "undershoots", "remainder", "undershoots,remainder"),
               2: ("", "remainder", "undershoots,remainder")}
    rows = []
    for p, terms in choices.items():
        for choice in terms:
            name = f"dual-norms-p{p}-" + (choice.replace(",", "-") or "none")
            s = run(f"estimators-disk-p{p}.prm", name,
                    {"Nonlinear solver/Strategy": "adaptive",
                     "Estimators/Equilibrated dual norms": choice})
            c = s["cycles"][-1]
            rows.append({"p": p, "equilibrated": choice.replace(",", " + ") or "none",
                         "newton": c["newton_iterations"], "gmres": c["linear_iterations"],
                         "gmres_saving": float(exact[p]["gmres"]) / c["linear_iterations"],
                         "error_energy": c["error_energy"],
                         "error_vs_exact": c["error_energy"] / float(exact[p]["error_energy"]),
                         "lin_over_disc": c["eta_lin"] / c["eta_disc"],
                         "alg_over_disc": c["eta_alg"] / c["eta_disc"],
                         "effectivity": c["effectivity"], "wall_seconds": c["wall_seconds"]})
    write_table("estimators-dual-norms", rows,
                ["p", "dual norms by equilibration", "Newton", "GMRES", "saving vs exact",
                 "error / exact", "eta_lin / eta_disc", "eta_alg / eta_disc",
                 "effectivity", "wall (s)"],
                [("p", "{}"), ("equilibrated", "{}"), ("newton", "{}"), ("gmres", "{}"),
                 ("gmres_saving", "x{:.1f}"), ("error_vs_exact", "{:.4f}"),
                 ("lin_over_disc", "{:.3f}"), ("alg_over_disc", "{:.3f}"),
                 ("effectivity", "{:.3f}"), ("wall_seconds", "{:.1f}")])


def bound(eta_1, nonc_1, nonc_2, contact_cone, dirichlet):
    """The guaranteed bound from its parts (doc/estimators.md, "The
    guaranteed bound"; VI::estimate_contact_error in common/source/estimators.cc):
    the smaller of a/2 + (a^2/4 + b)^(1/2) and (R^2 + N^2 + eta_cone)^(1/2),
    plus |||G|||, with R = eta_1 + eta_nonc2, N = eta_nonc1, a = R + N and
    b = R N + eta_cone / 2."""
    R = eta_1 + nonc_2
    a = R + nonc_1
    b = R * nonc_1 + 0.5 * contact_cone
    additive = 0.5 * a + math.sqrt(max(0.25 * a * a + b, 0.))
    quadratic = math.sqrt(max(R * R + nonc_1 * nonc_1 + contact_cone, 0.))
    return min(additive, quadratic) + dirichlet


def floor():
    """What keeps the seed-jump Q2 effectivity above 1.5 on the unfitted
    mesh: the bound of each mesh's exact discrete solution recomputed from
    its parts with the flux and residual part eta_1 replaced by the energy
    error (what a perfect flux reconstruction would give at best), then
    also without the contact and multiplier terms, so that only the
    non-conformity eta_nonc1 = |||s~ - u_h||| is left; the same on the
    mesh fitted to the free boundary."""
    cases = (("unfitted", "membranes-seed-jump.prm",
              {"Discretization/Polynomial degree": 2, "Mesh/Cycles": 6}),
             ("fitted", "membranes-seed-jump-fitted.prm", {"Mesh/Cycles": 6}))
    rows = []
    for mesh, scene, settings in cases:
        if QUICK:
            settings = {**settings, "Mesh/Cycles": 3}
        s = run(scene, f"floor-{mesh}", settings)
        for c in s["cycles"]:
            e, error = c["estimate"], c["error_energy"]
            parts = (e["nonc_1"], e["nonc_2"], e["contact_cone"], e["dirichlet"])
            # The formula must be the program's: it gives back its eta.
            if abs(bound(e["eta_1"], *parts) - c["eta"]) > 1e-9 * c["eta"]:
                sys.exit(f"floor: the bound from the parts of {mesh} cycle {c['cycle']} "
                         f"is not the program's eta {c['eta']}")
            rows.append({"mesh": mesh, "cycle": c["cycle"], "cells": c["cells"],
                         "dofs_per_field": c["dofs_per_field"], "error_energy": error,
                         "effectivity": c["effectivity"],
                         "eta_1_over_error": e["eta_1"] / error,
                         "nonc_1_over_error": e["nonc_1"] / error,
                         "nonc_2_over_error": e["nonc_2"] / error,
                         "contact_over_error": math.sqrt(max(e["contact_cone"], 0.) / 2) / error,
                         "dirichlet_over_error": e["dirichlet"] / error,
                         "perfect_fluxes": bound(error, *parts) / error,
                         "nonconformity_only": bound(error, e["nonc_1"], 0., 0., 0.) / error})
    write_table("estimators-floor", rows,
                ["mesh", "cycle", "cells", "DoFs per field", "energy error", "effectivity",
                 "eta_1 / error", "eta_nonc1 / error", "eta_nonc2 / error",
                 "(eta_cone / 2)^(1/2) / error", "|||G||| / error",
                 "bound / error with eta_1 = error", "... and only eta_nonc1 besides"],
                [("mesh", "{}"), ("cycle", "{}"), ("cells", "{}"), ("dofs_per_field", "{}"),
                 ("error_energy", "{:.4e}"), ("effectivity", "{:.3f}"),
                 ("eta_1_over_error", "{:.2f}"), ("nonc_1_over_error", "{:.3f}"),
                 ("nonc_2_over_error", "{:.3f}"), ("contact_over_error", "{:.3f}"),
                 ("dirichlet_over_error", "{:.3f}"), ("perfect_fluxes", "{:.3f}"),
                 ("nonconformity_only", "{:.3f}")])


def main():
    os.makedirs(DATA, exist_ok=True)
    # The parts of the study, in the order they run: what each prints, and
    # what it does.
    known = {"comparison": ("comparison of the strategies",
                            lambda: iteration_figures(comparison())),
             "gamma": ("(gamma_alg, gamma_lin) table", gamma_table),
             "effectivity": ("effectivity on nested meshes", effectivity_on_nested_meshes),
             "dual-norms": ("dual norms by equilibration", dual_norms),
             "floor": ("seed-jump Q2: the bound with perfect fluxes", floor)}
    parts = [a for a in sys.argv[1:] if not a.startswith("--")] or \
        ["comparison", "gamma", "effectivity"]
    for part in parts:
        if part not in known:
            sys.exit(f"estimators_comparison.py: unknown part '{part}' "
                     "(comparison, gamma, effectivity, dual-norms or floor)")
    for part, (message, study) in known.items():
        if part in parts:
            print(message, flush=True)
            study()
    print(f"wrote {DATA}/estimators-*")


if __name__ == "__main__":
    main()
