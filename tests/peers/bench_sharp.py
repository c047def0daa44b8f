"""Sharp meshing: isokit's marching cubes and dual contouring against manifold3d.

Three CSG parts with sharp edges (a box minus a cylinder; two boxes, one rotated 30° about
(1, 2, 3), whose edges run at general angles to the lattice; a torus mesh minus a cylinder
mesh), each meshed by

- `isokit scene PART -o out.obj --mesher mc|dual --res N` (whole command, wall time), and
  adaptive dual contouring `--mesher dual --error E` with E a fraction of the voxel
  (`--errors`, default 0.02 and 0.1);
- manifold3d's `level_set` on the same signed distance (a Python callable of numpy, the
  body-centred-cubic marching tetrahedra of manifold3d, edge length = isokit's voxel) — for
  the analytic parts only;
- manifold3d's exact booleans: of the primitives (analytic parts, 1024-segment cylinder, the
  reference) and of the same triangles isokit reads (mesh part).

Errors are the symmetric Hausdorff distance (libigl point-to-mesh distances from area
samples of both meshes) to the reference and the relative volume error. Run:

    cargo build --release --bin isokit
    python tests/peers/bench_sharp.py --isokit target/release/isokit --out docs/bench_sharp.md \
        --plot docs/bench_sharp.png

`--plot` (needs matplotlib, not a test dependency) draws the trade: Hausdorff distance
against seconds and against triangles, one panel per part.
"""

import argparse
import importlib.metadata
import json
import math
import os
import pathlib
import platform
import sys
import tempfile
import time

import manifold3d as mf
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from bench_scene import (  # noqa: E402  (the shared helpers of the scene benchmark)
    ROOT, csg_operands, cylinder, hausdorff, mf_mesh, read_obj, run_isokit, torus, volume)

BOX_HALF = [0.6, 0.4, 0.5]
BOX_C = [0.011, 0.0, -0.013]
CYL_R = 0.25
CYL_X, CYL_Z = 0.05, 0.02


def box_minus_cylinder_scene():
    return {"shape": {"difference": [
        {"box": {"half": BOX_HALF, "center": BOX_C}},
        {"cylinder": {"a": [CYL_X, -1, CYL_Z], "b": [CYL_X, 1, CYL_Z], "radius": CYL_R}}]}}


def box_minus_cylinder_sdf(x, y, z):
    """The same part's signed distance, positive inside (manifold3d's convention); plain
    floats (manifold3d calls it once per grid point)."""
    qx = abs(x - BOX_C[0]) - BOX_HALF[0]
    qy = abs(y - BOX_C[1]) - BOX_HALF[1]
    qz = abs(z - BOX_C[2]) - BOX_HALF[2]
    box = math.hypot(max(qx, 0.0), max(qy, 0.0), max(qz, 0.0)) + min(max(qx, qy, qz), 0.0)
    # The capped cylinder of the scene (caps at y = ±1, beyond the box).
    r = math.hypot(x - CYL_X, z - CYL_Z) - CYL_R
    h = abs(y) - 1.0
    cyl = min(max(r, h), 0.0) + math.hypot(max(r, 0.0), max(h, 0.0))
    return -max(box, -cyl)


def box_minus_cylinder_exact(segments=1024):
    box = mf.Manifold.cube([2 * h for h in BOX_HALF], center=True).translate(BOX_C)
    cyl = (mf.Manifold.cylinder(2.0, CYL_R, CYL_R, segments, center=True)
           .rotate([90, 0, 0]).translate([CYL_X, 0, CYL_Z]))
    return mf_mesh(box - cyl)


# Two boxes, one rotated 30° about (1, 2, 3) and moved: the union of `isokit-scene`'s
# tests/dual.rs.
BOX_A = [0.5, 0.35, 0.3]
BOX_B = [0.4, 0.3, 0.35]
B_AXIS, B_DEG, B_MOVE = [1.0, 2.0, 3.0], 30.0, [0.35, 0.3, 0.2]


def rotation(axis, deg):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    a = math.radians(deg)
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K


def rotated_boxes_scene():
    return {"shape": {"union": [
        {"box": {"half": BOX_A}},
        {"transform": {"translate": B_MOVE, "rotate": {"axis": B_AXIS, "degrees": B_DEG},
                       "of": {"box": {"half": BOX_B}}}}]}}


