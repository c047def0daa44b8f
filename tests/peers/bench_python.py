"""The Python package side by side with the peers, in one process, same run.

1. Signed distances of 1M points (half near the surface, half uniform in the padded
   bounds): `isokit.signed_distance` against libigl, Open3D's RaycastingScene, pysdf and
   point-cloud-utils (those that import), and against `isokit query` on the same files
   (its wall time, and that time minus the process start: the wall time of the same
   command on one point).
2. A modeling script that meshes a part at 256 samples along its longest side: isokit
   against fogleman's `sdf` (the maintained fork `sdfcad`; module `sdf`) and manifold3d's
   exact booleans, with the volume and the symmetric Hausdorff distance of each mesh to
   manifold3d's.

    pip install ./crates/isokit-python sdfcad point-cloud-utils
    pip install -r tests/peers/requirements.txt
    python tests/peers/bench_python.py --isokit target/release/isokit --mesh data/external/bunny00.off

Prints a markdown table (and writes it with --out). The machine may be shared: compare
ratios within one run, not figures across runs.
"""

import argparse
import os
import pathlib
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from bench_query import icosphere, query_points, read_off, write_ply  # noqa: E402

import isokit  # noqa: E402


def timed(fn, repeat=1):
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return out, best


def sdf_rows(name, V, F, n, exe, rng, tmp, repeat=1, peers=True):
    V = V.astype(np.float32).astype(np.float64)  # every tool sees the same vertices
    diag = np.linalg.norm(V.max(0) - V.min(0))
    P = query_points(V, F, n, rng)
    rows = []
    (ref, face, C), t = timed(lambda: isokit.signed_distance(V, F, P, progress=False), repeat)
    rows.append(("isokit.signed_distance", t, 0.0, 0,
                 "exact, f64; build included" + (f"; best of {repeat}" if repeat > 1 else "")))

    def add(tool, secs, d, note):
        far = np.abs(ref) > 1e-4 * diag
        rows.append((tool, secs, float(np.abs(d - ref).max()),
                     int(np.count_nonzero(np.sign(d[far]) != np.sign(ref[far]))), note))

    try:
        if not peers:
            raise ImportError("peers skipped (--isokit-only)")
        import igl
        (s, _, _, _), t = timed(lambda: igl.signed_distance(
            P, V, F, sign_type=igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL))
        add("libigl signed_distance (pseudonormal)", t, s, "exact, f64; AABB build included")
    except ImportError as e:
        print(f"libigl missing: {e}", file=sys.stderr)
    try:
        if not peers:
            raise ImportError("peers skipped (--isokit-only)")
        import open3d as o3d

        def o3d_run():
            scene = o3d.t.geometry.RaycastingScene()
            scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)),
                                o3d.core.Tensor(F.astype(np.uint32)))
            return scene.compute_signed_distance(o3d.core.Tensor(P.astype(np.float32))).numpy()
        d, t = timed(o3d_run)
        add("Open3D RaycastingScene", t, d.astype(np.float64), "f32; sign by ray parity; BVH build included")
    except ImportError as e:
        print(f"Open3D missing: {e}", file=sys.stderr)
    try:
        if not peers:
            raise ImportError("peers skipped (--isokit-only)")
        from pysdf import SDF

        def pysdf_run():
            return -SDF(V.astype(np.float32), F.astype(np.uint32))(P.astype(np.float32))
        d, t = timed(pysdf_run)
        add("pysdf", t, d.astype(np.float64), "f32; positive inside, negated; build included")
    except ImportError as e:
        print(f"pysdf missing: {e}", file=sys.stderr)
    try:
        if not peers:
            raise ImportError("peers skipped (--isokit-only)")
        import point_cloud_utils as pcu
        (d, _, _), t = timed(lambda: pcu.signed_distance_to_mesh(P, V, F.astype(np.int32)))
        add("point-cloud-utils signed_distance_to_mesh", t, d, "f64")
    except ImportError as e:
        print(f"point-cloud-utils missing: {e}", file=sys.stderr)
    if exe:
        mesh, pts, out, one = tmp / "m.ply", tmp / "p.npy", tmp / "d.npy", tmp / "one.npy"
        write_ply(mesh, V, F)
        np.save(pts, P.astype(np.float32))
        np.save(one, P[:1].astype(np.float32))
        cmd = lambda p: subprocess.run([exe, "query", mesh, "--points", p, "-o", out],
                                       check=True, capture_output=True)
        _, start = timed(lambda: cmd(one), repeat=3)
        _, wall = timed(lambda: cmd(pts), repeat)
        d = np.load(out).astype(np.float64)
        best = f"; best of {repeat}" if repeat > 1 else ""
        add("isokit query (command), wall", wall, d, "f32 points from .npy; file I/O included" + best)
        add("isokit query minus process start", wall - start, d,
            f"process start + mesh read + tree build on 1 point: {start:.2f} s")
    return name, len(F), len(P), rows


