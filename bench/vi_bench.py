"""What the studies in bench/ share: where the programs and the data are,
running a program with --set overrides, writing a table as CSV and
Markdown (doc/data/<stem>.{csv,md}) and reading the CSV back, and running
gnuplot (data blocks, a plot to a PNG)."""
import csv
import json
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "doc", "data")


def option(name, default=None, kind=str):
    """The value of --name=value on the command line, converted by kind, or
    default if it is not given."""
    prefix = f"--{name}="
    return next((kind(a[len(prefix):]) for a in sys.argv[1:] if a.startswith(prefix)),
                default)


def program(name):
    """The binary of step-<name>; STEP_<NAME> names another one (e.g. a
    copy, so that the build tree can be rebuilt while a study runs)."""
    return os.environ.get("STEP_" + name.upper(),
                          os.path.join(ROOT, "build", f"step-{name}", f"step-{name}"))


def run(binary, prm, settings, directory, np=1, threads=None, environment=None,
        wrapper=None):
    """Run binary on parameters/<prm> with the settings (section/name:
    value) and Output/Directory = directory, on np processes of at most
    `threads` threads each (DEAL_II_NUM_THREADS; None: deal.II's default,
    all cores shared by the processes), with the variables of
    `environment` added to the environment, under the command `wrapper`
    (a list, e.g. perf record and its options) if given; return its
    summary.json."""
    command = (wrapper or []) + [binary, os.path.join(ROOT, "parameters", prm)]
    for key, value in {**settings, "Output/Directory": directory}.items():
        command += ["--set", f"{key}={value}"]
    if np > 1:
        command = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", str(np)] + command
    env = {**os.environ, **(environment or {})}
    if threads is not None:
        env["DEAL_II_NUM_THREADS"] = str(threads)
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, env=env)
    with open(os.path.join(directory, "summary.json")) as f:
        return json.load(f)


def run_kept(binary, prm, settings, directory, reuse=False, threads=None):
    """run(), but also the summary.json of a run that failed (its status
    says why), and with reuse the summary a previous run left in
    directory, without running."""
    summary_file = os.path.join(directory, "summary.json")
    if reuse and os.path.exists(summary_file):
        with open(summary_file) as f:
            return json.load(f)
    try:
        return run(binary, prm, settings, directory, threads=threads)
    except subprocess.CalledProcessError:
        with open(summary_file) as f:
            return json.load(f)


# --continuation-method=smoothing: the cold-start studies with the smoothed
# C-function instead of the default interior-point method; their tables
# then carry the suffix "_smoothing".
CONTINUATION_METHOD = option("continuation-method", "interior point")
CONTINUATION_SUFFIX = ("_smoothing" if CONTINUATION_METHOD == "smoothing"
                       else "")


def cold_start_settings(refinements, guess, c_function):
    """One Q1 mesh without nested iteration, Newton from the initial guess
    `guess` (bench/cold_start.py, bench/cold_start_adaptive.py,
    bench/cold_start_million.py), with the continuation method of
    --continuation-method."""
    return {"Mesh/Initial refinements": refinements,
            "Mesh/Cycles": 1,
            "Discretization/Polynomial degree": 1,
            "Nonlinear solver/Nested iteration": "false",
            "Nonlinear solver/Initial guess": guess,
            "Nonlinear solver/C-function": c_function,
            "Nonlinear solver/Continuation method": CONTINUATION_METHOD,
            "Output/Write VTU": "false"}


def cost_study_settings(c_function, flux_degree, initial_refinements):
    """The contact solve of the cost study (bench/membranes_cost.py) on
    parameters/estimators-disk-p1.prm: adaptive inexact Newton with the
    given C-function and nested iteration, GMRES + AMG, estimates at the
    end of the Newton steps with fluxes of the given degree, without the
    scene's sharper final error bar (not part of the solve)."""
    return {"Mesh/Initial refinements": initial_refinements,
            "Nonlinear solver/Strategy": "adaptive",
            "Nonlinear solver/C-function": c_function,
            "Estimators/Flux degree": flux_degree,
            "Nonlinear solver/Nested iteration": "true",
            "Linear solver/Preconditioner": "amg",
            "Estimators/At every check": "false",
            "Estimators/Sharpen final estimate": "false"}


def profile_settings(cycles, reference_poisson):
    """The cost study's one-thread configuration that the profiles run
    (bench/profile_cost.py, bench/profile_memory.py): Fischer-Burmeister,
    gamma_lin = 0.1, RT_0 fluxes, nested from 768 cells, no VTU."""
    return {**cost_study_settings("fischer-burmeister", "p-1", 3),
            "Nonlinear solver/gamma_lin": 0.1,
            "Mesh/Cycles": cycles,
            "Benchmark/Reference Poisson solve": "true" if reference_poisson else "false",
            "Output/Write VTU": "false"}