def rotated_boxes_sdf():
    """The union's signed distance, positive inside, as a callable of plain floats (the
    rotation written out: manifold3d calls it once per grid point)."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rotation(B_AXIS, B_DEG).tolist()
    mx, my, mz = B_MOVE
    (ax, ay, az), (bx, by, bz) = BOX_A, BOX_B

    def box(x, y, z, hx, hy, hz):
        qx, qy, qz = abs(x) - hx, abs(y) - hy, abs(z) - hz
        return (math.hypot(max(qx, 0.0), max(qy, 0.0), max(qz, 0.0))
                + min(max(qx, qy, qz), 0.0))

    def sdf(x, y, z):
        dx, dy, dz = x - mx, y - my, z - mz
        # The rotation's transpose takes the point into the second box's frame.
        lx = r00 * dx + r10 * dy + r20 * dz
        ly = r01 * dx + r11 * dy + r21 * dz
        lz = r02 * dx + r12 * dy + r22 * dz
        return -min(box(x, y, z, ax, ay, az), box(lx, ly, lz, bx, by, bz))
    return sdf


def rotated_boxes_exact():
    a = mf.Manifold.cube([2 * h for h in BOX_A], center=True)
    m = np.hstack([rotation(B_AXIS, B_DEG), np.asarray(B_MOVE)[:, None]])
    b = mf.Manifold.cube([2 * h for h in BOX_B], center=True).transform(m)
    return mf_mesh(a + b)


def row(tool, res, seconds, mesh, ref, v_ref, voxel=None):
    h = hausdorff(mesh, ref)
    r = dict(tool=tool, res=res, seconds=seconds, triangles=len(mesh[1]), hausdorff=h,
             hausdorff_voxel=(h / voxel if voxel else None),
             vol_err=abs(volume(*mesh) - v_ref) / abs(v_ref))
    print(r, flush=True)
    return r


def adaptive_rows(exe, scene, tmp, res, voxel, errors, ref, v_ref):
    """`--mesher dual --error E` for each E (a fraction of the voxel)."""
    rows = []
    for e in errors:
        st, wall = run_isokit(exe, scene, tmp / "o.obj", "--res", res, "--mesher", "dual",
                              "--error", e * voxel)
        rows.append(row(f"isokit dual --error {e} voxel", res, wall, read_obj(tmp / "o.obj"),
                        ref, v_ref, voxel))
    return rows


def part_analytic(exe, tmp, resolutions, errors, name, scene_json, sdf, exact, bounds):
    """An analytic part: isokit's meshers and manifold3d's `level_set` against `exact`."""
    ref = exact()
    v_ref = volume(*ref)
    scene = tmp / f"{name}.json"
    scene.write_text(json.dumps(scene_json))
    rows = []
    lo, hi = bounds
    for res in resolutions:
        voxel = None
        for mesher in ["mc", "dual"]:
            st, wall = run_isokit(exe, scene, tmp / "o.obj", "--res", res, "--mesher", mesher)
            voxel = st["spacing"]
            rows.append(row(f"isokit {mesher}", res, wall, read_obj(tmp / "o.obj"), ref, v_ref,
                            voxel))
        rows += adaptive_rows(exe, scene, tmp, res, voxel, errors, ref, v_ref)
        t = time.perf_counter()
        m = mf.Manifold.level_set(sdf, [*lo, *hi], voxel)
        secs = time.perf_counter() - t
        rows.append(row("manifold3d level_set", res, secs, mf_mesh(m), ref, v_ref, voxel))
    return rows


def part_box_cylinder(exe, tmp, resolutions, errors):
    lo = [c - h - 0.1 for c, h in zip(BOX_C, BOX_HALF)]
    hi = [c + h + 0.1 for c, h in zip(BOX_C, BOX_HALF)]
    rows = part_analytic(exe, tmp, resolutions, errors, "box_cyl", box_minus_cylinder_scene(),
                         box_minus_cylinder_sdf, box_minus_cylinder_exact, (lo, hi))
    ref = box_minus_cylinder_exact()
    t = time.perf_counter()
    exact = box_minus_cylinder_exact(256)
    rows.append(row("manifold3d booleans (256-gon)", "", time.perf_counter() - t, exact, ref,
                    volume(*ref)))
    return rows


def part_rotated_boxes(exe, tmp, resolutions, errors):
    rows = part_analytic(exe, tmp, resolutions, errors, "rot", rotated_boxes_scene(),
                         rotated_boxes_sdf(), rotated_boxes_exact,
                         ([-0.7, -0.6, -0.5], [1.1, 1.0, 0.9]))
    t = time.perf_counter()
    exact = rotated_boxes_exact()
    rows.append(row("manifold3d booleans", "", time.perf_counter() - t, exact, exact,
                    volume(*exact)))
    return rows


def part_mesh(exe, tmp, segments, resolutions, errors):
    ref = mf_mesh(torus(1024) - cylinder(1024))
    v_ref = volume(*ref)
    rows = []
    _, _, out, secs = csg_operands(tmp, segments)
    rows.append(row("manifold3d booleans", "", secs, out, ref, v_ref))
    scene = tmp / "csg.json"
    scene.write_text(json.dumps({"shape": {"difference": [
        {"mesh": {"path": "a.off"}}, {"mesh": {"path": "b.off"}}]}}))
    for res in resolutions:
        for mesher in ["mc", "dual"]:
            st, wall = run_isokit(exe, scene, tmp / "o.obj", "--res", res, "--mesher", mesher)
            rows.append(row(f"isokit {mesher}", res, wall, read_obj(tmp / "o.obj"), ref, v_ref,
                            st["spacing"]))
        rows += adaptive_rows(exe, scene, tmp, res, st["spacing"], errors, ref, v_ref)
    return rows


def table(rows):
    out = ["| tool | res | seconds | triangles | Hausdorff | (voxels) | volume error |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        hv = f"{r['hausdorff_voxel']:.2f}" if r["hausdorff_voxel"] is not None else "—"
        out.append(f"| {r['tool']} | {r['res']} | {r['seconds']:.3f} | {r['triangles']:,} | "
                   f"{r['hausdorff']:.4f} | {hv} | {r['vol_err']:.1e} |")
    return "\n".join(out)


def tool_family(tool):
    """The series a row belongs to in the plot: its tool without the resolution."""
    return tool.replace(" (edge = voxel)", "").replace(" (256-gon)", "")


def plot(parts, path):
    """Hausdorff distance against seconds and against triangles, log-log, per part."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(parts), figsize=(6 * len(parts), 9), squeeze=False)
    # One colour and marker per tool in every panel.
    families = sorted({tool_family(r["tool"]) for _, rows in parts for r in rows})
    for col, (title, rows) in enumerate(parts):
        for row, (key, label) in enumerate([("seconds", "seconds (whole command)"),
                                            ("triangles", "triangles")]):
            ax = axes[row][col]
            for i, fam in enumerate(families):
                pts = [(r[key], max(r["hausdorff"], 1e-5), r["res"])
                       for r in rows if tool_family(r["tool"]) == fam]
                if not pts:
                    continue
                xs, ys, _ = zip(*pts)
                ax.plot(xs, ys, marker="osD^v<>"[i % 7], color=f"C{i}",
                        linestyle="-" if len(pts) > 1 else "", label=fam)
                for x, y, n in pts:
                    if n:
                        ax.annotate(str(n), (x, y), textcoords="offset points", xytext=(4, 4),
                                    fontsize=7)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel(label)
            ax.set_ylabel("Hausdorff distance to the exact boolean")
            ax.grid(True, which="both", alpha=0.3)
            if row == 0:
                ax.set_title(title, fontsize=10)
        axes[0][col].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--isokit", default=str(ROOT / "target/release/isokit"))
    ap.add_argument("--out", default=str(ROOT / "docs/bench_sharp.md"))
    ap.add_argument("--res", type=int, nargs="+", default=[32, 64, 128])
    ap.add_argument("--mesh-res", type=int, nargs="+", default=[64, 128, 256])
    ap.add_argument("--segments", type=int, default=64)
    ap.add_argument("--errors", type=float, nargs="*", default=[0.02, 0.1],
                    help="adaptive dual contouring's --error, in voxels")
    ap.add_argument("--plot", help="also draw the trade into this PNG (needs matplotlib)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = pathlib.Path(d)
        a = part_box_cylinder(args.isokit, tmp, args.res, args.errors)
        c = part_rotated_boxes(args.isokit, tmp, args.res, args.errors)
        b = part_mesh(args.isokit, tmp, args.segments, args.mesh_res, args.errors)
    text = "\n\n".join([
        "# Sharp meshing against manifold3d",
        f"Machine: {platform.machine()}, {platform.system()}, {os.cpu_count()} CPUs; manifold3d "
        f"{importlib.metadata.version('manifold3d')}. Command: `python {' '.join(sys.argv)}`.",
        "## A. Box minus cylinder (analytic; reference: manifold3d's exact boolean, 1024-gon)",
        table(a),
        f"## B. Torus mesh minus cylinder mesh ({args.segments} segments, the same triangles for "
        "every tool; reference: manifold3d's boolean of 1024-segment inputs)",
        table(b),
        "## C. Two boxes, one rotated 30° about (1, 2, 3) (analytic; reference: manifold3d's "
        "exact union)",
        table(c),
    ]) + "\n"
    pathlib.Path(args.out).write_text(text)
    print(text)
    if args.plot:
        plot([("A. box minus cylinder (analytic)", a),
              (f"B. torus mesh minus cylinder mesh ({args.segments} segments)", b),
              ("C. two boxes, one rotated 30° (analytic)", c)], args.plot)


if __name__ == "__main__":
    main()