def part_isokit():
    plate = isokit.box(half=(1.0, 0.15, 0.7))
    bosses = isokit.union(*[isokit.cylinder(a=(x, 0, 0), b=(x, 0.6, 0), radius=0.3) for x in (-0.5, 0.5)])
    holes = isokit.union(*[isokit.cylinder(a=(x, -1, z), b=(x, 1, z), radius=0.1)
                           for x in (-0.8, 0.8) for z in (-0.45, 0.45)])
    bores = isokit.union(*[isokit.cylinder(a=(x, -1, 0), b=(x, 1, 0), radius=0.15) for x in (-0.5, 0.5)])
    return (plate | bosses) - holes - bores


def part_sdf():
    import sdf
    plate = sdf.box((2.0, 0.3, 1.4))
    def cyl(a, b, r):
        return sdf.capped_cylinder(np.array(a, float), np.array(b, float), r)
    bosses = cyl((-0.5, 0, 0), (-0.5, 0.6, 0), 0.3) | cyl((0.5, 0, 0), (0.5, 0.6, 0), 0.3)
    holes = None
    for x in (-0.8, 0.8):
        for z in (-0.45, 0.45):
            h = cyl((x, -1, z), (x, 1, z), 0.1)
            holes = h if holes is None else holes | h
    bores = cyl((-0.5, -1, 0), (-0.5, 1, 0), 0.15) | cyl((0.5, -1, 0), (0.5, 1, 0), 0.15)
    return (plate | bosses) - holes - bores


def part_manifold(seg=512):
    import manifold3d as mf
    plate = mf.Manifold.cube([2.0, 0.3, 1.4], center=True)
    up = lambda h, r: mf.Manifold.cylinder(h, r, r, seg).rotate([-90, 0, 0])
    through = lambda r: mf.Manifold.cylinder(2.0, r, r, seg, center=True).rotate([-90, 0, 0])
    m = plate + up(0.6, 0.3).translate([-0.5, 0, 0]) + up(0.6, 0.3).translate([0.5, 0, 0])
    for x in (-0.8, 0.8):
        for z in (-0.45, 0.45):
            m -= through(0.1).translate([x, 0, z])
    for x in (-0.5, 0.5):
        m -= through(0.15).translate([x, 0, 0])
    mesh = m.to_mesh()
    return np.asarray(mesh.vert_properties)[:, :3].astype(np.float64), np.asarray(mesh.tri_verts).astype(np.int64)


