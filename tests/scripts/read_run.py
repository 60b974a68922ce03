#!/usr/bin/env python3
"""Reads a rockwave run directory with VTK's own Python package (`pip install vtk`), as a check
that our .pvd series and .vtp frames open in an established reader we did not write.

Usage: read_run.py RUN_DIR

Prints one JSON object: per .pvd series in RUN_DIR, the frames it lists (time, file) and, per
frame as VTK reads it, the point and polygon counts, every point and cell array with its number
of components and tuples, a few values (the first points and first tuples of each array) and
exact sums (math.fsum) over all of them. Python floats print the shortest round-trip decimal, so
the numbers are exact.

Exits 2 when the `vtk` module is missing, 1 when a file cannot be read.
"""

import json
import math
import os
import struct
import sys
import xml.etree.ElementTree as ET

try:
    import vtk
except ImportError as e:  # the Rust test decides whether this is a skip or a failure
    print(f"read_run.py: the Python package 'vtk' is missing: {e}", file=sys.stderr)
    sys.exit(2)

SAMPLE = 5


def arrays(data):
    out = {}
    for i in range(data.GetNumberOfArrays()):
        a = data.GetArray(i)
        n = a.GetNumberOfTuples()
        out[a.GetName()] = {
            "components": a.GetNumberOfComponents(),
            "tuples": n,
            "first": [list(a.GetTuple(k)) for k in range(min(n, SAMPLE))],
            "sum": math.fsum(a.GetComponent(k, c) for k in range(n) for c in range(a.GetNumberOfComponents())),
        }
    return out


def read_frame(path):
    # The generic reader picks the reader from the file's own header, as ParaView does.
    reader = vtk.vtkXMLGenericDataObjectReader()
    reader.SetFileName(path)
    reader.Update()
    poly = reader.GetOutput()
    if poly is None or not poly.IsA("vtkPolyData"):
        raise RuntimeError(f"{path}: not read as vtkPolyData")
    errors = reader.GetErrorCode()
    if errors:
        raise RuntimeError(f"{path}: VTK reader error code {errors}")
    n = poly.GetNumberOfPoints()
    return {
        "class": poly.GetClassName(),
        "points": n,
        "verts": poly.GetNumberOfVerts(),
        "polys": poly.GetNumberOfPolys(),
        "first_points": [list(poly.GetPoint(k)) for k in range(min(n, SAMPLE))],
        # The same coordinates as IEEE-754 bit patterns, for comparisons that must be exact
        # whatever JSON parser reads this.
        "first_points_bits": [
            [struct.unpack("<Q", struct.pack("<d", c))[0] for c in poly.GetPoint(k)]
            for k in range(min(n, SAMPLE))
        ],
        "points_sum": math.fsum(c for k in range(n) for c in poly.GetPoint(k)),
        "point_data": arrays(poly.GetPointData()),
        "cell_data": arrays(poly.GetCellData()),
    }


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        sys.exit(64)
    run = sys.argv[1]
    out = {"vtk_version": vtk.vtkVersion.GetVTKVersion(), "series": {}}
    for name in sorted(os.listdir(run)):
        if not name.endswith(".pvd"):
            continue
        # VTK's Python package has no .pvd reader (ParaView's vtkPVDReader is not in it): the
        # collection is plain XML, parsed with Python's own parser; every frame it lists goes
        # through VTK.
        root = ET.parse(os.path.join(run, name)).getroot()
        if root.get("type") != "Collection":
            raise RuntimeError(f"{name}: VTKFile type is {root.get('type')!r}, not Collection")
        frames = []
        for ds in root.iter("DataSet"):
            frame = read_frame(os.path.join(run, ds.get("file")))
            frame["time"] = float(ds.get("timestep"))
            frame["file"] = ds.get("file")
            frames.append(frame)
        out["series"][name] = {"frames": frames}
    json.dump(out, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    try:
        main()
    except Exception as e:  # noqa: BLE001 - report any reader failure as a failed read
        print(f"read_run.py: {e}", file=sys.stderr)
        sys.exit(1)
