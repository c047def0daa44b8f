"""Isosurfaces of tetrahedral grids: `isokit mesh grid.vtu` (marching tetrahedra) against
VTK's `vtkContour3DLinearGrid` and `vtkContourFilter` (from the `vtk` wheel on PyPI) on the
same `.vtu` file, in one run: time and accuracy.

Each grid is the signed distance to a torus (R = 0.6, r = 0.25), exact at the points of a
tetrahedralized N x N x N lattice over [-1, 1]^3 (`vtkDataSetTriangleFilter`, 5 tetrahedra
per cube) with every point moved by up to 0.2 spacings, written by
`vtkXMLUnstructuredGridWriter` (appended, zlib). Times are read + contour, the median of a
few runs: VTK's in this process (reader and filter `Update()`), isokit's as it reports them
(`... in S s`, the reading and the meshing, not the writing of the mesh). Accuracy is the
largest |torus distance| at the surface's vertices (the linear interpolation's error, the
same for all three when they cut the same edges) and the relative difference of area and
enclosed volume from VTK's contour.

    python tests/peers/bench_tets.py --isokit target/release/isokit --out docs/bench_tets.md

Also `isokit render` of each grid at 512 x 512 (ray casting through the cells), with no peer
in this run (VTK has no isosurface ray caster for unstructured grids).

Needs numpy and vtk. Never run in CI.
"""

import argparse
import json
import datetime
import os
import platform
import re
import statistics
import subprocess
import tempfile
import time

import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy


def torus(p):
    q = np.hypot(p[:, 0], p[:, 1]) - 0.6
    return np.hypot(q, p[:, 2]) - 0.25


def write_grid(n, path, field=torus, jitter=0.2):
    image = vtk.vtkImageData()
    image.SetDimensions(n, n, n)
    image.SetOrigin(-1, -1, -1)
    h = 2.0 / (n - 1)
    image.SetSpacing(h, h, h)
    tri = vtk.vtkDataSetTriangleFilter()
    tri.SetInputData(image)
    tri.Update()
    ug = tri.GetOutput()
    pts = vtk_to_numpy(ug.GetPoints().GetData()).astype(np.float64)
    if jitter > 0:
        pts += np.random.default_rng(2026).uniform(-jitter * h, jitter * h, pts.shape)
    ug.GetPoints().SetData(numpy_to_vtk(pts.astype(np.float32), deep=True))
    a = numpy_to_vtk(field(pts).astype(np.float32), deep=True)
    a.SetName("distance")
    ug.GetPointData().SetScalars(a)
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetInputData(ug)
    w.SetFileName(path)
    w.Write()
    return ug.GetNumberOfCells()


def mass(poly):
    tris = vtk.vtkTriangleFilter()
    tris.SetInputData(poly)
    tris.Update()
    m = vtk.vtkMassProperties()
    m.SetInputData(tris.GetOutput())
    m.Update()
    pts = vtk_to_numpy(tris.GetOutput().GetPoints().GetData()).astype(np.float64)
    return {
        "points": poly.GetNumberOfPoints(),
        "triangles": tris.GetOutput().GetNumberOfCells(),
        "area": m.GetSurfaceArea(),
        "volume": m.GetVolume(),
        "err": float(np.abs(torus(pts)).max()),
    }


def vtk_contour(path, linear):
    t = time.perf_counter()
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    read = time.perf_counter() - t
    f = vtk.vtkContour3DLinearGrid() if linear else vtk.vtkContourFilter()
    f.SetInputData(r.GetOutput())
    if linear:
        f.SetInputArrayToProcess(0, 0, 0, 0, "distance")
        f.SetMergePoints(True)
        f.SetSequentialProcessing(False)
    f.SetValue(0, 0.0)
    f.Update()
    return read, time.perf_counter() - t, f.GetOutput()


