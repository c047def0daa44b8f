"""Direct volume rendering: isokit's post-classification against its pre-integration over step
sizes (error against a fine-step reference, and time), and VTK's CPU volume ray caster
(`vtkFixedPointVolumeRayCastMapper`, from the `vtk` wheel on PyPI) on the same volume, transfer
function and camera, in one run.

The volume is the signed distance of `data/trefoil.ply` sampled by isokit (128 samples along the
longest side); the transfer function is isokit's `distance-shell` preset (a glowing shell one
to two voxels inside the surface: the thin feature that post-classification aliases). isokit
renders through its Python package (`Field.render_volume`, CPU twin); the reference is isokit
post-classified at 1/16 of a voxel. Errors are the mean and max absolute difference of the
premultiplied linear RGB over all pixels; times are isokit's own `seconds` (the ray casting)
and VTK's `Render()` wall time, each the median of a few frames after a warm-up.

VTK's opacity is per unit distance (`SetScalarOpacityUnitDistance`): the transfer function's
extinction sigma at each control point becomes the opacity `1 - exp(-sigma * u)` for u = one
voxel, which VTK then corrects for its step. VTK interpolates that opacity, not sigma, linearly
between the points, so the two models differ slightly inside each piece; VTK's colour is read
back in 8 bits.

    xvfb-run -a python tests/peers/bench_dvr.py --out docs/bench_dvr.md

Needs the isokit package (`pip install ./crates/isokit-python`), numpy and vtk, and an X
display for VTK's render window (xvfb-run). Never run in CI.
"""

import argparse
import datetime
import math
import pathlib
import platform
import statistics
import struct
import time
import zlib

import numpy as np

import isokit

ROOT = pathlib.Path(__file__).resolve().parents[2]


def render(field, tf, cam, size, cls, step, frames=3):
    secs, fr = [], None
    for _ in range(frames):
        fr = field.render_volume(tf, width=size, height=size, classification=cls, step=step,
                                 camera=cam, backend="cpu")
        secs.append(fr.stats["seconds"])
    g = fr.gbuffer
    return np.stack([g["R"], g["G"], g["B"]], axis=-1), statistics.median(secs)


def vtk_render(field, tf_points, cam, size, step, frames=3):
    import vtk
    from vtk.util import numpy_support

    nz, ny, nx = field.values.shape
    h = field.spacing
    img = vtk.vtkImageData()
    img.SetDimensions(nx, ny, nz)
    img.SetOrigin(*field.origin)
    img.SetSpacing(h, h, h)
    arr = numpy_support.numpy_to_vtk(np.ascontiguousarray(field.values).ravel(), deep=True,
                                     array_type=vtk.VTK_FLOAT)
    img.GetPointData().SetScalars(arr)
    ctf = vtk.vtkColorTransferFunction()
    otf = vtk.vtkPiecewiseFunction()
    for v, r, g, b, sigma in tf_points:
        ctf.AddRGBPoint(v, r, g, b)
        otf.AddPoint(v, 1.0 - math.exp(-sigma * h))
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetScalarOpacityUnitDistance(h)
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()
    mapper = vtk.vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(img)
    mapper.SetAutoAdjustSampleDistances(0)
    mapper.SetSampleDistance(step)
    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)
    ren = vtk.vtkRenderer()
    ren.AddVolume(volume)
    ren.SetBackground(0, 0, 0)
    win = vtk.vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.AddRenderer(ren)
    win.SetSize(size, size)
    c = ren.GetActiveCamera()
    c.SetPosition(*cam["eye"])
    c.SetFocalPoint(*cam["target"])
    c.SetViewUp(0, 1, 0)
    c.SetViewAngle(cam["fov"])
    ren.ResetCameraClippingRange()
    win.Render()
    secs = []
    for _ in range(frames):
        t = time.perf_counter()
        win.Render()
        secs.append(time.perf_counter() - t)
    w2i = vtk.vtkWindowToImageFilter()
    w2i.SetInput(win)
    w2i.SetInputBufferTypeToRGB()
    w2i.ReadFrontBufferOff()
    w2i.Update()
    out = numpy_support.vtk_to_numpy(w2i.GetOutput().GetPointData().GetScalars())
    rgb = out.reshape(size, size, 3)[::-1].astype(np.float32) / 255.0
    return rgb, statistics.median(secs)