def huge_pages_environment():
    """The environment that puts glibc's heap in huge pages
    (GLIBC_TUNABLES=glibc.malloc.hugetlb=1, README.md), keeping the other
    tunables the caller set."""
    return {"GLIBC_TUNABLES": ":".join(
        t for t in (os.environ.get("GLIBC_TUNABLES"), "glibc.malloc.hugetlb=1") if t)}


def growth_exponent(seconds, previous_seconds, dofs, previous_dofs):
    """The exponent a of seconds ~ dofs^a between two meshes (1: linear)."""
    return math.log(seconds / previous_seconds) / math.log(dofs / previous_dofs)


def poisson_seconds(cycle):
    """The reference Poisson solves of a cycle of summary.json (Benchmark/
    Reference Poisson solve: one CG + AMG solve per membrane), summed."""
    return sum(solve["seconds"] for solve in cycle["reference_poisson"])


def estimator_seconds(timing):
    """The estimators' share of a TimerOutput split ("timing" in summary.json)."""
    return sum(seconds for section, seconds in timing.items()
               if section.startswith("estimators"))


def convergence_rows(records, rate, run, counts):
    """The CSV rows of a convergence study, one a cycle of records (the
    "cycles" of summary.json): run (a dict saying which run), the cycle and
    its cells, counts(cycle) (a dict: DoFs, iterations), the energy error and
    its rate(previous, current) against the cycle before, the error of the
    multiplier and the wall time."""
    return [{**run, "cycle": c["cycle"], "cells": c["cells"], **counts(c),
             "error_energy": c["error_energy"],
             "rate": rate(records[n - 1], c) if n else "",
             "error_lambda_l2": c.get("error_lambda_l2", ""),
             "wall_seconds": c["wall_seconds"]}
            for n, c in enumerate(records)]


def write_csv(stem, rows):
    """rows (dicts) to doc/data/<stem>.csv, the keys of the first row as the
    columns (read_table reads it)."""
    os.makedirs(DATA, exist_ok=True)
    with open(os.path.join(DATA, stem + ".csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)


def write_table(stem, rows, header, formats):
    """rows (dicts) to doc/data/<stem>.csv, all keys; and to <stem>.md (see
    write_markdown)."""
    write_csv(stem, rows)
    write_markdown(stem, rows, header, formats)


def write_markdown(stem, rows, header, formats):
    """rows (dicts) to doc/data/<stem>.md: the columns of formats ((key,
    format) pairs) under header, NaN (or a missing key) as '-'."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        lines.append("| " + " | ".join(fmt.format(row.get(key, float("nan"))).replace("nan", "-")
                                       for key, fmt in formats) + " |")
    write_md(stem, lines)


def write_md(stem, parts, separator="\n", echo=False):
    """parts (lines of markdown, or whole tables with separator "\n\n") to
    doc/data/<stem>.md; with echo, to the terminal as well."""
    text = separator.join(parts)
    os.makedirs(DATA, exist_ok=True)
    with open(os.path.join(DATA, stem + ".md"), "w") as f:
        f.write(text + "\n")
    if echo:
        print(text)


def gnuplot(script):
    """Run gnuplot on the script (a string); it writes the files it names."""
    subprocess.run(["gnuplot"], input=script.encode(), check=True)


def write_dat(path, blocks):
    """Data for gnuplot to path: blocks is a list of (comment, rows), each
    block the `index` of its place, each row a sequence of values written
    space-separated; a comment of None writes no comment line."""
    with open(path, "w") as f:
        for comment, rows in blocks:
            if comment is not None:
                f.write(f"# {comment}\n")
            for row in rows:
                f.write(" ".join(str(value) for value in row) + "\n")
            f.write("\n\n")


def plot_png(png, settings, plots, size="900,600", font=12):
    """One gnuplot plot to png (pngcairo of size, font size font): the set
    commands in settings (a list of lines), then plots, the plot items."""
    gnuplot(f"set terminal pngcairo size {size} font ',{font}'\n"
            f"set output '{png}'\n" + "".join(line + "\n" for line in settings)
            + "plot " + ", \\\n     ".join(plots) + "\n")


def write_report(stem, lines):
    """lines (a report in markdown) to doc/data/<stem>.md, and to the
    terminal."""
    write_md(stem, lines, echo=True)
    print(f"wrote {os.path.join(DATA, stem)}.md")


def read_table(stem):
    """The rows write_table wrote to doc/data/<stem>.csv, each value with
    the type it was written with (int, float or str), so that writing them
    again gives the same file."""
    def value(text):
        for kind in (int, float):
            try:
                return kind(text)
            except ValueError:
                pass
        return text
    with open(os.path.join(DATA, stem + ".csv"), newline="") as f:
        return [{key: value(text) for key, text in row.items()} for row in csv.DictReader(f)]
