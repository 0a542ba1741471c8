#!/usr/bin/env python3
"""Wall time of step-hho with and without static condensation
(doc/step-hho.md, "Speed").

Runs parameters/hho-timing.prm (seed-smooth, p = 3, nested iteration on the
seed's five meshes, the last with 16384 cells and 195072 unknowns after
static condensation) in five configurations:
  cg-1        static condensation, CG + AMG on the face systems, 1 process
  cg-2        the same on 2 MPI processes (1 thread each)
  lu-1        static condensation, LU (MUMPS) on the face systems, 1 process
  full-lu     no static condensation, LU (MUMPS) on the whole Newton system
  cg-1-loose  as cg-1 with Newton and CG tolerances 1e-8 instead of the
              defaults 1e-10 (Newton) and 1e-12 (CG)
The end-to-end time is that of the whole process (start to exit, all five
meshes), with the CPU time (user + system) of the process and its children
beside it; the split into assembly, static condensation, solve and recovery
comes from the TimerOutput sections in summary.json. The condensed runs are
repeated and the fastest is kept (the machine is shared: the load average
before each run is recorded).

Writes doc/data/hho-timing.{csv,md}.
Usage: bench/hho_timing.py [--repeat N] [--cycles N]   (from the repository
root, after the build).
"""
import json
import os
import resource
import subprocess
import sys
import time

from vi_bench import DATA, ROOT, program, write_csv

PROGRAM = program("hho")
SCENE = os.path.join(ROOT, "parameters", "hho-timing.prm")


def option(name, default):
    return int(sys.argv[sys.argv.index(name) + 1]) if name in sys.argv else default


REPEAT = option("--repeat", 3)
CYCLES = option("--cycles", 5)

CONFIGURATIONS = [
    # name, processes, static condensation, solver, repetitions, settings
    ("cg-1", 1, "true", "cg", REPEAT, []),
    ("cg-2", 2, "true", "cg", REPEAT, []),
    ("lu-1", 1, "true", "direct", 1, []),
    ("full-lu", 1, "false", "direct", 1, []),
    ("cg-1-loose", 1, "true", "cg", REPEAT,
     ["Nonlinear solver/Tolerance=1e-8", "Linear solver/Tolerance=1e-8"]),
]

# TimerOutput sections, grouped as in the text: the assembly of the
# matrices of a mesh (and without condensation the Jacobian rows of each
# Newton step), the static condensation of each Newton step, the setup of
# the linear solver (AMG or the LU factorisation), the solves, the recovery
# of the cell unknowns.
GROUPS = {
    "assembly": ["assembly", "assembly: jacobian rows"],
    "static condensation": ["static condensation"],
    "solve: setup": ["solve: setup"],
    "solve": ["solve"],
    "recovery": ["recovery"],
}


def run(name, processes, condensation, solver, settings):
    out = os.path.join(ROOT, "output", "bench", f"hho-timing-{name}")
    command = [PROGRAM, SCENE,
               "--set", f"Mesh/Cycles={CYCLES}",
               "--set", f"Discretization/Static condensation={condensation}",
               "--set", f"Linear solver/Solver={solver}",
               "--set", f"Output/Directory={out}"]
    for setting in settings:
        command += ["--set", setting]
    environment = dict(os.environ)
    if processes > 1:
        command = ["mpirun", "--allow-run-as-root", "--oversubscribe",
                   "-np", str(processes)] + command
        environment["DEAL_II_NUM_THREADS"] = "1"
    with open("/proc/loadavg") as f:
        load = float(f.read().split()[0])
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, env=environment)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - usage.ru_utime) + (after.ru_stime - usage.ru_stime)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return wall, cpu, load, summary


