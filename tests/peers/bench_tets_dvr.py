"""Direct volume rendering of tetrahedral grids: `isokit render grid.vtu --mode dvr` (rays
through the cells, each cell's segment one entry of the 3D pre-integration table, CPU)
against VTK's projected tetrahedra (`vtkProjectedTetrahedraMapper`, offscreen through EGL on
Mesa's llvmpipe here: OpenGL in software on the same CPU cores), in one run: time and
accuracy, 512 x 512, the same camera.

Grids: the tetrahedralized N x N x N lattices of `bench_tets.py` (5 tetrahedra per cube).
- Time: the torus distance with its points jittered (as `bench_tets.py`), a transfer
  function that is clear outside the torus and ramps up inside. isokit: the command's own
  figures (`--stats`: set-up = neighbours, boundary kd-tree, gradients; render = the table
  and the rays) and its whole wall time; VTK: reading, the first frame (sorting and
  projecting the cells), a second frame after the camera moved by 2 degrees.
- Accuracy: a linear field `0.6 x - 0.35 y + 0.25 z + 0.1` on the unjittered lattice (the
  grid is the box [-1, 1]^3 and the value is linear along each ray through it), white
  emission: each pixel's exact opacity is `1 - exp(-L / (v1 - v0) * (S(v1) - S(v0)))`, with
  `S` the integral of the extinction over values. Both renderers' PNGs are 8 bits (isokit's
  sRGB-encoded, decoded here; VTK's linear): mean and 99th percentile of |opacity - exact|
  over the pixels whose rays cross the box.
VTK's opacity is per unit distance `u`; measured here (a constant opacity `o` through a
lattice of depth L gives 1 - exp(-o L / u) rather than 1 - (1 - o)^(L / u)), its projected
tetrahedra take `o / u` as the extinction, so VTK is given `o = sigma * u` on 256 values with
`u = 1 / max sigma`, and both see one transfer function.

    python tests/peers/bench_tets_dvr.py --isokit target/release/isokit --out docs/bench_tets_dvr.md

Needs numpy and vtk. Never run in CI.
"""

import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_tets import torus, write_grid  # noqa: E402

SIZE = 512
EYE, TARGET, UP, FOV = (2.8, -2.2, 1.9), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 50.0
COEF, BIAS = np.array([0.6, -0.35, 0.25]), 0.1


def linear(p):
    return p @ COEF + BIAS


# Extinction control points (value, sigma) of each case; emission white.
TF_TORUS = [(-0.3, 6.0), (-0.05, 6.0), (0.0, 2.0), (0.02, 0.0), (1.2, 0.0)]
TF_LINEAR = [(-1.2, 0.3), (-0.2, 2.5), (0.3, 0.6), (1.3, 1.8)]


def tf_json(points, path):
    with open(path, "w") as f:
        json.dump({"points": [[v, 1, 1, 1, s] for v, s in points]}, f)


def sigma_of(points, v):
    xs, ys = zip(*points)
    return np.interp(v, xs, ys)


def isokit_dvr(exe, grid, tf, out):
    t = time.perf_counter()
    p = subprocess.run(
        [exe, "render", grid, "--mode", "dvr", "--tf", tf, "-o", out, "--stats", "-q",
         "--width", str(SIZE), "--height", str(SIZE), "--eye", ",".join(map(str, EYE)),
         "--target", ",".join(map(str, TARGET)), "--up", ",".join(map(str, UP)),
         "--fov", str(FOV)],
        capture_output=True, text=True, check=True,
    )
    s = json.loads(p.stdout)
    s["wall"] = time.perf_counter() - t
    return s


def read_png(path):
    r = vtk.vtkPNGReader()
    r.SetFileName(path)
    r.Update()
    img = r.GetOutput()
    w, h, _ = img.GetDimensions()
    a = vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)
    return a[::-1].astype(np.float64) / 255.0  # rows from the top


def srgb_to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def vtk_dvr(grid, points, out):
    """VTK's projected tetrahedra: times of reading, the first frame and a moved frame; the
    second frame's camera is put back and a third written as a PNG (linear RGB)."""
    t = time.perf_counter()
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(grid)
    r.Update()
    ug = r.GetOutput()
    ug.GetPointData().SetActiveScalars("distance")
    read = time.perf_counter() - t
    rw = vtk.vtkRenderWindow()
    rw.SetOffScreenRendering(1)
    rw.SetSize(SIZE, SIZE)
    ren = vtk.vtkRenderer()
    ren.SetBackground(0, 0, 0)
    rw.AddRenderer(ren)
    m = vtk.vtkProjectedTetrahedraMapper()
    m.SetInputData(ug)
    prop = vtk.vtkVolumeProperty()
    otf = vtk.vtkPiecewiseFunction()
    lo, hi = points[0][0], points[-1][0]
    unit = 1.0 / max(s for _, s in points)
    for v in np.linspace(lo, hi, 256):
        otf.AddPoint(float(v), float(sigma_of(points, v) * unit))
    ctf = vtk.vtkColorTransferFunction()
    ctf.AddRGBPoint(lo, 1, 1, 1)
    ctf.AddRGBPoint(hi, 1, 1, 1)
    prop.SetScalarOpacity(otf)
    prop.SetColor(ctf)
    prop.SetScalarOpacityUnitDistance(unit)
    prop.SetInterpolationTypeToLinear()
    vol = vtk.vtkVolume()
    vol.SetMapper(m)
    vol.SetProperty(prop)
    ren.AddVolume(vol)
    cam = ren.GetActiveCamera()
    cam.SetPosition(*EYE)
    cam.SetFocalPoint(*TARGET)
    cam.SetViewUp(*UP)
    cam.SetViewAngle(FOV)
    ren.ResetCameraClippingRange()
    t = time.perf_counter()
    rw.Render()
    first = time.perf_counter() - t
    cam.Azimuth(2.0)
    ren.ResetCameraClippingRange()
    t = time.perf_counter()
    rw.Render()
    moved = time.perf_counter() - t
    cam.Azimuth(-2.0)
    ren.ResetCameraClippingRange()
    rw.Render()
    w2i = vtk.vtkWindowToImageFilter()
    w2i.SetInput(rw)
    w2i.ReadFrontBufferOff()
    w2i.Update()
    pw = vtk.vtkPNGWriter()
    pw.SetFileName(out)
    pw.SetInputConnection(w2i.GetOutputPort())
    pw.Write()
    return read, first, moved


