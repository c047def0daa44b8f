"""The modeling vocabulary's three example parts (examples/scenes/flange.json, gear.json,
vase.json) meshed by isokit at several resolutions: time to mesh, holes in the output
(boundary edges: edges with one triangle) and the symmetric Hausdorff distance to
manifold3d's exact part (its booleans of cylinders for the flange, its 2D booleans extruded
for the gear, its revolve ∩ twisted extrusion for the vase's body; the vase's shell is an
offset, which manifold3d cannot build exactly, so the whole vase has no reference).

fogleman's `sdf` (the fork `sdfcad` on PyPI) is the peer this is meant to run beside; where
it is not importable its rows are left out and the run says so.

    python tests/peers/bench_vocab.py --isokit target/release/isokit --res 64 128 256 \\
        --out docs/bench_vocab.md

Needs numpy, libigl and manifold3d (tests/peers/requirements.txt).
"""

import argparse
import json
import pathlib
import platform
import subprocess
import sys
import tempfile
import time

import igl
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "reference"))
import test_vocab as parts  # noqa: E402  (the manifold3d parts of the reference tests)
from test_manifold import manifold_mesh, read_obj  # noqa: E402

RNG = np.random.default_rng(20)


def boundary_edges(F):
    e = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return int((counts == 1).sum())


def samples(V, F, n=30000):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    t = RNG.choice(len(F), size=n, p=area / area.sum())
    u, v = RNG.random(n), RNG.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    return a[t] + u[:, None] * (b[t] - a[t]) + v[:, None] * (c[t] - a[t])


def hausdorff(A, B):
    (VA, FA), (VB, FB) = A, B
    d_ab, _, _ = igl.point_mesh_squared_distance(samples(VA, FA), VB, FB)
    d_ba, _, _ = igl.point_mesh_squared_distance(samples(VB, FB), VA, FA)
    return float(np.sqrt(max(d_ab.max(), d_ba.max())))


def cases():
    flange = parts.example("flange.json")
    gear = parts.example("gear.json")
    vase = parts.example("vase.json")
    body = dict(vase, shape=parts.vase_body(vase))
    return [
        ("flange", flange, manifold_mesh(parts.flange_reference(flange))),
        ("gear", gear, manifold_mesh(parts.gear_reference(gear))),
        ("vase (with shell)", vase, None),
        ("vase body", body, manifold_mesh(parts.vase_body_reference(vase))),
    ]


def run_isokit(exe, scene, res, tmp):
    path = pathlib.Path(tmp) / "scene.json"
    path.write_text(json.dumps(dict(scene, sampling={"resolution": res})))
    out = pathlib.Path(tmp) / "out.obj"
    t0 = time.perf_counter()
    r = subprocess.run(
        [exe, "scene", str(path), "-o", str(out), "--stats"],
        capture_output=True,
        text=True,
        check=True,
    )
    wall = time.perf_counter() - t0
    stats = json.loads(r.stdout)
    return read_obj(out), stats, wall


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--isokit", required=True)
    ap.add_argument("--res", type=int, nargs="+", default=[64, 128, 256])
    ap.add_argument("--out", type=pathlib.Path)
    a = ap.parse_args()
    try:
        import sdfcad  # noqa: F401

        note = "sdfcad is importable but not driven yet: add its parts here"
    except ImportError:
        note = "sdfcad is not installed: its rows are absent"
    lines = [
        f"Machine: {platform.machine()}, {platform.processor() or 'cpu'}; "
        f"Python {platform.python_version()}; {note}.",
        "",
        "| part | res | lattice | seconds (evaluate, mesh, write) | wall s | triangles "
        "| boundary edges | Hausdorff to manifold3d (voxels) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, scene, ref in cases():
        for res in a.res:
            with tempfile.TemporaryDirectory() as tmp:
                mesh, stats, wall = run_isokit(a.isokit, scene, res, tmp)
            V, F = mesh
            seconds = stats["total_seconds"]
            h = "—"
            if ref is not None:
                d = hausdorff(mesh, ref)
                h = f"{d:.4f} ({d / stats['spacing']:.2f})"
            dims = "×".join(str(x) for x in stats["dims"])
            lines.append(
                f"| {name} | {res} | {dims} | {seconds:.3f} | {wall:.2f} | {len(F)} "
                f"| {boundary_edges(F)} | {h} |"
            )
            print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    if a.out:
        a.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
