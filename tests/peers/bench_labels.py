"""Label volumes meshed into the surface between their regions: `isokit mesh LABELS.nrrd
--labels` (surface nets on labels) against VTK's `vtkSurfaceNets3D` (from the `vtk` wheel on
PyPI) on the same label volume, in one run: time, counts and the area per region pair.

The volume: an N^3 lattice over [-1, 1]^3 holding four regions: 1 a ball of radius 0.45
at the centre, 2 the rest of x < 0.1, 3 the rest of x >= 0.1 with y < 0, 4 the rest of
x >= 0.1 with y >= 0, inside the ball of radius 0.95 (0 outside it): a T-junction of 2, 3
and 4, junction curves where they meet the ball and the outside. Without smoothing both
place each vertex at its cell's centre, so the meshes must agree in triangle count and in
area per pair to rounding; with smoothing each uses its own relaxation (isokit: 16 passes
of 0.5, kept in the cell; VTK: its defaults), compared by time, and by area against the
exact areas of the smooth interfaces for the ball (4 pi 0.45^2).

    python tests/peers/bench_labels.py --isokit target/release/isokit --out docs/bench_labels.md

Needs numpy and vtk. Never run in CI.
"""

import argparse
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


def labels(n):
    c = np.linspace(-1, 1, n)
    z, y, x = np.meshgrid(c, c, c, indexing="ij")  # C order: x fastest
    r = np.sqrt(x * x + y * y + z * z)
    lab = np.where(x < 0.1, 2, np.where(y < 0, 3, 4)).astype(np.int32)
    lab[r < 0.45] = 1
    lab[r >= 0.95] = 0
    return lab


def write_nrrd(lab, path):
    n = lab.shape[0]
    h = 2.0 / (n - 1)
    with open(path, "wb") as f:
        f.write(
            (
                "NRRD0004\ntype: int\ndimension: 3\n"
                f"sizes: {n} {n} {n}\nspace dimension: 3\n"
                f"space directions: ({h},0,0) (0,{h},0) (0,0,{h})\nspace origin: (-1,-1,-1)\n"
                "endian: little\nencoding: raw\n\n"
            ).encode()
        )
        f.write(lab.astype("<i4").tobytes())


def read_ply_regions(path):
    """isokit's binary PLY: vertices (x y z nx ny nz float), faces (uchar 3, 3 int, int
    region_a, int region_b): positions, triangles, region pairs."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + 11
    head = data[:end].decode()
    nv = int(re.search(r"element vertex (\d+)", head).group(1))
    nf = int(re.search(r"element face (\d+)", head).group(1))
    assert "property int region_a\nproperty int region_b" in head
    v = np.frombuffer(data, "<f4", nv * 6, end).reshape(nv, 6)[:, :3].astype(np.float64)
    rec = np.dtype([("n", "u1"), ("i", "<i4", 3), ("a", "<i4"), ("b", "<i4")])
    f = np.frombuffer(data, rec, nf, end + 24 * nv)
    return v, f["i"], f["a"], f["b"]


def pair_areas(v, tris, a, b):
    """Area per (a, b) pair of triangles."""
    p = v[tris]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    out = {}
    for key in set(zip(a.tolist(), b.tolist())):
        m = (a == key[0]) & (b == key[1])
        out[key] = float(area[m].sum())
    return out


def isokit_labels(exe, path, out, smooth):
    t = time.perf_counter()
    p = subprocess.run(
        [exe, "mesh", path, "--labels", "--smooth", str(smooth), "-o", out, "-q"],
        capture_output=True, text=True, check=True,
    )
    wall = time.perf_counter() - t
    return float(re.search(r" in ([0-9.]+) s", p.stderr).group(1)), wall


def vtk_nets(lab, smooth):
    n = lab.shape[0]
    img = vtk.vtkImageData()
    img.SetDimensions(n, n, n)
    img.SetOrigin(-1, -1, -1)
    h = 2.0 / (n - 1)
    img.SetSpacing(h, h, h)
    arr = numpy_to_vtk(lab.ravel(), deep=True)
    arr.SetName("labels")
    img.GetPointData().SetScalars(arr)
    f = vtk.vtkSurfaceNets3D()
    f.SetInputData(img)
    for k in range(1, 5):
        f.SetValue(k - 1, k)
    f.SetBackgroundLabel(0)
    f.SetOutputMeshTypeToTriangles()
    if not smooth:
        f.SmoothingOff()
    t = time.perf_counter()
    f.Update()
    secs = time.perf_counter() - t
    out = f.GetOutput()
    bl = vtk_to_numpy(out.GetCellData().GetArray("BoundaryLabels"))
    lo, hi = np.minimum(bl[:, 0], bl[:, 1]), np.maximum(bl[:, 0], bl[:, 1])
    v = vtk_to_numpy(out.GetPoints().GetData()).astype(np.float64)
    conn = vtk_to_numpy(out.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    return secs, len(conn), pair_areas(v, conn, lo.astype(int), hi.astype(int))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isokit", default="target/release/isokit")
    ap.add_argument("--sizes", default="64,128,256")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out")
    a = ap.parse_args()
    rows, area_rows = [], []
    ball = 4 * np.pi * 0.45**2
    with tempfile.TemporaryDirectory() as d:
        for n in map(int, a.sizes.split(",")):
            lab = labels(n)
            path = os.path.join(d, f"labels{n}.nrrd")
            write_nrrd(lab, path)
            ply = os.path.join(d, "out.ply")
            for smooth in (0, 16):
                runs = [isokit_labels(a.isokit, path, ply, smooth) for _ in range(a.repeat)]
                v, tris, ra, rb = read_ply_regions(ply)
                ours = pair_areas(v, tris, ra, rb)
                vt = [vtk_nets(lab, smooth > 0) for _ in range(a.repeat)]
                theirs = vt[0][2]
                worst = max(abs(ours.get(p, 0) / theirs[p] - 1) for p in theirs)
                rows.append(
                    f"| {n}³ | {'16 passes' if smooth else 'off'} "
                    f"| {statistics.median(r[0] for r in runs) * 1e3:.0f} "
                    f"(command {statistics.median(r[1] for r in runs) * 1e3:.0f}) "
                    f"| {statistics.median(r[0] for r in vt) * 1e3:.0f} "
                    f"| {len(tris):,} | {vt[0][1]:,} "
                    f"| {len(ours)} / {len(theirs)} | {worst:.1e} |"
                )
                print(rows[-1], flush=True)
                area_rows.append(
                    f"| {n}³ | {'16 passes' if smooth else 'off'} "
                    f"| {sum(x for p, x in ours.items() if 1 in p) / ball - 1:+.4f} "
                    f"| {sum(x for p, x in theirs.items() if 1 in p) / ball - 1:+.4f} |"
                )
    text = "\n".join([
        f"Measured {datetime.datetime.now():%Y-%m-%d} on {platform.node()} ({os.cpu_count()} cores), "
        f"VTK {vtk.vtkVersion.GetVTKVersion()}, `python tests/peers/bench_labels.py`, medians of {a.repeat} runs.",
        "",
        "| lattice | smoothing | isokit ms | vtkSurfaceNets3D ms | isokit triangles | VTK triangles "
        "| pairs isokit / VTK | largest relative area difference per pair |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
        *rows,
        "",
        "The ball's surface (every pair with region 1) against 4 pi 0.45^2:",
        "",
        "| lattice | smoothing | isokit area error | VTK area error |",
        "| --- | --- | --- | --- |",
        *area_rows,
    ]) + "\n"
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)
    print(text)


if __name__ == "__main__":
    main()
