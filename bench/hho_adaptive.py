#!/usr/bin/env python3
"""CG and Newton stopped by the HHO estimate against both run to their
tolerances (doc/step-hho.md, "The adaptive strategy").

step-hho with the estimate, nested iteration, CG + AMG on the condensed
systems, p = 1, 2, 3, on the four scenes of bench/hho_estimator.py, once with
Nonlinear solver/Strategy = exact and once with adaptive (CG stops when
eta_alg <= 0.03 max(eta_disc, eta_lin), Newton when eta_lin <= 0.3
eta_disc). Per scene and degree: the Newton steps and CG
iterations summed over the meshes, and on the finest mesh the energy error
of the cell polynomials, the effectivity and the L2 error of the multiplier,
all in one run per strategy. Writes doc/data/hho-adaptive.{csv,md}. About
two minutes on two cores.

Run from the repository root after ./demo.sh or ./test.sh, as the other
scripts.
"""
import os

from hho_estimator import DEGREES, SCENES
from vi_bench import ROOT, program, run, write_csv, write_md

STRATEGIES = ["exact", "adaptive"]
OUT = os.path.join(ROOT, "output", "bench-hho-adaptive")


def main():
    rows = []
    for scene, prm, settings, meshes in SCENES:
        for p in DEGREES:
            for strategy in STRATEGIES:
                summary = run(program("hho"), prm,
                              {**settings, "Discretization/Polynomial degree": p,
                               "Mesh/Cycles": meshes, "Estimators/Enabled": "true",
                               "Nonlinear solver/Nested iteration": "true",
                               "Nonlinear solver/Strategy": strategy,
                               "Linear solver/Solver": "cg",
                               "Output/Write VTU": "false"},
                              os.path.join(OUT, f"{scene}-p{p}-{strategy}"))
                cycles = summary["cycles"]
                last = cycles[-1]
                rows.append({"scene": scene, "p": p, "strategy": strategy,
                             "cells": last["cells"],
                             "newton": sum(c["newton_iterations"] for c in cycles),
                             "cg": sum(c["linear_iterations"] for c in cycles),
                             "error_energy": last["error_energy"],
                             "effectivity": last["effectivity"],
                             "error_lambda": last["error_lambda_l2"],
                             "seconds": sum(c["wall_seconds"] for c in cycles)})
            print(f"  {scene} p={p}: done", flush=True)
    write_csv("hho-adaptive", rows)

    lines = ["| scene | p | cells (finest) | Newton steps: exact / adaptive | "
             "CG iterations: exact / adaptive (factor) | energy error, finest: "
             "exact / adaptive | effectivity, finest: exact / adaptive | "
             "multiplier L2 error, finest: exact / adaptive | seconds: exact / "
             "adaptive |",
             "|---|---:|---:|---|---|---|---|---|---|"]
    for scene, _, _, _ in SCENES:
        for p in DEGREES:
            e, a = (next(r for r in rows if r["scene"] == scene and r["p"] == p
                         and r["strategy"] == s) for s in STRATEGIES)
            lines.append(
                f"| {scene} | {p} | {e['cells']} | {e['newton']} / {a['newton']} | "
                f"{e['cg']} / {a['cg']} ({e['cg'] / max(a['cg'], 1):.1f}) | "
                f"{e['error_energy']:.4e} / {a['error_energy']:.4e} | "
                f"{e['effectivity']:.2f} / {a['effectivity']:.2f} | "
                f"{e['error_lambda']:.2e} / {a['error_lambda']:.2e} | "
                f"{e['seconds']:.2f} / {a['seconds']:.2f} |")
    write_md("hho-adaptive", lines, echo=True)
    print("wrote doc/data/hho-adaptive.{csv,md}")


if __name__ == "__main__":
    main()
