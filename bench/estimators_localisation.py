#!/usr/bin/env python3
"""Where the estimate of the seed's jump test is sharp and where it is not
(doc/estimators.md): the energy error and the estimators per band of cells
around the free boundary r = 1/3, for Q2 on the square (the circle cuts the
cells) and on the mesh fitted to the circle, from the cellwise fields of the
VTU output ("error_energy" beside "eta", "eta_flux", "eta_residual").

Writes doc/data/estimators-localisation.{csv,md}.
Usage, from the repository root after ./demo.sh or ./test.sh:
  bench/estimators_localisation.py
"""
import base64
import math
import os
import re
import struct
import zlib

from vi_bench import ROOT, program, run, write_table

OUT = os.path.join(ROOT, "output", "bench-localisation")
RADIUS, CENTER, DEGREE = 1. / 3., (0.5, 0.5), 2
# (name, parameter file, initial refinements, cycles): both end near 4000
# to 5000 unknowns per field.
CASES = [("square (unfitted)", "membranes-seed-jump.prm", 2, 4),
         ("square-circle (fitted)", "membranes-seed-jump-fitted.prm", 1, 3)]
FIELDS = ("error_energy", "eta", "eta_flux", "eta_residual", "eta_nonconformity")


def read_vtu(path):
    """The arrays of a VTU file of deal.II (binary, zlib-compressed blocks):
    name -> list of numbers (points: list of 3-tuples)."""
    text = open(path).read()
    arrays = {}
    pattern = (r'<DataArray type="(\w+)"(?: Name="(\w+)")?'
               r'(?: NumberOfComponents="(\d+)")? format="binary">\s*(\S+)\s*</DataArray>')
    for kind, name, components, data in re.findall(pattern, text):
        n_blocks = struct.unpack("<I", base64.b64decode(data[:8])[:4])[0]
        header_length = (4 * (3 + n_blocks) + 2) // 3 * 4
        header = struct.unpack(f"<{3 + n_blocks}I", base64.b64decode(data[:header_length]))
        raw, offset, payload = base64.b64decode(data[header_length:]), 0, b""
        for size in header[3:]:
            payload += zlib.decompress(raw[offset:offset + size])
            offset += size
        code = {"Float32": "f", "Float64": "d", "Int32": "i", "UInt8": "B",
                "Int64": "q", "UInt32": "I"}[kind]
        values = struct.unpack(f"<{len(payload) // struct.calcsize(code)}{code}", payload)
        if components:
            k = int(components)
            values = [values[i:i + k] for i in range(0, len(values), k)]
        arrays[name or "points"] = values
    return arrays


def band(points):
    """0 for a cell the circle cuts, -k (+k) for a cell in the k-th layer of
    cell widths inside (outside) it, layer 1 touching it; |k| <= 3."""
    distances = [math.hypot(x - CENTER[0], y - CENTER[1]) for x, y, _ in points]
    width = max(x for x, _, _ in points) - min(x for x, _, _ in points)
    tolerance = 1e-3 * width  # cells of the fitted mesh touch the circle
    if min(distances) < RADIUS - tolerance and max(distances) > RADIUS + tolerance:
        return 0
    if max(distances) <= RADIUS:
        return -min(3, 1 + int((RADIUS - max(distances)) / width))
    return min(3, 1 + int((min(distances) - RADIUS) / width))


def main():
    rows = []
    for name, prm, refinements, cycles in CASES:
        directory = os.path.join(OUT, prm.replace(".prm", ""))
        summary = run(program("membranes"), prm,
                      {"Discretization/Polynomial degree": DEGREE,
                       "Mesh/Initial refinements": refinements, "Mesh/Cycles": cycles,
                       "Mesh/Refinement": "global", "Output/Write VTU": "true"},
                      directory)
        last = summary["cycles"][-1]
        arrays = read_vtu(os.path.join(directory, f"solution_{cycles - 1:02d}.0.vtu"))
        # Cell data comes as point data of the (p + 1)^dim points of each cell.
        per_cell = (DEGREE + 1) ** 2
        sums = {}
        for c in range(len(arrays["points"]) // per_cell):
            first = c * per_cell
            b = band(arrays["points"][first:first + per_cell])
            entry = sums.setdefault(b, dict(cells=0, **{f: 0. for f in FIELDS}))
            entry["cells"] += 1
            for f in FIELDS:
                entry[f] += arrays[f][first] ** 2
        for b in sorted(sums):
            entry = {f: math.sqrt(v) if f != "cells" else v for f, v in sums[b].items()}
            rows.append({"mesh": name, "dofs_per_field": last["dofs_per_field"],
                         "band": ("cut" if b == 0 else f"{b:+d}" +
                                  ("" if abs(b) < 3 else " and beyond")),
                         **entry, "ratio": entry["eta"] / entry["error_energy"]})
        rows.append({"mesh": name, "dofs_per_field": last["dofs_per_field"],
                     "band": "all", "cells": last["cells"],
                     "error_energy": last["error_energy"], "eta": last["eta"],
                     "eta_flux": math.nan, "eta_residual": math.nan,
                     "eta_nonconformity": math.nan, "ratio": last["effectivity"]})
        print(f"  {name}: done", flush=True)
    write_table("estimators-localisation", rows,
                ["mesh", "DoFs per field", "cells (layers from r = 1/3)", "cells",
                 "energy error", "eta_flux", "eta_residual", "eta_nonconformity",
                 "eta", "eta / error"],
                [("mesh", "{}"), ("dofs_per_field", "{}"), ("band", "{}"),
                 ("cells", "{}"), ("error_energy", "{:.2e}"), ("eta_flux", "{:.2e}"),
                 ("eta_residual", "{:.2e}"), ("eta_nonconformity", "{:.2e}"),
                 ("eta", "{:.2e}"), ("ratio", "{:.2f}")])


if __name__ == "__main__":
    main()
