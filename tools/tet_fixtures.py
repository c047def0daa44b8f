"""Tetrahedral grids written by VTK and meshio, for isokit's readers and marching tetrahedra.

Writes `data/tets/` (committed): one grid, the signed distance to a torus (R = 0.6,
r = 0.25) at the points of a tetrahedralized 9 x 9 x 9 lattice over [-1, 1]^3, each point
moved by up to 0.2 spacings (seed 2026), in the encodings these writers produce by default
and on request, plus `reference.json`: what VTK itself reports for the grid (cells,
points, range) and for its isosurface at 0 (`vtkContourFilter`: points, triangles, area,
volume), which the tests compare against.

    python3 -m venv /tmp/vtk && /tmp/vtk/bin/pip install vtk meshio numpy
    /tmp/vtk/bin/python tools/tet_fixtures.py
"""

import json
import os
import sys

import meshio
import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "tets")


def torus(p):
    q = np.hypot(p[:, 0], p[:, 1]) - 0.6
    return np.hypot(q, p[:, 2]) - 0.25


def grid():
    image = vtk.vtkImageData()
    image.SetDimensions(9, 9, 9)
    image.SetOrigin(-1, -1, -1)
    image.SetSpacing(0.25, 0.25, 0.25)
    tri = vtk.vtkDataSetTriangleFilter()
    tri.SetInputData(image)
    tri.Update()
    ug = tri.GetOutput()
    pts = vtk_to_numpy(ug.GetPoints().GetData()).astype(np.float64)
    rng = np.random.default_rng(2026)
    pts += rng.uniform(-0.05, 0.05, pts.shape)
    ug.GetPoints().SetData(numpy_to_vtk(pts.astype(np.float32), deep=True))
    # The scalar first, then a second scalar and a vector array the readers must skip or
    # select by name.
    for name, values in [
        ("distance", torus(pts)),
        ("height", pts[:, 2]),
        ("position", pts),
    ]:
        a = numpy_to_vtk(np.ascontiguousarray(values, dtype=np.float32), deep=True)
        a.SetName(name)
        ug.GetPointData().AddArray(a)
    return ug


def xml(ug, path, mode, compress):
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetInputData(ug)
    w.SetFileName(path)
    {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary,
     "appended": w.SetDataModeToAppended}[mode]()
    if not compress:
        w.SetCompressorTypeToNone()
    w.Write()


def legacy(ug, path, binary):
    w = vtk.vtkUnstructuredGridWriter()
    w.SetInputData(ug)
    w.SetFileName(path)
    w.SetFileTypeToBinary() if binary else w.SetFileTypeToASCII()
    w.Write()


def reference(ug):
    r = {"cells": ug.GetNumberOfCells(), "points": ug.GetNumberOfPoints()}
    d = vtk_to_numpy(ug.GetPointData().GetArray("distance"))
    r["range"] = [float(d.min()), float(d.max())]
    ug.GetPointData().SetActiveScalars("distance")
    c = vtk.vtkContourFilter()
    c.SetInputData(ug)
    c.SetValue(0, 0.0)
    c.Update()
    surface = c.GetOutput()
    tris = vtk.vtkTriangleFilter()
    tris.SetInputData(surface)
    tris.Update()
    mass = vtk.vtkMassProperties()
    mass.SetInputData(tris.GetOutput())
    mass.Update()
    r["contour"] = {
        "filter": "vtkContourFilter " + vtk.vtkVersion.GetVTKVersion(),
        "points": surface.GetNumberOfPoints(),
        "triangles": tris.GetOutput().GetNumberOfCells(),
        "area": mass.GetSurfaceArea(),
        "volume": mass.GetVolume(),
    }
    return r


def main():
    os.makedirs(OUT, exist_ok=True)
    ug = grid()
    files = {
        "torus.vtu": lambda p: xml(ug, p, "appended", True),
        "torus_ascii.vtu": lambda p: xml(ug, p, "ascii", False),
        "torus.vtk": lambda p: legacy(ug, p, True),
    }
    for name, write in files.items():
        write(os.path.join(OUT, name))
    # meshio: its own XML writer (inline base64, zlib) and the legacy 4.2 layout.
    m = meshio.read(os.path.join(OUT, "torus.vtu"))
    meshio.write(os.path.join(OUT, "torus_meshio.vtu"), m)
    meshio.write(os.path.join(OUT, "torus_meshio.vtk"), m, file_format="vtk42", binary=True)
    ref = reference(ug)
    ref["files"] = sorted(os.listdir(OUT))
    ref["writers"] = {"vtk": vtk.vtkVersion.GetVTKVersion(), "meshio": meshio.__version__}
    with open(os.path.join(OUT, "reference.json"), "w") as f:
        json.dump(ref, f, indent=2)
        f.write("\n")
    json.dump(ref, sys.stdout, indent=2)


if __name__ == "__main__":
    main()
