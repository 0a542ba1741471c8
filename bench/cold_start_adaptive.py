#!/usr/bin/env python3
"""The adaptive strategy from a cold start, against the mesh (doc/stress.md,
"Cold starts with the adaptive strategy").

Each scene is solved on one mesh, without nested iteration, from the zero
initial guess and from the data's, with Newton-min and Fischer-Burmeister and
the settings a user gets with `Nonlinear solver/Strategy = adaptive` and
`Linear solver/Solver = gmres`: GMRES with ILU (the default preconditioner),
both stopped by the estimators (Newton when eta_lin <= gamma_lin eta_disc,
GMRES when eta_alg is small against both), the continuation where the active
set stalls or cycles. The energy error of
the run from zero beside the one from the data shows that the cold start
stops as close to the discrete solution as the warm one.

  seed-smooth  parameters/membranes-seed-smooth.prm, Q1 on the square
  disk         parameters/membranes-disk.prm, Q1
  L-shape      parameters/membranes-l-shape.prm, Q1

Meshes from about 3e3 to 2.6e5 unknowns per field; about 25 minutes on two
cores. Writes
doc/data/cold_start_adaptive.{csv,md}. Usage, from the repository root
after ./demo.sh or ./test.sh:
  bench/cold_start_adaptive.py [--amg] [--reuse]
                               [--continuation-method=smoothing]
--amg preconditions GMRES with the contact AMG instead of ILU and writes
doc/data/cold_start_adaptive_amg.{csv,md}; --reuse takes the runs whose
summary.json the last run left in output/bench-cold-start-adaptive[-amg].
STEP_MEMBRANES names another binary.
"""
import os
import sys

from vi_bench import (CONTINUATION_SUFFIX, ROOT, cold_start_settings, program,
                      run_kept, write_table)

PROGRAM = program("membranes")
AMG = "--amg" in sys.argv
NAME = "cold_start_adaptive" + ("_amg" if AMG else "") + CONTINUATION_SUFFIX
OUT = os.path.join(ROOT, "output", "bench-" + NAME.replace("_", "-"))
REUSE = "--reuse" in sys.argv

# (scene, parameter file, initial refinements of the meshes)
SCENES = [("seed-smooth", "membranes-seed-smooth.prm", [6, 7, 9]),
          ("disk", "membranes-disk.prm", [4, 5, 7]),
          ("L-shape", "membranes-l-shape.prm", [5, 6, 8])]


def solve(scene, prm, refinements, guess, c_function):
    """One run's summary (also of a failed run)."""
    directory = os.path.join(
        OUT, f"{scene}-{refinements}-{guess}-{c_function}")
    settings = cold_start_settings(refinements, guess, c_function)
    settings.update({"Nonlinear solver/Strategy": "adaptive",
                     "Linear solver/Solver": "gmres",
                     "Linear solver/Preconditioner": "amg" if AMG else "ilu",
                     "Estimators/Enabled": "true"})
    return run_kept(PROGRAM, prm, settings, directory, reuse=REUSE)


def row(scene, guess, c_function, summary):
    """The table's row of a case."""
    failed = summary.get("status") != "converged" or not summary.get("cycles")
    if failed:
        return {"scene": scene, "guess": guess, "c_function": c_function,
                "dofs_per_field": "", "newton": "failed",
                "continuation_from": "", "linear": "", "error": float("nan"),
                "eta": float("nan"), "effectivity": float("nan"), "seconds": ""}
    c = summary["cycles"][0]
    smoothed = [s["k"] for s in c.get("newton_steps", []) if "smoothing" in s]
    return {"scene": scene, "guess": guess, "c_function": c_function,
            "dofs_per_field": c["dofs_per_field"],
            "newton": c["newton_iterations"],
            # the continuation starts after the last plain step
            "continuation_from": smoothed[0] - 1 if smoothed else "",
            "linear": c["linear_iterations"],
            "error": c["error_energy"], "eta": c["eta"],
            "effectivity": c["effectivity"],
            "seconds": round(c["solve_seconds"], 1)}


rows = []
for scene, prm, meshes in SCENES:
    for refinements in meshes:
        for guess in ["zero", "data"]:
            for c_function in ["min", "fischer-burmeister"]:
                rows.append(row(scene, guess, c_function,
                                solve(scene, prm, refinements, guess,
                                      c_function)))
                r = rows[-1]
                print(f"{scene:12s} {r['dofs_per_field']!s:>8s} unknowns/field, "
                      f"{guess:4s} start, {c_function:18s}: {r['newton']} "
                      f"Newton steps, {r['linear']} GMRES, error {r['error']}",
                      flush=True)

write_table(NAME, rows,
            ["scene", "start", "C-function", "unknowns per field",
             "Newton steps", "continuation after step", "GMRES iterations",
             "energy error", "eta", "effectivity", "seconds"],
            [("scene", "{}"), ("guess", "{}"), ("c_function", "{}"),
             ("dofs_per_field", "{}"), ("newton", "{}"),
             ("continuation_from", "{}"), ("linear", "{}"),
             ("error", "{:.3e}"), ("eta", "{:.3e}"), ("effectivity", "{:.2f}"),
             ("seconds", "{}")])
print(f"wrote doc/data/{NAME}.{{csv,md}}")
