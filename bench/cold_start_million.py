#!/usr/bin/env python3
"""Cold starts on meshes of about 1e6 unknowns per field (doc/stress.md,
"Cold starts": the target of at most 25 Newton steps from zero up to 1e6
unknowns per field, for every method).

Each scene is solved once per method and C-function on its mesh of about
1e6 unknowns per field, without nested iteration, from the zero initial
guess, with the continuation (the default):

  fem       step-membranes, Q1, exact Newton, GMRES + contact AMG to the
            exact tolerance (the step counts of MUMPS), no estimators
  sipg      the same with SIPG Q1 (four unknowns per cell and field)
  hho       step-hho, cells P1 / faces P0, LU of the condensed face system;
            also one refinement after bench/cold_start.py --method hho
  adaptive  step-membranes, Q1, the adaptive strategy with the contact AMG
            and the estimators that stop it
  inexact   step-membranes, Q1, the inexact strategy (GMRES + contact AMG
            to the forcing term), no estimators

  seed-smooth  parameters/membranes-seed-smooth.prm
  disk         parameters/membranes-disk.prm (its Q2 scene in Q1)
  L-shape      parameters/membranes-l-shape.prm

Two runs at a time, one thread each: about an hour on two cores, up to
5 GB per run. Writes doc/data/cold_start_million.{csv,md}. Usage, from the
repository root after ./demo.sh or ./test.sh:
  bench/cold_start_million.py [--methods=fem,sipg,hho,adaptive,inexact] [--reuse]
--reuse takes the runs whose summary.json the last run left in
output/bench-cold-start-million. STEP_MEMBRANES and STEP_HHO name other
binaries.
"""
import os
import sys
from concurrent.futures import ThreadPoolExecutor

from vi_bench import ROOT, cold_start_settings, option, program, run_kept, write_table

OUT = os.path.join(ROOT, "output", "bench-cold-start-million")
REUSE = "--reuse" in sys.argv
METHODS = option("methods", "fem,sipg,hho,adaptive,inexact").split(",")

# (scene, parameter file, refinements of its Q1 mesh of about 1e6
# unknowns per field)
SCENES = [("seed-smooth", "membranes-seed-smooth.prm", 10),
          ("disk", "membranes-disk.prm", 8),
          ("L-shape", "membranes-l-shape.prm", 9)]
# Newton's strategy of each method (HHO: LU of the condensed face system)
STRATEGY = {"fem": "exact", "sipg": "exact", "hho": "exact",
            "adaptive": "adaptive", "inexact": "inexact"}


def meshes(method, q1_refinements):
    """The method's refinements: SIPG one less than Q1 (four unknowns per
    cell and field), HHO also one more before it (its table in
    bench/cold_start.py ends one refinement below)."""
    if method == "sipg":
        return [q1_refinements - 1]
    if method == "hho":
        return [q1_refinements - 2, q1_refinements - 1]
    return [q1_refinements]


def settings(method, refinements, c_function):
    """The run's --set overrides."""
    s = cold_start_settings(refinements, "zero", c_function)
    s["Nonlinear solver/Strategy"] = STRATEGY[method]
    if method == "hho":
        s["Linear solver/Solver"] = "direct"
        return s
    s.update({"Linear solver/Solver": "gmres",
              "Linear solver/Preconditioner": "amg",
              "Estimators/Enabled": str(method == "adaptive").lower()})
    if method in ("fem", "sipg"):
        s["Discretization/Method"] = method
    return s


def solve(case):
    """One run's summary (also of a failed run)."""
    method, scene, prm, refinements, c_function = case
    directory = os.path.join(OUT, f"{method}-{scene}-{refinements}-{c_function}")
    return run_kept(program("hho" if method == "hho" else "membranes"), prm,
                    settings(method, refinements, c_function), directory,
                    reuse=REUSE, threads=1)


def row(case, summary):
    """The table's row of a run."""
    method, scene, _, _, c_function = case
    r = {"method": method, "scene": scene, "c_function": c_function}
    if summary.get("status") != "converged" or not summary.get("cycles"):
        return {**r, "newton": "failed"}
    c = summary["cycles"][0]
    smoothed = [s["k"] for s in c.get("newton_steps", []) if "smoothing" in s]
    # (step-hho counts both membranes and the multiplier: a membrane has
    # the cell unknowns of one field and the faces of one)
    per_field = c.get("dofs_per_field",
                      c.get("dofs_cell", 0) // 3 + c.get("dofs_condensed", 0) // 2)
    return {**r, "cells": c["cells"], "dofs_per_field": per_field,
            "newton": c["newton_iterations"],
            "continuation_from": smoothed[0] - 1 if smoothed else "",
            "gmres": c["linear_iterations"] if method != "hho" else "",
            "error_energy": c["error_energy"],
            "effectivity": c.get("effectivity", float("nan")),
            "seconds": round(c["wall_seconds"], 1)}


cases = [(method, scene, prm, refinements, c_function)
         for method in METHODS
         for scene, prm, q1_refinements in SCENES
         for refinements in meshes(method, q1_refinements)
         for c_function in ["min", "fischer-burmeister"]]


def report(case):
    r = row(case, solve(case))
    print(f"{r['method']:8s} {r['scene']:12s} {r.get('dofs_per_field', '')!s:>8s} "
          f"unknowns/field, {r['c_function']:18s}: {r['newton']} steps"
          + (f" (continuation after {r['continuation_from']})"
             if r.get("continuation_from", "") != "" else ""), flush=True)
    return r


with ThreadPoolExecutor(max_workers=2) as pool:
    rows = list(pool.map(report, cases))

write_table("cold_start_million", rows,
            ["method", "scene", "C-function", "cells", "unknowns per field",
             "Newton steps", "continuation after step", "GMRES iterations",
             "energy error", "effectivity", "seconds"],
            [("method", "{}"), ("scene", "{}"), ("c_function", "{}"),
             ("cells", "{}"), ("dofs_per_field", "{}"), ("newton", "{}"),
             ("continuation_from", "{}"), ("gmres", "{}"),
             ("error_energy", "{:.3e}"), ("effectivity", "{:.2f}"),
             ("seconds", "{}")])
print("wrote doc/data/cold_start_million.{csv,md}")