def main():
    os.makedirs(DATA, exist_ok=True)
    rows = []
    for name, processes, condensation, solver, repetitions, settings in \
            CONFIGURATIONS:
        best = None
        for _ in range(repetitions):
            wall, cpu, load, summary = run(name, processes, condensation, solver,
                                           settings)
            print(f"{name}: {wall:.2f} s, CPU {cpu:.2f} s (load average "
                  f"{load:.2f})", flush=True)
            if best is None or wall < best[0]:
                best = (wall, cpu, load, summary)
        wall, cpu, load, summary = best
        last = summary["cycles"][-1]
        total = summary["timing"]
        row = {"configuration": name, "processes": processes,
               "static_condensation": condensation, "solver": solver,
               "newton_tolerance":
                   summary["parameters"]["Nonlinear solver"]["Tolerance"],
               "linear_tolerance":
                   summary["parameters"]["Linear solver"]["Tolerance"],
               "end_to_end_seconds": round(wall, 3),
               "cpu_seconds": round(cpu, 3),
               "load_average_before": load,
               "cells": last["cells"], "dofs": last["dofs"],
               "dofs_condensed": last["dofs_condensed"],
               "newton_last_mesh": last["newton_iterations"],
               "cg_last_mesh": last["linear_iterations"],
               "last_mesh_seconds": round(last["wall_seconds"], 3),
               "error_energy": last["error_energy"],
               "error_lambda_l2": last["error_lambda_l2"]}
        for group, sections in GROUPS.items():
            row[f"{group} (all meshes)"] = round(
                sum(total.get(s, 0.) for s in sections), 3)
            row[f"{group} (last mesh)"] = round(
                sum(last["timing"].get(s, 0.) for s in sections), 3)
        # The remaining sections: setup of the unknowns, residuals, errors,
        # postprocessing, refinement.
        grouped = [s for sections in GROUPS.values() for s in sections]
        for scope, timing in [("all meshes", total), ("last mesh", last["timing"])]:
            row[f"other sections ({scope})"] = round(sum(
                seconds for s, seconds in timing.items() if s not in grouped), 3)
        rows.append(row)

    write_csv("hho-timing", rows)

    lines = ["| | " + " | ".join(r["configuration"] for r in rows) + " |",
             "|---|" + "---:|" * len(rows)]

    def line(label, key, fmt="{}"):
        lines.append(f"| {label} | " + " | ".join(fmt.format(r[key]) for r in rows)
                     + " |")

    line("processes", "processes")
    line("static condensation", "static_condensation")
    line("face / whole system solver", "solver")
    lines.append("| Newton / CG tolerance | " + " | ".join(
        f"{r['newton_tolerance']} / {r['linear_tolerance']}" for r in rows) + " |")
    line("end to end, five meshes [s]", "end_to_end_seconds", "{:.2f}")
    line("CPU time, five meshes [s]", "cpu_seconds", "{:.2f}")
    line("load average before the run", "load_average_before", "{:.2f}")
    line("last mesh: cells", "cells")
    line("last mesh: unknowns (no SC)", "dofs")
    line("last mesh: unknowns (SC)", "dofs_condensed")
    line("last mesh: Newton-min iterations", "newton_last_mesh")
    line("last mesh: CG iterations", "cg_last_mesh")
    line("last mesh: wall time [s]", "last_mesh_seconds", "{:.2f}")
    for scope in ["last mesh", "all meshes"]:
        for group in list(GROUPS) + ["other sections"]:
            line(f"{scope}: {group} [s]", f"{group} ({scope})", "{:.2f}")
    line("last mesh: energy error", "error_energy", "{:.4e}")
    line("last mesh: multiplier L2 error", "error_lambda_l2", "{:.4e}")
    with open(os.path.join(DATA, "hho-timing.md"), "w") as f:
        f.write("#### step-hho, seed-smooth, p = 3, five meshes (wall times, "
                "fastest of the repetitions)\n\n" + "\n".join(lines) + "\n")
    print(f"wrote {DATA}/hho-timing.{{csv,md}}")


if __name__ == "__main__":
    main()
