#!/usr/bin/env python3
"""Where the time of the cost study's contact solve goes on its two largest
meshes (doc/performance.md, "Where the time above linear goes").

One run of the one-thread configuration of
  bench/membranes_cost.py --c-function=fischer-burmeister --flux-degree=p-1
                          --gamma-lin=0.1 --coarse-start --cycles=7
(Fischer-Burmeister, RT_0 fluxes, nested sequence from 768 cells to 3.1e6
unknowns per field, 11.0 GB) under `perf record -F 199`. The phases of a
cycle run one after the other, in this order: refinement, set-up, patch
set-up ("estimators: patch matrices"), assembly, Newton with its
estimators (the rest of the contact solve), errors and output, the
reference Poisson pair; each phase's samples are those inside the window
of its time in summary.json (so a window can be off by the fraction of a
second a cycle spends outside them). For each phase the table gives its
wall time and the seconds of samples in the kernel's clearing of pages
(`clear_page*`: pages touched for the first time); for the contact solve
(set-up to Newton) also the samples outside the kernel (the program's own
time) and, on the last mesh, the growth exponents of the wall time and
of the program's time against the mesh before.

Writes doc/data/profile-cost[-huge-pages][-cycles-<N>].md.
Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/profile_cost.py [--huge-pages] [--cycles=N]
--huge-pages runs with glibc's heap in huge pages
(GLIBC_TUNABLES=glibc.malloc.hugetlb=1, the other tunables kept).
--cycles=N stops after N meshes instead of 7 (5: half a minute and 1
GB; 7: about 6 minutes and 11.0 GB).
Needs perf (Debian package linux-perf).
"""
import bisect
import os
import re
import shutil
import subprocess
import sys

from vi_bench import (ROOT, growth_exponent, huge_pages_environment, option, poisson_seconds,
                      profile_settings, program, run, write_report)

HUGE_PAGES = "--huge-pages" in sys.argv
CYCLES = option("cycles", 7, int)
STEM = "profile-cost" + ("-huge-pages" if HUGE_PAGES else "") \
    + ("" if CYCLES == 7 else f"-cycles-{CYCLES}")
OUT = os.path.join(ROOT, "output", "bench-profile", STEM)
RATE = 199  # samples per second


def samples(perf_data):
    """(time, symbol, in the kernel) of every sample, from perf script."""
    text = subprocess.run(["perf", "script", "-i", perf_data, "-F", "time,ip,sym,dso"],
                          check=True, capture_output=True, text=True).stdout
    rows = []
    for line in text.splitlines():
        m = re.match(r"\s*([\d.]+):\s+\S+\s+(.*?)\s+\((\S+)\)\s*$", line)
        if m:
            rows.append((float(m.group(1)), m.group(2), "kallsyms" in m.group(3)))
    return rows


def phases(cycle):
    """(name, seconds, part of the contact solve) in the order they run."""
    t = cycle["timing"]
    setup, patches, assembly = (t["setup"], t["estimators: patch matrices"],
                                t["assembly"])
    solve = cycle["solve_seconds"]
    return [("refinement", t.get("refinement", 0.0), False),
            ("set-up", setup, True),
            ("patch set-up", patches, True),
            ("assembly", assembly, True),
            ("Newton with its estimators", solve - setup - patches - assembly, True),
            ("errors and output",
             cycle["wall_seconds"] - t.get("refinement", 0.0) - solve, False),
            ("2 Poisson", poisson_seconds(cycle), False)]


def main():
    if shutil.which("perf") is None:
        sys.exit("profile_cost.py: perf not found (apt-get install linux-perf)")
    os.makedirs(OUT, exist_ok=True)
    perf_data = os.path.join(OUT, "perf.data")
    settings = profile_settings(CYCLES, reference_poisson=True)
    environment = huge_pages_environment() if HUGE_PAGES else {}
    summary = run(program("membranes"), "estimators-disk-p1.prm", settings, OUT,
                  threads=1, environment=environment,
                  wrapper=["perf", "record", "-q", "-F", str(RATE), "-o", perf_data, "--"])
    rows = samples(perf_data)
    times = [r[0] for r in rows]  # (perf script lists them in order)
    # The cycles follow the first sample (the start of the program; its
    # set-up before the first cycle takes a fraction of a second).
    clock = times[0]
    table = []  # per cycle: summary, phases, clearing and own time of the solve
    for cycle in summary["cycles"]:
        own = clearing_in_solve = 0.0
        lines = []
        for name, seconds, in_solve in phases(cycle):
            window = rows[bisect.bisect_left(times, clock):
                          bisect.bisect_left(times, clock + seconds)]
            clearing = sum(1 for r in window if r[2] and "clear_page" in r[1]) / RATE
            if in_solve:
                own += sum(1 for r in window if not r[2]) / RATE
                clearing_in_solve += clearing
            lines.append((name, seconds, clearing))
            clock += seconds
        table.append((cycle, lines, clearing_in_solve, own))
    table = table[-2:]
    n0, wall0, own0 = (table[0][0]["dofs_per_field"], table[0][0]["solve_seconds"],
                       table[0][3])
    n1, wall1, own1 = (table[1][0]["dofs_per_field"], table[1][0]["solve_seconds"],
                       table[1][3])
    header = ["phase"] + [f"{c['dofs_per_field']} per field: wall (s)" for c, *_ in table] \
        + [f"{c['dofs_per_field']} per field: clearing pages (s)" for c, *_ in table]
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for i, (name, _, _) in enumerate(table[0][1]):
        out.append(f"| {name} | " + " | ".join(f"{lines[i][1]:.2f}" for _, lines, *_ in table)
                   + " | " + " | ".join(f"{lines[i][2]:.1f}" for _, lines, *_ in table) + " |")
    out.append("| contact solve | " + " | ".join(f"{c['solve_seconds']:.2f}" for c, *_ in table)
               + " | " + " | ".join(f"{s:.1f}" for _, _, s, _ in table) + " |")
    out.append("| contact solve, the program's own samples | "
               + " | ".join(f"{o:.2f}" for *_, o in table) + " | - | - |")
    out.append("")
    out.append(f"Growth exponents of the contact solve from {n0} to {n1} unknowns per "
               f"field: wall time {growth_exponent(wall1, wall0, n1, n0):.2f}, the program's own "
               f"samples {growth_exponent(own1, own0, n1, n0):.2f}; kernel CPU of the last "
               f"solve (getrusage) {table[-1][0]['solve_usage']['system_seconds']:.2f} s, "
               f"{table[-1][0]['solve_usage']['minor_page_faults']:.0f} minor faults; "
               f"peak resident memory of the run (summary.json) "
               f"{summary['peak_resident_bytes'] / 1e9:.2f} GB. Binary of {summary.get('git', '?')}"
               + (", glibc's heap in huge pages." if HUGE_PAGES else "."))
    write_report(STEM, out)


if __name__ == "__main__":
    main()