def volume(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def surface_samples(V, F, n, rng):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    t = rng.choice(len(F), size=n, p=area / area.sum())
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    return np.vstack([V, a[t] + u[:, None] * (b[t] - a[t]) + v[:, None] * (c[t] - a[t])])


def hausdorff(A, B, rng):
    """Symmetric Hausdorff distance by exact point-to-mesh distances (isokit's, checked
    against libigl in the tests) from dense surface samples of each mesh."""
    (VA, FA), (VB, FB) = A, B
    dab = np.abs(isokit.signed_distance(VB, FB, surface_samples(VA, FA, 200_000, rng), sign="unsigned", progress=False)[0])
    dba = np.abs(isokit.signed_distance(VA, FA, surface_samples(VB, FB, 200_000, rng), sign="unsigned", progress=False)[0])
    return float(max(dab.max(), dba.max()))


def modeling_rows(res, rng):
    rows = []
    ref, t_ref = timed(part_manifold)
    v_ref = volume(*ref)
    shape = part_isokit()
    mesh, t = timed(lambda: shape.mesh(res=res, progress=False))
    V, F = mesh
    h = (np.asarray(shape.bounds[1]) - np.asarray(shape.bounds[0])).max() / (res - 1)
    rows.append(("isokit Shape.mesh (lazy band, marching cubes)", t, len(F), volume(V, F) / v_ref - 1,
                 hausdorff((V, F), ref, rng), f"res {res}; voxel {h:.4f}; dense fraction "
                 f"{mesh.stats['sampling']['dense_fraction']:.3f}"))
    dense, t = timed(lambda: shape.mesh(res=res, dense=True, progress=False))
    rows.append(("isokit Shape.mesh(dense=True)", t, len(dense[1]), volume(*dense) / v_ref - 1,
                 hausdorff(tuple(dense), ref, rng), "every sample evaluated (the baseline)"))
    try:
        import sdf as fsdf
        f = part_sdf()
        lo, hi = np.array(shape.bounds[0]) - 2 * h, np.array(shape.bounds[1]) + 2 * h
        step = (hi - lo).max() / (res - 1)
        tris, t = timed(lambda: f.generate(step=step, bounds=(lo, hi), verbose=False))
        P = np.asarray(tris, dtype=np.float64)
        Vs, inv = np.unique(P.round(9), axis=0, return_inverse=True)
        Fs = inv.reshape(-1, 3)
        from importlib.metadata import version
        rows.append((f"sdfcad {version('sdfcad')} generate (marching cubes)",
                     t, len(Fs), volume(Vs, Fs) / v_ref - 1, hausdorff((Vs, Fs), ref, rng),
                     f"step {step:.4f} over the same bounds; {os.cpu_count()} workers"))
    except ImportError as e:
        print(f"sdfcad missing: {e}", file=sys.stderr)
    rows.append(("manifold3d (exact booleans, 512-gon cylinders)", t_ref, len(ref[1]), 0.0, 0.0, "the reference"))
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isokit", default="target/release/isokit", help="the command, for `isokit query`")
    ap.add_argument("--mesh", action="append", default=[], help="OFF meshes besides the icosphere")
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--out", default=None)
    ap.add_argument("--repeat", type=int, default=1, help="best of N for isokit's two rows")
    ap.add_argument("--isokit-only", action="store_true", help="only isokit.signed_distance "
                    "against `isokit query` (no peers, no modeling script)")
    a = ap.parse_args()
    rng = np.random.default_rng(2026)
    tmp = pathlib.Path(tempfile.mkdtemp())
    exe = a.isokit if pathlib.Path(a.isokit).exists() else None
    meshes = [("icosphere L7", *icosphere(7))] + [(pathlib.Path(p).stem, *read_off(p)) for p in a.mesh]
    lines = [f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
             f"Python {platform.python_version()}, numpy {np.__version__}, isokit {isokit.__version__}; "
             f"{time.strftime('%Y-%m-%d')}.", "",
             f"### Signed distance, {a.points:,} points, in-process", "",
             "| mesh | triangles | tool | seconds | points/s | time ÷ isokit's | max \\|d − isokit\\| | sign mismatches | notes |",
             "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | --- |"]
    for name, V, F in meshes:
        name, nf, n, rows = sdf_rows(name, V, F.astype(np.int64), a.points, exe, rng, tmp,
                                     a.repeat, not a.isokit_only)
        ours = rows[0][1]
        for tool, secs, err, signs, note in rows:
            lines.append(f"| {name} | {nf:,} | {tool} | {secs:.3f} | {n / secs:,.0f} | "
                         f"{secs / ours:.2f} | {err:.1e} | {signs} | {note} |")
            print(lines[-1], file=sys.stderr)
    if a.isokit_only:
        text = "\n".join(lines) + "\n"
        print(text)
        if a.out:
            pathlib.Path(a.out).write_text(text)
        return
    lines += ["", f"### Modeling script: a bracket (plate, two bosses, six holes) meshed at {a.res}", "",
              "| tool | seconds | triangles | volume vs manifold3d | Hausdorff to manifold3d | notes |",
              "| --- | ---: | ---: | ---: | ---: | --- |"]
    for tool, secs, nt, dv, hd, note in modeling_rows(a.res, rng):
        lines.append(f"| {tool} | {secs:.2f} | {nt:,} | {dv:+.2e} | {hd:.4f} | {note} |")
        print(lines[-1], file=sys.stderr)
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        pathlib.Path(a.out).write_text(text)


if __name__ == "__main__":
    main()