def write_png(path, rgb):
    """Linear RGB in [0, 1] as an 8-bit sRGB PNG (no imaging library needed)."""
    x = np.clip(rgb, 0, 1)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    px = (srgb * 255 + 0.5).astype(np.uint8)
    h, w, _ = px.shape
    raw = b"".join(b"\x00" + px[y].tobytes() for y in range(h))

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    pathlib.Path(path).write_bytes(png)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--size", type=int, default=256, help="image side of the step table")
    ap.add_argument("--vtk-size", type=int, default=512, help="image side against VTK")
    ap.add_argument("--out", default=None)
    ap.add_argument("--images", default=None, help="folder for the 512^2 images (PNG)")
    a = ap.parse_args()

    t = time.perf_counter()
    field = isokit.mesh(str(ROOT / "data" / "trefoil.ply")).sample(res=a.res)
    sample_s = time.perf_counter() - t
    h = field.spacing
    tf_points = [[-2 * h, 0, 0, 0, 0], [-h, 1.0, 0.6, 0.2, 4.0 / h], [0, 0, 0, 0, 0]]
    tf = {"points": tf_points}
    cam = {"eye": [2.0, 1.5, 3.6], "target": [0, 0, 0], "fov": 40}

    ref, ref_s = render(field, tf, cam, a.size, "post", h / 16, frames=1)
    rows = []
    for mult in [2, 1, 0.5, 0.25]:
        for cls in ["post", "preintegrated"]:
            img, secs = render(field, tf, cam, a.size, cls, mult * h)
            d = np.abs(img - ref)
            rows.append((mult, cls, secs, d.mean(), d.max()))
            print(f"step {mult} voxel {cls:14s} {secs:6.3f} s  mean {d.mean():.2e}  max {d.max():.2e}")

    vtk_rows = []
    try:
        big_ref, _ = render(field, tf, cam, a.vtk_size, "post", h / 16, frames=1)
        for mult in [1, 0.5]:
            v_img, v_s = vtk_render(field, tf_points, cam, a.vtk_size, mult * h)
            i_post, i_post_s = render(field, tf, cam, a.vtk_size, "post", mult * h)
            i_pre, i_pre_s = render(field, tf, cam, a.vtk_size, "preintegrated", mult * h)
            err = lambda x: float(np.abs(x - big_ref).mean())
            if a.images:
                d = pathlib.Path(a.images)
                d.mkdir(parents=True, exist_ok=True)
                for name, im in [("vtk", v_img), ("post", i_post), ("pre", i_pre),
                                 ("reference", big_ref)]:
                    write_png(d / f"dvr_{name}_step{mult}.png", im)
            vtk_rows.append((mult, v_s, err(v_img), i_post_s, err(i_post), i_pre_s, err(i_pre),
                             float(np.abs(v_img - i_post).mean())))
            print(f"{a.vtk_size}^2 step {mult}: VTK {v_s:.3f} s err {err(v_img):.2e}; isokit post "
                  f"{i_post_s:.3f} s err {err(i_post):.2e}; pre {i_pre_s:.3f} s err {err(i_pre):.2e}")
    except Exception as e:  # no vtk, no display
        print(f"VTK not run: {e}")
        vtk_rows = None

    lines = [
        f"Machine: {platform.processor() or platform.machine()}, {platform.system()}; "
        f"Python {platform.python_version()}. Date: {datetime.date.today()}. Command: "
        f"`xvfb-run -a python tests/peers/bench_dvr.py --out {a.out}`. Volume: the trefoil's "
        f"distance, {' x '.join(map(str, field.dims))} samples (sampled in {sample_s:.1f} s), "
        f"transfer function `distance-shell`; reference: isokit post-classified at 1/16 voxel "
        f"({ref_s:.2f} s at {a.size}^2). Errors: |premultiplied linear RGB - reference| over all "
        f"pixels.",
        "",
        f"| step (voxels) | classification | seconds ({a.size}^2) | mean error | max error |",
        "| ---: | --- | ---: | ---: | ---: |",
    ]
    for mult, cls, secs, mean, mx in rows:
        lines.append(f"| {mult} | {cls} | {secs:.3f} | {mean:.2e} | {mx:.2e} |")
    if vtk_rows:
        lines += [
            "",
            f"Against VTK 9 `vtkFixedPointVolumeRayCastMapper` at {a.vtk_size}^2 (median of 3 "
            "frames after a warm-up; VTK's 8-bit read-back):",
            "",
            "| step (voxels) | VTK s | VTK error | isokit post s | post error | isokit pre s "
            "| pre error | mean \\|VTK - isokit post\\| |",
            "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
        ]
        for r in vtk_rows:
            lines.append("| {} | {:.3f} | {:.2e} | {:.3f} | {:.2e} | {:.3f} | {:.2e} | {:.2e} |"
                         .format(*r))
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        pathlib.Path(a.out).write_text(text)


if __name__ == "__main__":
    main()
