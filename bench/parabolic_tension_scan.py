#!/usr/bin/env python3
"""The effectivity of step-parabolic's estimate against the tension ratio
(doc/stress.md, "Tension ratio").

The seed-jump solution built for the tensions (u1 = s^2 outside the contact
disk r <= 1/3, u2 = 0) is the initial value and so the exact solution at
all times (tests/stress/parabolic/tension-ratio-1e-6.prm): mu2 = 1, mu1 =
1e-6 ... 1e6, Q1 and Q2 on the disk with 768, 3072 and 12288 cells, two
steps of dt = 0.1, exact strategy, each without the transmitted load
(Estimators/Transmitted load = never) and with it (always; 'auto' takes it
when the tensions are more than 10 times apart, and for p >= 2). The
effectivity is that of the whole run (eta / error at t = 0.2). About 5
minutes on two cores.
Writes doc/data/parabolic_tension_scan.{csv,md}. Usage, from the
repository root after ./demo.sh or ./test.sh:
  bench/parabolic_tension_scan.py [--reuse]
--reuse takes the runs whose summary.json the last run left in
output/bench-parabolic-tension-scan. STEP_PARABOLIC names another binary.
"""
import json
import os
import sys

from vi_bench import ROOT, program, run, write_table

PROGRAM = program("parabolic")
OUT = os.path.join(ROOT, "output", "bench-parabolic-tension-scan")
PRM = os.path.join(ROOT, "tests", "stress", "parabolic",
                   "tension-ratio-1e-6.prm")
REUSE = "--reuse" in sys.argv

RATIOS = ["1e-6", "1e-4", "1e-2", "1", "1e2", "1e6"]
REFINEMENTS = [3, 4, 5]


def solve(degree, mu1, load, refinements):
    """The summary of one run."""
    directory = os.path.join(OUT, f"p{degree}-{mu1}-{load}-{refinements}")
    settings = {"Problem/mu1": mu1,
                "Problem/mu2": 1,
                "Problem/Expression/Constants":
                    f"R=0.3333333333333333, m={mu1}",
                "Mesh/Initial refinements": refinements,
                "Discretization/Polynomial degree": degree,
                "Estimators/Transmitted load": load}
    if not (REUSE and os.path.exists(os.path.join(directory, "summary.json"))):
        run(PROGRAM, PRM, settings, directory)
    with open(os.path.join(directory, "summary.json")) as f:
        return json.load(f)


rows = []
for degree in [1, 2]:
    for mu1 in RATIOS:
        ratio = float(mu1)
        for load in ["never", "always"]:
            summaries = [solve(degree, mu1, load, r) for r in REFINEMENTS]
            values = [s["totals"]["effectivity"] for s in summaries]
            auto = ("always" if max(ratio, 1) > 10 * min(ratio, 1) or degree >= 2
                    else "never")
            rows.append({
                "p": degree, "ratio": mu1,
                "transmitted_load": "yes" if load == "always" else "no",
                "auto": "yes" if auto == load else "",
                "dofs": " / ".join(str(s["mesh"]["dofs_per_field"])
                                   for s in summaries),
                "effectivity": " / ".join(f"{e:.3g}" for e in values),
                "finest": f"{values[-1]:.3f}"})
            print(f"p={degree} mu1/mu2={mu1:5s} transmitted load {load:6s}: "
                  + ", ".join(f"{e:.3g}" for e in values), flush=True)

write_table("parabolic_tension_scan", rows,
            ["p", "mu1 / mu2", "transmitted load", "auto's choice",
             "unknowns per field", "effectivity, coarsest to finest",
             "finest"],
            [("p", "{}"), ("ratio", "{}"), ("transmitted_load", "{}"),
             ("auto", "{}"), ("dofs", "{}"), ("effectivity", "{}"),
             ("finest", "{}")])
print("wrote doc/data/parabolic_tension_scan.{csv,md}")