def exact_opacity(points):
    """Per pixel: the exact opacity of the linear field's ray through [-1, 1]^3 and whether
    the ray crosses the box (by more than 1e-3)."""
    eye, target, up = map(np.array, (EYE, TARGET, UP))
    f = target - eye
    f /= np.linalg.norm(f)
    right = np.cross(f, up)
    right /= np.linalg.norm(right)
    u = np.cross(right, f)
    t = np.tan(np.radians(FOV) / 2)
    c = (np.arange(SIZE) + 0.5) / SIZE * 2 - 1
    sx, sy = np.meshgrid(c * t, -c * t)
    d = f + sx[..., None] * right + sy[..., None] * u
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    with np.errstate(divide="ignore"):
        inv = 1.0 / d
    a, b = (-1 - eye) * inv, (1 - eye) * inv
    t0, t1 = np.minimum(a, b).max(-1), np.maximum(a, b).min(-1)
    crosses = t1 > t0 + 1e-3
    v0 = linear(eye + t0[..., None] * d)
    v1 = linear(eye + t1[..., None] * d)
    # S(v): the integral of the piecewise-linear extinction, on a fine table.
    vs = np.linspace(points[0][0] - 1, points[-1][0] + 1, 400001)
    sig = sigma_of(points, vs)
    S = np.concatenate([[0], np.cumsum(0.5 * (sig[1:] + sig[:-1]) * np.diff(vs))])
    L = np.where(crosses, t1 - t0, 0)
    dv = v1 - v0
    small = np.abs(dv) < 1e-9
    depth = np.where(small, sigma_of(points, v0) * L,
                     (np.interp(v1, vs, S) - np.interp(v0, vs, S)) / np.where(small, 1, dv) * L)
    return 1 - np.exp(-depth), crosses


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isokit", default="target/release/isokit")
    ap.add_argument("--sizes", default="33,65,97")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out")
    a = ap.parse_args()
    times, acc = [], []
    with tempfile.TemporaryDirectory() as d:
        tf_t, tf_l = os.path.join(d, "torus.json"), os.path.join(d, "linear.json")
        tf_json(TF_TORUS, tf_t)
        tf_json(TF_LINEAR, tf_l)
        exact, crosses = exact_opacity(TF_LINEAR)
        for n in map(int, a.sizes.split(",")):
            path = os.path.join(d, f"torus{n}.vtu")
            cells = write_grid(n, path)
            png = os.path.join(d, "o.png")
            st = [isokit_dvr(a.isokit, path, tf_t, png) for _ in range(a.repeat)]
            vt = [vtk_dvr(path, TF_TORUS, os.path.join(d, "v.png")) for _ in range(a.repeat)]
            med = lambda xs: statistics.median(xs) * 1e3  # noqa: E731
            times.append(
                f"| {n}³ | {cells:,} | {med(s['prepare_seconds'] for s in st):.0f} "
                f"| {med(s['seconds'] for s in st):.0f} | {med(s['wall'] for s in st):.0f} "
                f"| {st[0]['segments_per_ray']:.1f} | {med(r[0] for r in vt):.0f} "
                f"| {med(r[1] for r in vt):.0f} | {med(r[2] for r in vt):.0f} |"
            )
            print(times[-1], flush=True)
            lin = os.path.join(d, f"linear{n}.vtu")
            write_grid(n, lin, field=linear, jitter=0.0)
            isokit_dvr(a.isokit, lin, tf_l, png)
            ours = srgb_to_linear(read_png(png)[..., 0])
            vtk_dvr(lin, TF_LINEAR, os.path.join(d, "v.png"))
            theirs = read_png(os.path.join(d, "v.png"))[..., 0]
            errs = []
            for img in (ours, theirs):
                e = np.abs(img - exact)[crosses]
                errs += [e.mean(), np.percentile(e, 99)]
            acc.append(f"| {n}³ | {cells:,} | " + " | ".join(f"{x:.4f}" for x in errs) + " |")
            print(acc[-1], flush=True)
    text = "\n".join([
        f"Measured {datetime.datetime.now():%Y-%m-%d} on {platform.node()} ({os.cpu_count()} cores), "
        f"VTK {vtk.vtkVersion.GetVTKVersion()} ({vtk.vtkRenderWindow().GetClassName()}), "
        "`python tests/peers/bench_tets_dvr.py`, medians of "
        f"{a.repeat} runs, {SIZE} x {SIZE}.",
        "",
        "| lattice | cells | isokit set-up ms | isokit render ms (table + rays) | isokit command ms "
        "| segments per ray | VTK read ms | VTK first frame ms | VTK moved frame ms |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
        *times,
        "",
        "Opacity against the exact integral (linear field, unjittered lattice):",
        "",
        "| lattice | cells | isokit mean | isokit p99 | VTK mean | VTK p99 |",
        "| --- | --- | --- | --- | --- | --- |",
        *acc,
    ]) + "\n"
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)
    print(text)


if __name__ == "__main__":
    main()
