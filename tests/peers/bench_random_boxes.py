"""Sharp meshing on random scenes of two boxes: isokit's meshers against manifold3d's exact
booleans.

Each scene is a box (half extents 0.5, 0.35, 0.3) and a second box (0.4, 0.3, 0.35) rotated
about a random axis by 10–80° and moved, united, subtracted or intersected in turn: edges
and corners at general angles to the lattice and to each other, with the thin wedges,
shallow creases and small facets such scenes have. `--general` keeps only rotations whose
faces are at least 25° from parallel to the first box's and whose edges are at least 15°
from its planes (no shallow creases; acute wedges and spikes remain).

For every `LABEL=EXE:MESHER` given, `EXE scene SCENE -o out.obj --res R --mesher MESHER`
meshes each scene; the table gives, in voxels, the largest distance from the exact surface
(manifold3d's boolean; its vertices, 200,000 area samples and points along its sharp edges)
to the mesh, and the largest distance from the mesh's vertices to the exact surface. Run
(two binaries of isokit, one before a change, compare in one run):

    cargo build --release --bin isokit
    cp target/release/isokit /tmp/isokit-before   # (then build the change)
    python tests/peers/bench_random_boxes.py --res 64 --scenes 20 \\
        before=/tmp/isokit-before:dual after=target/release/isokit:dual \\
        mc=target/release/isokit:mc

Needs numpy, libigl and manifold3d (tests/peers/requirements.txt).
"""

import argparse
import json
import math
import pathlib
import subprocess
import sys
import tempfile

import igl
import manifold3d as mf
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from bench_scene import mf_mesh, read_obj  # noqa: E402
from bench_sharp import rotation  # noqa: E402

BOX_A = [0.5, 0.35, 0.3]
BOX_B = [0.4, 0.3, 0.35]
OPS = ["union", "difference", "intersection"]


def scenes(rng, n, general):
    """`n` scenes: (op, axis, degrees, move)."""
    out = []
    for i in range(n):
        while True:
            axis = rng.normal(size=3)
            deg = float(rng.uniform(10, 80))
            r = np.abs(rotation(axis, deg))
            # |R_ij| is the cosine between face normal i of the first box and j of the second,
            # and the sine between edge j of the second box and plane i of the first.
            if not general or (r.min() > math.sin(math.radians(15))
                               and r.max() < math.cos(math.radians(25))):
                break
        move = (rng.uniform(-0.3, 0.3, 3) + np.array([0.3, 0.25, 0.2])).tolist()
        out.append((OPS[i % 3], axis.tolist(), deg, move))
    return out


def exact(op, axis, deg, move):
    a = mf.Manifold.cube([2 * h for h in BOX_A], center=True)
    m = np.hstack([rotation(axis, deg), np.asarray(move)[:, None]])
    b = mf.Manifold.cube([2 * h for h in BOX_B], center=True).transform(m)
    return mf_mesh({"union": a + b, "difference": a - b, "intersection": a ^ b}[op])


def probe_points(rng, V, F, n=200_000, per_edge=40):
    """The exact mesh's vertices, area samples, and points along its edges whose faces meet
    at more than 10° (where the largest errors are)."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    cross = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    t = rng.choice(len(F), size=n, p=area / area.sum())
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    pts = [V, a[t] + u[:, None] * (b[t] - a[t]) + v[:, None] * (c[t] - a[t])]
    normal = cross / np.linalg.norm(cross, axis=1)[:, None]
    edges = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    face = np.tile(np.arange(len(F)), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, face = edges[order], face[order]
    s = np.linspace(0, 1, per_edge)[:, None]
    for i in np.nonzero(np.all(edges[1:] == edges[:-1], axis=1))[0]:
        if normal[face[i]] @ normal[face[i + 1]] < math.cos(math.radians(10)):
            p, q = V[edges[i, 0]], V[edges[i, 1]]
            pts.append(p + s * (q - p))
    return np.vstack(pts)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", help="LABEL=EXE:MESHER")
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--scenes", type=int, default=15)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--general", action="store_true")
    args = ap.parse_args()
    if any("=" not in r or ":" not in r.split("=", 1)[1] for r in args.runs):
        ap.error("each run is LABEL=EXE:MESHER, e.g. dual=target/release/isokit:dual")
    runs = [(lab, *spec.rsplit(":", 1)) for lab, spec in (r.split("=", 1) for r in args.runs)]
    rng = np.random.default_rng(args.seed)
    tmp = pathlib.Path(tempfile.mkdtemp())
    results = {lab: [] for lab, _, _ in runs}
    print("| scene | op | " + " | ".join(f"{lab} H | {lab} vertex" for lab, _, _ in runs) + " |")
    print("|---:|---|" + "---:|---:|" * len(runs))
    for i, (op, axis, deg, move) in enumerate(scenes(rng, args.scenes, args.general)):
        EV, EF = exact(op, axis, deg, move)
        if len(EF) == 0:
            print(f"| {i} | {op} {deg:.0f}° | (empty: skipped) |")
            continue
        P = probe_points(rng, EV, EF)
        scene = tmp / f"s{i}.json"
        scene.write_text(json.dumps({"shape": {op: [
            {"box": {"half": BOX_A}},
            {"transform": {"translate": move, "rotate": {"axis": axis, "degrees": deg},
                           "of": {"box": {"half": BOX_B}}}}]}}))
        cells = []
        for lab, exe, mesher in runs:
            out = tmp / "o.obj"
            r = subprocess.run([exe, "scene", str(scene), "-o", str(out), "--stats",
                                "--res", str(args.res), "--mesher", mesher],
                               capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit(f"{lab} on scene {i}: {r.stderr.strip()}")
            h = json.loads(r.stdout)["spacing"]
            V, F = read_obj(out)
            d_surface, _, _ = igl.point_mesh_squared_distance(P, V, F)
            d_vertex, _, _ = igl.point_mesh_squared_distance(V, EV, EF)
            row = (math.sqrt(d_surface.max()) / h, math.sqrt(d_vertex.max()) / h)
            results[lab].append(row)
            cells.append(f"{row[0]:.3f} | {row[1]:.3f}")
        print(f"| {i} | {op} {deg:.0f}° | " + " | ".join(cells) + " |", flush=True)
    print()
    for lab, rows in results.items():
        H = np.array([r[0] for r in rows])
        print(f"- {lab}: {len(rows)} scenes, Hausdorff surface→mesh median {np.median(H):.3f} voxel, "
              f"max {H.max():.3f}; ≤ 0.1 voxel in {(H <= 0.1).sum()}, ≤ 0.2 in {(H <= 0.2).sum()}; "
              f"median vertex distance {np.median([r[1] for r in rows]):.3f} voxel")


if __name__ == "__main__":
    main()
