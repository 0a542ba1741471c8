#!/usr/bin/env python3
"""Semismooth Newton from a cold start, against the mesh (doc/stress.md,
"Cold starts").

Each scene is solved on one mesh, without nested iteration, from the zero
initial guess and from the data's (boundary data inside the domain), with
Newton-min and Fischer-Burmeister, the exact strategy (MUMPS) and no
estimators: the count of Newton steps is the algorithm's alone. Each case
runs twice: plain semismooth Newton (Nonlinear solver/Continuation =
false, at most 50 steps) and with the continuation that takes over where
the active set stalls (doc/reference.md, "Continuation"); the table gives
the step after which it started. With Newton-min, PETSc's SNES VI
(SNESVINEWTONRSLS with MUMPS) solves the same discrete problem from the same
iterate in the run with the continuation (Benchmark/Compare with PETSc VI).

  seed-smooth  parameters/membranes-seed-smooth.prm, Q1 on the square
  disk         parameters/membranes-disk.prm, Q1
  L-shape      parameters/membranes-l-shape.prm, Q1

Meshes of about 3e3 to 6.6e4 unknowns per field (--fine adds 2.6e5 for
seed-smooth: a quarter of an hour more); about 25 minutes on two cores.
--method sipg solves the same scenes with SIPG Q1 (step-membranes), --method
hho with HHO of degree 1 (step-hho, direct solves of the condensed face
system, from zero only); neither has the PETSc peer. Writes doc/data/cold_start.{csv,md}
(fem) or doc/data/cold_start_<method>.{csv,md}, with the suffix _smoothing
for --continuation-method=smoothing. Usage, from the repository
root after ./demo.sh or ./test.sh:
  bench/cold_start.py [--method fem|sipg|hho] [--fine] [--reuse]
                      [--continuation-method=smoothing]
--reuse takes the runs whose summary.json the last run left in
output/bench-cold-start[-<method>].
STEP_MEMBRANES and STEP_HHO name other binaries.
"""
import os
import sys

from vi_bench import (CONTINUATION_SUFFIX, ROOT, cold_start_settings, program,
                      run_kept, write_table)

METHOD = (sys.argv[sys.argv.index("--method") + 1]
          if "--method" in sys.argv else "fem")
PROGRAM = program("hho" if METHOD == "hho" else "membranes")
SUFFIX = ("" if METHOD == "fem" else "_" + METHOD) + CONTINUATION_SUFFIX
OUT = os.path.join(ROOT, "output", "bench-cold-start" + SUFFIX.replace("_", "-"))
FINE = "--fine" in sys.argv
REUSE = "--reuse" in sys.argv

# (scene, parameter file, initial refinements of the meshes)
SCENES = [("seed-smooth", "membranes-seed-smooth.prm", [6, 7, 8]),
          ("disk", "membranes-disk.prm", [4, 5, 6]),
          ("L-shape", "membranes-l-shape.prm", [5, 6, 7])]
if FINE:
    SCENES[0][2].append(9)
# (the broken and hybrid spaces have about four times the unknowns of Q1 on
# a mesh: one refinement less)
if METHOD != "fem":
    SCENES = [(scene, prm, [r - 1 for r in meshes])
              for scene, prm, meshes in SCENES]


def solve(scene, prm, refinements, guess, c_function, continuation):
    """One run's summary (also of a failed run)."""
    directory = os.path.join(
        OUT, f"{scene}-{refinements}-{guess}-{c_function}-{continuation}")
    settings = cold_start_settings(refinements, guess, c_function)
    settings.update({"Nonlinear solver/Strategy": "exact",
                     "Nonlinear solver/Continuation": continuation,
                     "Linear solver/Solver": "direct"})
    if METHOD != "hho":
        settings["Discretization/Method"] = METHOD
        settings["Estimators/Enabled"] = "false"
        settings["Benchmark/Compare with PETSc VI"] = (
            "true" if METHOD == "fem" and c_function == "min"
            and continuation == "true" else "false")
    return run_kept(PROGRAM, prm, settings, directory, reuse=REUSE)


def steps(summary):
    """Newton steps of the run, or "failed"."""
    if summary.get("status") != "converged" or not summary.get("cycles"):
        return "failed"
    return summary["cycles"][0]["newton_iterations"]


def row(scene, guess, c_function, plain, summary):
    """The table's row of a case: the plain run and the one with the
    continuation."""
    if steps(summary) == "failed":
        return {"scene": scene, "guess": guess, "c_function": c_function,
                "dofs_per_field": "", "plain": steps(plain), "newton": "failed",
                "continuation_from": "", "seconds": "",
                "petsc_newton": "", "petsc_seconds": ""}
    c = summary["cycles"][0]
    smoothed = [s["k"] for s in c.get("newton_steps", []) if "smoothing" in s]
    peer = c.get("petsc_vi", {})
    return {"scene": scene, "guess": guess, "c_function": c_function,
            # (step-hho reports all its unknowns)
            "dofs_per_field": c.get("dofs_per_field", c.get("dofs")),
            "plain": steps(plain),
            "newton": c["newton_iterations"],
            # the continuation starts after the last plain step
            "continuation_from": smoothed[0] - 1 if smoothed else "",
            "seconds": round(c.get("solve_seconds", c["wall_seconds"]), 2),
            "petsc_newton": peer.get("newton_iterations",
                                     "failed" if peer else ""),
            "petsc_seconds": round(peer["seconds"], 2) if "seconds" in peer else ""}


rows = []
for scene, prm, meshes in SCENES:
    for refinements in meshes:
        # (step-hho starts from zero only)
        for guess in ["zero"] if METHOD == "hho" else ["zero", "data"]:
            for c_function in ["min", "fischer-burmeister"]:
                plain = solve(scene, prm, refinements, guess, c_function, "false")
                summary = solve(scene, prm, refinements, guess, c_function, "true")
                rows.append(row(scene, guess, c_function, plain, summary))
                r = rows[-1]
                print(f"{scene:12s} {r['dofs_per_field']!s:>7s} unknowns/field, "
                      f"{guess:4s} start, {c_function:18s}: plain {r['plain']}, "
                      f"{r['newton']} steps"
                      + (f" (continuation after {r['continuation_from']})"
                         if r["continuation_from"] != "" else "")
                      + (f", PETSc RSLS {r['petsc_newton']}" if r["petsc_newton"] != "" else ""),
                      flush=True)

write_table("cold_start" + SUFFIX, rows,
            ["scene", "start", "C-function",
             "unknowns" if METHOD == "hho" else "unknowns per field",
             "plain Newton",
             "with continuation", "continuation after step", "seconds",
             "PETSc RSLS steps", "PETSc seconds"],
            [("scene", "{}"), ("guess", "{}"), ("c_function", "{}"),
             ("dofs_per_field", "{}"), ("plain", "{}"), ("newton", "{}"),
             ("continuation_from", "{}"),
             ("seconds", "{}"), ("petsc_newton", "{}"), ("petsc_seconds", "{}")])
print(f"wrote doc/data/cold_start{SUFFIX}.{{csv,md}}")
