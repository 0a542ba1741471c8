#!/usr/bin/env python3
"""The effectivity of the estimate against the tension ratio (doc/stress.md,
"Tension ratio").

seed-jump (data built for the tensions: u1 = s^2 outside the contact disk,
u2 = 0) and seed-smooth, mu2 = 1 and mu1 = 1e-6 ... 1e6, Q1 on 4 x 4 to
128 x 128 cells and Q2 on 4 x 4 to 64 x 64, exact strategy, each with the
multiplier of the estimate without the transmitted load (Estimators/
Transmitted load = never, the estimate of equal tensions) and with it
(always; 'auto' takes it for the stopping tests when the tensions are more
than 10 times apart). The final estimates of the conforming method are
sharpened (Estimators/Sharpen final estimate): both dual norms bounded by
equilibration where that is smaller, and with 'auto' both multipliers, so
fem also runs 'auto'. About 30 minutes on two cores for fem, 10 for sipg.
Writes doc/data/tension_scan.{csv,md} (fem) or
doc/data/tension_scan_<method>.{csv,md}. Usage, from the repository root
after ./demo.sh or ./test.sh:
  bench/tension_scan.py [--method fem|sipg|nipg|iipg] [--reuse]
--reuse takes the runs whose summary.json the last run left in
output/bench-tension-scan[-<method>]. STEP_MEMBRANES names another binary.
"""
import json
import os
import sys

from vi_bench import ROOT, program, run, write_table

PROGRAM = program("membranes")
METHOD = (sys.argv[sys.argv.index("--method") + 1]
          if "--method" in sys.argv else "fem")
SUFFIX = "" if METHOD == "fem" else "_" + METHOD
OUT = os.path.join(ROOT, "output", "bench-tension-scan" + SUFFIX.replace("_", "-"))
PRM = os.path.join(ROOT, "tests", "stress", "membranes", "tension-ratio-1e-6.prm")
REUSE = "--reuse" in sys.argv

RATIOS = ["1e-6", "1e-4", "1e-2", "1", "1e2", "1e6"]
# (with sharpening, auto's final estimates are the smaller of the two)
LOADS = ["never", "always"] + (["auto"] if METHOD == "fem" else [])
# degree -> cycles from 4 x 4 cells
CYCLES = {1: 6, 2: 5}


def solve(test, degree, mu1, load):
    """The summary of one run."""
    directory = os.path.join(OUT, f"{test}-p{degree}-{mu1}-{load}")
    settings = {"Problem/Test case": test,
                "Problem/mu1": mu1,
                "Problem/mu2": 1,
                "Mesh/Initial refinements": 2,
                "Mesh/Cycles": CYCLES[degree],
                "Discretization/Polynomial degree": degree,
                "Discretization/Method": METHOD,
                "Estimators/Transmitted load": load,
                "Estimators/Sharpen final estimate":
                    "true" if METHOD == "fem" else "false",
                "Output/Write VTU": "false"}
    if not (REUSE and os.path.exists(os.path.join(directory, "summary.json"))):
        run(PROGRAM, PRM, settings, directory)
    with open(os.path.join(directory, "summary.json")) as f:
        return json.load(f)


def effectivities(summary):
    return [c["eta"] / c["error_energy"] for c in summary["cycles"]]


rows = []
for test in ["seed-jump", "seed-smooth"]:
    for degree in [1, 2]:
        for mu1 in RATIOS:
            ratio = float(mu1)
            for load in LOADS:
                summary = solve(test, degree, mu1, load)
                values = effectivities(summary)
                auto = "always" if max(ratio, 1) > 10 * min(ratio, 1) else "never"
                rows.append({
                    "test": test, "p": degree, "ratio": mu1,
                    "transmitted_load": {"always": "yes", "never": "no",
                                         "auto": "auto"}[load],
                    "auto": "yes" if auto == load else "",
                    "dofs": " / ".join(str(c["dofs_per_field"])
                                       for c in summary["cycles"]),
                    "effectivity": " / ".join(f"{e:.3g}" for e in values),
                    "finest": f"{values[-1]:.3f}",
                    "worst_from_16": f"{max(values[2:]):.3f}"})
                print(f"{test:11s} p={degree} mu1/mu2={mu1:5s} "
                      f"transmitted load {load:6s}: "
                      + ", ".join(f"{e:.3g}" for e in values), flush=True)

write_table("tension_scan" + SUFFIX, rows,
            ["test", "p", "mu1 / mu2", "transmitted load",
             "auto's choice for the stopping tests",
             "unknowns per field", "effectivity, coarsest to finest",
             "finest", "largest from 16 x 16 cells"],
            [("test", "{}"), ("p", "{}"), ("ratio", "{}"),
             ("transmitted_load", "{}"), ("auto", "{}"), ("dofs", "{}"),
             ("effectivity", "{}"), ("finest", "{}"),
             ("worst_from_16", "{}")])
print(f"wrote doc/data/tension_scan{SUFFIX}.{{csv,md}}")
