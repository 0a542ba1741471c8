#!/usr/bin/env python3
"""HHO reproduces solutions of degree p on meshes with faces between
refinement levels (doc/step-hho.md, "Adaptive refinement").

Runs step-hho on hho/exactness/polynomial.prm (no contact, fixed-fraction
refinement: hanging faces on every mesh after the first) with the solution
u1 = q + 3, u2 = q - x^p of degree p, for p = 1, 2, 3, and checks on every
mesh
  - that the mesh is not uniform after the first (it would not test the
    faces between levels);
  - that the energy error of the cell polynomials and the estimate are at
    round-off, below 1e-9 of the energy norm of the solution (of order 1).
Usage: check_hho_exactness.py PROGRAM WORKDIR PRM
Exits non-zero with one line per failure."""
import json
import os
import shutil
import subprocess
import sys

ROUND_OFF = 1e-9


def solution(p):
    """u1, u2, f1, f2 (mu1 = 1, mu2 = 2) of degree p, u1 - u2 >= 2 on the
    unit square."""
    q = {1: "x + 2*y", 2: "x^2 + x*y - y^2/2", 3: "x^3 - 3*x*y^2 + y^2"}[p]
    laplacian = {1: "0", 2: "1", 3: "2"}[p]  # of q; x^p has p (p - 1) x^(p-2)
    xp = {1: "x", 2: "x^2", 3: "x^3"}[p]
    lap_xp = {1: "0", 2: "2", 3: "6*x"}[p]
    u1 = f"{q} + 3"
    u2 = f"{q} - {xp}"
    f1 = f"-({laplacian})"
    f2 = f"-2*(({laplacian}) - ({lap_xp}))"
    return u1, u2, f1, f2


def main():
    program, workdir, prm = sys.argv[1:4]
    failures = []
    for p in (1, 2, 3):
        u1, u2, f1, f2 = solution(p)
        directory = os.path.join(workdir, f"p{p}")
        shutil.rmtree(directory, ignore_errors=True)
        settings = {"Discretization/Polynomial degree": p,
                    "Problem/Expression/u1": u1, "Problem/Expression/g1": u1,
                    "Problem/Expression/u2": u2, "Problem/Expression/g2": u2,
                    "Problem/Expression/f1": f1, "Problem/Expression/f2": f2,
                    "Output/Directory": directory}
        command = [program, prm]
        for key, value in settings.items():
            command += ["--set", f"{key}={value}"]
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
        with open(os.path.join(directory, "summary.json")) as f:
            cycles = json.load(f)["cycles"]
        for c in cycles:
            where = f"p = {p}, cycle {c['cycle']}"
            # a uniform mesh of N = 16 4^k cells has 2 N - 2 sqrt(N)
            # interior faces, each with 2 p unknowns after condensation
            n = c["cells"]
            side = round(n ** 0.5)
            uniform = (side * side == n and
                       c["dofs_condensed"] == 2 * p * (2 * n - 2 * side))
            if c["cycle"] > 0 and uniform:
                failures.append(f"{where}: {n} cells, a uniform mesh")
            for key in ("error_energy", "eta"):
                if not c[key] <= ROUND_OFF:
                    failures.append(f"{where}: {key} = {c[key]:.3e}, not at "
                                    f"round-off")
    for line in failures:
        print(line)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
