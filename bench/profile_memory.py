#!/usr/bin/env python3
"""Which code holds, and which code first touches, the memory of the cost
study's contact solve (doc/performance.md, "What holds the memory").

Two runs of the one-thread configuration of bench/profile_cost.py
(Fischer-Burmeister, gamma_lin = 0.1, RT_0 fluxes, the nested sequence from
768 cells), without the reference Poisson pair:
- under heaptrack: at the moment the heap is largest, every live
  allocation is charged to the innermost function of this repository on
  its call stack (VI::..., StepMembranes::...) and to the function that
  one called. The heap counts what was allocated, touched or not.
- under `perf record -e page-faults` (every 128th fault, with its call
  stack): the pages the process touches for the first time, which the
  kernel must clear (on this virtual machine at a high price, "Where the
  time above linear goes"), charged the same way, for each phase of the
  last mesh (refinement, set-up, patch set-up, assembly, Newton with its
  estimators, errors and output: the method of the problem class on the
  call stack). A fault maps one 4 KiB page (glibc's default heap;
  transparent huge pages only where a program asks for them).

Writes doc/data/profile-memory[-cycles-<N>].md.
Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/profile_memory.py [--cycles=N] [--tables-only]
--cycles=N stops after N meshes instead of 6 (6: to 7.9e5 unknowns per
field, about 7 minutes and 3 GB; 7: to 3.1e6 unknowns per field, 12 GB,
not tried).
--tables-only writes the tables again from the recorded runs in
output/bench-profile/<stem>/ without running them.
Needs heaptrack and perf (Debian packages heaptrack and linux-perf).
"""
import collections
import json
import os
import re
import shutil
import subprocess
import sys

from vi_bench import ROOT, option, profile_settings, program, run, write_report

CYCLES = option("cycles", 6, int)
TABLES_ONLY = "--tables-only" in sys.argv
STEM = "profile-memory" + ("" if CYCLES == 6 else f"-cycles-{CYCLES}")
OUT = os.path.join(ROOT, "output", "bench-profile", STEM)
ROWS = 15  # holders listed per table; the rest are summed in one row
# (the Poisson pair is not the question here)
SETTINGS = profile_settings(CYCLES, reference_poisson=False)
FAULT_PERIOD = 128  # one sample per this many page faults
STACK_BYTES = 32768  # of the stack copied per sample, for the unwinding
PAGE = 4096
# (a function of ours, possibly after its return type; templates removed)
OURS = re.compile(r"(^|\s)(VI|StepMembranes)::")
# The phases of a cycle: the method of MembraneProblem that
# VI::StationaryProblem::run() called
# (the patch set-up is the flux reconstruction's reinit in setup_system).
PHASES = {"refine_mesh": "refinement", "setup_system": "set-up",
          "assemble_system": "assembly", "initialize_iterate": "Newton with its estimators",
          "solve": "Newton with its estimators", "postprocess": "errors and output",
          "compute_errors": "errors and output", "output_results": "errors and output"}
PHASE_ORDER = ["refinement", "set-up", "patch set-up", "assembly",
               "Newton with its estimators", "errors and output"]
UNWOUND = "call stacks not unwound to run()"


def function_name(frame):
    """A frame's function without its arguments and template arguments."""
    name = re.sub(r"\(.*", "", frame).strip()
    while True:  # innermost template argument lists first
        shorter = re.sub(r"<[^<>]*>", "\x01", name)
        if shorter == name:
            return name.replace("\x01", "<>")
        name = shorter


def holder(frames):
    """(our innermost function, the function it called) of a call stack
    given innermost first."""
    for i, frame in enumerate(frames):
        name = function_name(frame)
        # (a balanced name: not a lambda or template cut at its arguments)
        if OURS.search(name) and name.count("<") == name.count(">"):
            return name, (function_name(frames[i - 1]) or "-") if i else "-"
    return "outside this repository", "-"


def phase(frames):
    """The phase of a cycle a call stack (innermost first) belongs to, or
    None outside the cycles' phases."""
    names = [function_name(frame) for frame in frames]
    outermost_first = names[::-1]
    run_frame = next((i for i, name in enumerate(outermost_first)
                      if name.endswith("StationaryProblem::run")), None)
    if run_frame is None:
        return None
    methods = [m.group(1) for m in
               (re.search(r"MembraneProblem<>::(\w+)$", name)
                for name in outermost_first[run_frame + 1:]) if m]
    if not methods:
        return None
    method = methods[0]
    if method == "setup_system" and any(n.endswith("FluxReconstruction<>::reinit")
                                        for n in names):
        return "patch set-up"
    return PHASES.get(method)


def profiled_run(directory, wrapper):
    """The summary.json of the study's run in directory under the command
    `wrapper`: run now, or with --tables-only the recorded one."""
    if not TABLES_ONLY:
        os.makedirs(directory, exist_ok=True)
        return run(program("membranes"), "estimators-disk-p1.prm", SETTINGS, directory,
                   threads=1, wrapper=wrapper)
    path = os.path.join(directory, "summary.json")
    if not os.path.exists(path):
        sys.exit(f"profile_memory.py: no recorded run in {directory} for --tables-only")
    with open(path) as f:
        return json.load(f)


