#!/usr/bin/env python3
"""The a posteriori estimate of step-hho against the error (doc/step-hho.md,
"A posteriori estimate").

step-hho with Estimators/Enabled = true, nested iteration, CG + AMG on the
condensed systems, p = 1, 2, 3, on four scenes with exact solutions:
  seed-smooth, seed-jump  parameters/hho-seed-*.prm: 64 ... 16384 cells
  disk                    parameters/membranes-disk.prm (curved cells at
                          the circle): 48 ... 3072 cells
  L-shape                 parameters/membranes-l-shape.prm: 48 ... 3072 cells
Writes doc/data/hho-estimator.{csv,md} (the energy error of the cell
polynomials, the estimate, the effectivity, the two largest parts of the
bound and the estimate's share of the wall time) and hho-estimator.png (the
effectivity against the mesh). About three minutes on two cores.

Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/hho_estimator.py
STEP_HHO names another binary.
"""
import math
import os

from vi_bench import DATA, ROOT, estimator_seconds, gnuplot, program, run, write_csv, write_dat, write_md

DEGREES = [1, 2, 3]
# (scene, parameter file, settings of the scene, meshes)
SCENES = [("seed-smooth", "hho-seed-smooth.prm", {}, 5),
          ("seed-jump", "hho-seed-jump.prm", {}, 5),
          ("disk", "membranes-disk.prm", {"Discretization/Method": "hho"}, 4),
          ("L-shape", "membranes-l-shape.prm", {"Discretization/Method": "hho"}, 4)]
OUT = os.path.join(ROOT, "output", "bench-hho-estimator")


def main():
    rows = []
    for scene, prm, settings, meshes in SCENES:
        for p in DEGREES:
            summary = run(program("hho"), prm,
                          {**settings, "Discretization/Polynomial degree": p,
                           "Mesh/Cycles": meshes, "Estimators/Enabled": "true",
                           "Nonlinear solver/Nested iteration": "true",
                           "Linear solver/Solver": "cg",
                           "Output/Write VTU": "false"},
                          os.path.join(OUT, f"{scene}-p{p}"))
            for c in summary["cycles"]:
                parts = c["estimate"]
                rows.append({"scene": scene, "p": p, "cells": c["cells"],
                             "dofs": c["dofs"], "error_energy": c["error_energy"],
                             "eta": c["eta"], "effectivity": c["effectivity"],
                             "flux": parts["flux"],
                             "nonconformity_1": parts["nonconformity_1"],
                             "estimator_share": estimator_seconds(c["timing"])
                             / c["wall_seconds"]})
            print(f"  {scene} p={p}: done", flush=True)
    write_csv("hho-estimator", rows)

    tables = []
    for scene, _, _, _ in SCENES:
        lines = [f"#### {scene}: effectivity eta / |||u - u_T|||_h", "",
                 "| cells | " + " | ".join(f"P{p} error | P{p} effectivity"
                                          for p in DEGREES) + " |",
                 "|---:|" + "---:|---:|" * len(DEGREES)]
        cells = sorted({r["cells"] for r in rows if r["scene"] == scene})
        for n in cells:
            line = f"| {n} |"
            for p in DEGREES:
                r = next(r for r in rows if r["scene"] == scene and r["p"] == p
                         and r["cells"] == n)
                line += f" {r['error_energy']:.3e} | {r['effectivity']:.2f} |"
            lines.append(line)
        tables.append("\n".join(lines))
    lines = ["#### The finest mesh of each scene: the parts against the error, "
             "and the estimate's share of the wall time", "",
             "| scene | p | cells | flux / error | nonconformity_1 / error | "
             "effectivity | estimate's share of the time |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for scene, _, _, _ in SCENES:
        for p in DEGREES:
            r = [r for r in rows if r["scene"] == scene and r["p"] == p][-1]
            lines.append(f"| {scene} | {p} | {r['cells']} | "
                         f"{r['flux'] / r['error_energy']:.2f} | "
                         f"{r['nonconformity_1'] / r['error_energy']:.2f} | "
                         f"{r['effectivity']:.2f} | {r['estimator_share']:.2f} |")
    tables.append("\n".join(lines))
    write_md("hho-estimator", tables, separator="\n\n")

    dat = os.path.join(DATA, "hho-estimator.dat")
    blocks = [(f"{scene} p={p}",
               [(math.sqrt(r["cells"]), r["effectivity"]) for r in rows
                if r["scene"] == scene and r["p"] == p])
              for scene, _, _, _ in SCENES for p in DEGREES]
    write_dat(dat, blocks)
    panels = []
    for s, (scene, _, _, _) in enumerate(SCENES):
        plots = [f"'{dat}' index {s * len(DEGREES) + k} with linespoints lw 2 "
                 f"pt {k + 4} title 'P{p}'" for k, p in enumerate(DEGREES)]
        panels.append(f"set title 'step-hho, {scene}'\nplot {', '.join(plots)}, "
                      "1 dt 2 lc rgb 'gray' notitle")
    gnuplot(f"""set terminal pngcairo size 1200,900 font ',11'
set output '{os.path.join(DATA, "hho-estimator.png")}'
set multiplot layout 2,2
set logscale x
set yrange [0:3]
set xlabel 'square root of the number of cells'
set ylabel 'effectivity eta / |||u - u_T|||_h'
set key bottom left
set grid
""" + "\n".join(panels) + "\nunset multiplot\n")
    os.remove(dat)
    print("wrote doc/data/hho-estimator.{csv,md,png}")


if __name__ == "__main__":
    main()