def isokit_mesh(exe, path, out):
    """isokit's own figure (reading and meshing, printed to 10 ms) and the whole command's
    wall time (process start and writing the PLY included)."""
    t = time.perf_counter()
    p = subprocess.run([exe, "mesh", path, "-o", out, "-q"], capture_output=True, text=True, check=True)
    wall = time.perf_counter() - t
    return float(re.search(r" in ([0-9.]+) s", p.stderr).group(1)), wall


def isokit_render(exe, path, out):
    """`isokit render` of the grid at 512²: the kd-tree and neighbour set-up and the
    tracing, as it reports them (`--stats`)."""
    p = subprocess.run(
        [exe, "render", path, "-o", out, "--width", "512", "--height", "512", "--stats", "-q"],
        capture_output=True, text=True, check=True,
    )
    return json.loads(p.stdout)


def read_ply_mesh(path):
    r = vtk.vtkPLYReader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isokit", default="target/release/isokit")
    ap.add_argument("--sizes", default="33,65,97")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out")
    a = ap.parse_args()
    rows, renders = [], []
    with tempfile.TemporaryDirectory() as d:
        for n in map(int, a.sizes.split(",")):
            path = os.path.join(d, f"torus{n}.vtu")
            cells = write_grid(n, path)
            out = os.path.join(d, "surface.ply")
            runs = [isokit_mesh(a.isokit, path, out) for _ in range(a.repeat)]
            ours = statistics.median(r[0] for r in runs)
            wall = statistics.median(r[1] for r in runs)
            mine = mass(read_ply_mesh(out))
            peers = {}
            for name, linear in [("vtkContour3DLinearGrid", True), ("vtkContourFilter", False)]:
                runs = [vtk_contour(path, linear) for _ in range(a.repeat)]
                peers[name] = (
                    statistics.median(r[0] for r in runs),
                    statistics.median(r[1] for r in runs),
                    mass(runs[0][2]),
                )
            ref = peers["vtkContourFilter"][2]
            st = [isokit_render(a.isokit, path, os.path.join(d, "r.png")) for _ in range(a.repeat)]
            renders.append(
                f"| {n}³ | {cells:,} | {statistics.median(s['prepare_seconds'] for s in st) * 1e3:.0f} "
                f"| {statistics.median(s['trace_seconds'] for s in st) * 1e3:.0f} "
                f"| {st[0]['hits']:,} | {st[0]['cells_per_ray']:.1f} |"
            )
            print(renders[-1], flush=True)
            for name, (read, total, m) in [("isokit mesh", (None, ours, mine))] + list(peers.items()):
                rows.append(
                    f"| {n}³ | {cells:,} | {name} | {total * 1e3:.0f} | "
                    + (f"{read * 1e3:.0f}" if read is not None else f"(command: {wall * 1e3:.0f})")
                    + f" | {m['points']:,} | {m['triangles']:,} | {m['err']:.2e} | "
                    f"{m['area'] / ref['area'] - 1:+.1e} | {m['volume'] / ref['volume'] - 1:+.1e} |"
                )
                print(rows[-1], flush=True)
    head = [
        f"Measured {datetime.datetime.now():%Y-%m-%d} on {platform.node()} ({os.cpu_count()} cores), "
        f"VTK {vtk.vtkVersion.GetVTKVersion()}, `python tests/peers/bench_tets.py`.",
        "",
        "| lattice | cells | contour | read + contour ms | of it read ms (isokit: whole command ms) | points | triangles "
        "| max \\|d\\| at vertices | area vs vtkContourFilter | volume vs vtkContourFilter |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    render_head = [
        "",
        "`isokit render` of the same grids at 512 x 512 (ray casting through the cells, CPU, "
        "the default camera framing the grid's box): no peer in this run.",
        "",
        "| lattice | cells | set-up ms (neighbours, boundary kd-tree, point gradients) | trace ms "
        "| surface pixels | cells per ray |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    text = "\n".join(head + rows + render_head + renders) + "\n"
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)
    print(text)


if __name__ == "__main__":
    main()