def heap_at_peak():
    """Bytes live at the heap's peak per holder, the total and the run's
    summary."""
    out = os.path.join(OUT, "heaptrack")
    stacks = os.path.join(out, "peak.stacks")
    record = os.path.join(out, "heaptrack")
    summary = profiled_run(out, ["heaptrack", "-o", record])
    if not TABLES_ONLY:
        subprocess.run(["heaptrack_print", "-f", record + ".zst", "--print-peaks", "0",
                        "--print-allocators", "0", "--print-temporary", "0",
                        "--print-leaks", "0", "--flamegraph-cost-type", "peak",
                        "-F", stacks], check=True, stdout=subprocess.DEVNULL)
    bytes_of = collections.Counter()
    with open(stacks) as f:
        for line in f:  # frames outermost first, then the bytes
            stack, _, size = line.rstrip("\n").rpartition(" ")
            bytes_of[holder(stack.split(";")[::-1])] += int(size)
    return bytes_of, summary


def first_touches():
    """Per phase of the last mesh: bytes first touched per holder; and the
    run's summary."""
    out = os.path.join(OUT, "faults")
    stacks = os.path.join(out, "stacks.txt")
    data = os.path.join(out, "perf.data")
    summary = profiled_run(out, ["perf", "record", "-q", "-e", "page-faults",
                                 "-c", str(FAULT_PERIOD), "--call-graph",
                                 f"dwarf,{STACK_BYTES}", "-o", data, "--"])
    if not TABLES_ONLY:
        with open(stacks, "w") as f:
            subprocess.run(["perf", "script", "-i", data, "-F", "ip,sym"], check=True,
                           stdout=f)
    with open(stacks) as f:
        text = f.read()
    # Samples in time order, one block each: "<ip> <symbol>" per frame,
    # innermost first. The last cycle starts where its refinement does:
    # at the last sample of the refinement after one of another phase.
    samples = []  # (phase, holder)
    last_cycle_start = 0
    for block in text.split("\n\n"):
        frames = [line.strip().split(None, 1)[1] if " " in line.strip() else ""
                  for line in block.splitlines() if line.strip()]
        if not frames:
            continue
        # (None: outside the phases, or a stack perf could not unwind
        # to run(); kept, so that the last cycle's total is complete)
        name = phase(frames)
        if name == "refinement" and samples and samples[-1][0] not in ("refinement", None):
            last_cycle_start = len(samples)
        samples.append((name, holder(frames)))
    per_phase = {name: collections.Counter() for name in PHASE_ORDER + [None]}
    for name, h in samples[last_cycle_start:]:
        per_phase[name][h] += FAULT_PERIOD * PAGE
    return [(name or UNWOUND, bytes_of) for name, bytes_of in per_phase.items()], summary


def table(rows, total):
    """Markdown rows of the largest holders, the rest summed."""
    lines = ["| holder (innermost function of this repository) | which called | MB | share |",
             "|---|---|---|---|"]
    for (function, callee), size in rows[:ROWS]:
        lines.append(f"| {function} | {callee} | {size / 1e6:.1f} | {size / total:.1%} |")
    rest = sum(size for _, size in rows[ROWS:])
    if rest:
        lines.append(f"| {len(rows) - ROWS} others | - | {rest / 1e6:.1f} | {rest / total:.1%} |")
    return lines


def main():
    for tool in () if TABLES_ONLY else ("heaptrack", "heaptrack_print", "perf"):
        if shutil.which(tool) is None:
            sys.exit(f"profile_memory.py: {tool} not found "
                     "(apt-get install heaptrack linux-perf)")
    heap, summary = heap_at_peak()
    per_phase, fault_summary = first_touches()
    last = summary["cycles"][-1]
    unknowns = 3 * last["dofs_per_field"]  # u1, u2 and lambda
    total = sum(heap.values())
    out = [f"Binary of {summary.get('git', '?')}; the last mesh has "
           f"{last['dofs_per_field']} unknowns per field.", "",
           f"**The heap at its peak**: {total / 1e9:.2f} GB ({total / unknowns:.0f} bytes "
           "per unknown of the last mesh), allocated, touched or not:", ""]
    out += table(heap.most_common(), total)
    touched = sum(sum(b.values()) for _, b in per_phase)
    usage = fault_summary["cycles"][-1]["solve_usage"]
    out += ["", f"**First touched on the last mesh** (samples of every {FAULT_PERIOD}th page "
            f"fault): {touched / 1e9:.2f} GB in the last cycle; "
            f"the contact solve's minor faults (summary.json) "
            f"{usage['minor_page_faults']:.0f}, "
            f"{usage['minor_page_faults'] * PAGE / 1e9:.2f} GB; the run's peak resident "
            f"memory (summary.json) {fault_summary['peak_resident_bytes'] / 1e9:.2f} GB, "
            f"{fault_summary['peak_resident_bytes'] / unknowns:.0f} bytes per unknown:", "",
            "| phase | GB first touched |", "|---|---|"]
    out += [f"| {name} | {sum(b.values()) / 1e9:.2f} |" for name, b in per_phase]
    for name, bytes_of in per_phase:
        phase_total = sum(bytes_of.values())
        if phase_total >= 0.05 * touched:
            out += ["", f"In the {name}:", ""] + table(bytes_of.most_common(), phase_total)
    write_report(STEM, out)


if __name__ == "__main__":
    main()
