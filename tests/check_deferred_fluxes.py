#!/usr/bin/env python3
"""Check of Estimators/Defer fluxes (doc/estimators.md, "Deferred fluxes").

Runs step-membranes on each .prm twice, with the default (deferred fluxes)
and with Estimators/Defer fluxes = false, and checks that
  - both runs take the same decisions: the same cycles, Newton and GMRES
    counts, and the same estimate records (Newton step, GMRES iteration,
    accepted) in summary.json's "iterations";
  - every check that skipped its fluxes ("fluxes": false) holds the
    flux-free terms of the complete estimate of the same iterate in the
    other run: eta_lin from below and eta_alg from above, and eta_alg
    exactly (to round-off) where the remainder is bounded by Friedrichs'
    inequality in both (no 'remainder' in Estimators/Equilibrated dual
    norms): the flux-free evaluation, which visits most cells for their
    values only, must sum the same remainder as the complete one;
  - every other record and the final estimates agree;
  - at least one check of all the runs skipped its fluxes (the test would
    otherwise not test anything).
Usage: check_deferred_fluxes.py PROGRAM WORKDIR PRM [PRM ...]
Exits non-zero with one line per failure."""
import math
import os
import shutil
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                os.pardir, "bench"))
import vi_bench  # noqa: E402  (running a program with --set overrides)

RELATIVE = 1e-12  # round-off of the same sums in the same order


def run(program, prm, directory, defer):
    shutil.rmtree(directory, ignore_errors=True)
    return vi_bench.run(program, prm, {"Estimators/Defer fluxes": defer}, directory)


def close(a, b):
    return math.isclose(a, b, rel_tol=RELATIVE, abs_tol=1e-300)


def equilibrated_remainder(prm):
    """Whether the .prm bounds the remainder by equilibration."""
    with open(prm) as f:
        for line in f:
            words = line.split("#", 1)[0].split("=", 1)
            if len(words) == 2 and " ".join(words[0].split()) == "set Equilibrated dual norms":
                return "remainder" in words[1]
    return False


def main():
    program, workdir, prms = (os.path.abspath(sys.argv[1]), sys.argv[2],
                              [os.path.abspath(p) for p in sys.argv[3:]])
    failures, deferred_checks = [], 0
    for prm in prms:
        name = os.path.basename(prm)
        friedrichs = not equilibrated_remainder(prm)
        deferred = run(program, prm, os.path.join(workdir, name, "deferred"), "true")
        complete = run(program, prm, os.path.join(workdir, name, "complete"), "false")
        if len(deferred["cycles"]) != len(complete["cycles"]):
            failures.append(f"{name}: {len(deferred['cycles'])} cycles against "
                            f"{len(complete['cycles'])}")
            continue
        for d, c in zip(deferred["cycles"], complete["cycles"]):
            where = f"{name}, cycle {d['cycle']}"
            for key in ("dofs", "newton_iterations", "linear_iterations"):
                if d[key] != c[key]:
                    failures.append(f"{where}: {key} {d[key]} against {c[key]}")
            for key in ("eta", "eta_disc", "eta_lin", "eta_alg"):
                if not close(d[key], c[key]):
                    failures.append(f"{where}: final {key} {d[key]} against {c[key]}")
            ids = lambda records: [(r["k"], r["i"], r["accepted"]) for r in records]
            if ids(d["iterations"]) != ids(c["iterations"]):
                failures.append(f"{where}: the estimate records differ")
                continue
            for r, s in zip(d["iterations"], c["iterations"]):
                # (the check that GMRES accepted and the Newton step's own
                # record share their Newton step and GMRES iteration)
                at = (f"{where}, Newton step {r['k']}, GMRES iteration {r['i']}"
                      + (", accepted" if r["accepted"] else ""))
                if r.get("fluxes", True):
                    for key in ("eta", "eta_disc", "eta_lin", "eta_alg"):
                        if not close(r[key], s[key]):
                            failures.append(f"{at}: {key} {r[key]} against {s[key]}")
                    continue
                deferred_checks += 1
                if "eta" in r or "eta_disc" in r:
                    failures.append(f"{at}: a check without fluxes reports eta")
                if r["eta_lin"] > s["eta_lin"] * (1 + RELATIVE):
                    failures.append(f"{at}: eta_lin {r['eta_lin']} without fluxes is "
                                    f"above the complete {s['eta_lin']}")
                if r["eta_alg"] < s["eta_alg"] * (1 - RELATIVE):
                    failures.append(f"{at}: eta_alg {r['eta_alg']} without fluxes is "
                                    f"below the complete {s['eta_alg']}")
                elif friedrichs and not close(r["eta_alg"], s["eta_alg"]):
                    failures.append(f"{at}: eta_alg {r['eta_alg']} without fluxes is "
                                    f"not the complete {s['eta_alg']} (the same "
                                    "Friedrichs bound)")
    if deferred_checks == 0:
        failures.append("no check skipped its fluxes")
    for failure in failures:
        print(failure)
    print(f"{deferred_checks} checks without fluxes, {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
