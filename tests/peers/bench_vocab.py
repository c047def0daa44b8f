"""The modeling vocabulary's three example parts (examples/scenes/flange.json, gear.json,
vase.json) meshed by isokit at several resolutions: time to mesh, holes in the output
(boundary edges: edges with one triangle) and the symmetric Hausdorff distance to
manifold3d's exact part (its booleans of cylinders for the flange, its 2D booleans extruded
for the gear, its revolve ∩ twisted extrusion for the vase's body; the vase's shell is an
offset, which manifold3d cannot build exactly, so the whole vase has no reference).

fogleman's `sdf` (its maintained fork `sdfcad` on PyPI, module `sdf`) builds the same parts
from its own vocabulary (`circle`, `polygon`, `hexagon`, `circular_array`, `extrude`,
`revolve`, `twist`, `shell`, `|`, `&`, `-`) and meshes them with its `generate` over isokit's
sampled domain at isokit's spacing (2 workers); where it is not importable its rows are left
out and the run says so. Its triangles come as a soup: vertices are welded where they are
equal to 1e-6 before boundary edges are counted.

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


def sdfcad_part(name, scene):
    """The part `name` in fogleman's vocabulary, with the parameters of its scene file."""
    import sdf

    prm = scene.get("params", {})
    if name == "flange":
        plate = sdf.circle(1.0).extrude(prm["plate"])
        boss = sdf.circle(0.42).extrude(0.4).translate((0, 0, 0.2))
        bore = sdf.circle(0.25).extrude(2.0)
        hole = sdf.circle(prm["bolt_radius"], center=(prm["bolt_circle"], 0))
        holes = sdf.d2.circular_array(hole, int(prm["bolts"])).extrude(1.0)
        return (plate | boss) - bore - holes
    if name == "gear":
        tooth = sdf.polygon([[0.75, -0.09], [0.98, -0.05], [0.98, 0.05], [0.75, 0.09]])
        teeth = sdf.d2.circular_array(tooth, int(prm["teeth"]))
        return ((sdf.circle(0.8) | teeth) - sdf.circle(prm["bore"])).extrude(prm["thickness"])
    profile = sdf.polygon([[-0.1, -0.8], [0.4, -0.8], [0.55, -0.45], [0.55, -0.1],
                           [0.35, 0.35], [0.28, 0.6], [0.36, 0.8], [-0.1, 0.8]])
    # isokit turns the section at height z by rate·z degrees; sdf's twist(k) evaluates its
    # operand at the point turned by k·z radians, which turns the shape by −k·z.
    hexa = sdf.hexagon(0.56).extrude(1.8).twist(-np.radians(prm["twist"]))
    body = sdf.revolve(profile, 0) & hexa
    if name == "vase body":
        return body
    return body.shell(prm["wall"]) - sdf.box((2, 2, 0.2), center=(0, 0, 0.85))


def run_sdfcad(name, scene, stats):
    """sdfcad's mesh of the part over isokit's sampled domain at isokit's spacing."""
    f = sdfcad_part(name, scene)
    lo, hi = stats["domain"]
    t0 = time.perf_counter()
    pts = f.generate(step=stats["spacing"], bounds=(tuple(lo), tuple(hi)), workers=2,
                     verbose=False)
    seconds = time.perf_counter() - t0
    P = np.asarray(pts, dtype=np.float64)
    V, inv = np.unique(np.round(P, 6), axis=0, return_inverse=True)
    F = inv.reshape(-1, 3)
    F = F[(F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 2] != F[:, 0])]
    return (V, F), seconds


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--isokit", required=True)
    ap.add_argument("--res", type=int, nargs="+", default=[64, 128, 256])
    ap.add_argument("--out", type=pathlib.Path)
    a = ap.parse_args()
    try:
        from importlib.metadata import version

        import sdf  # noqa: F401

        peer = True
        note = f"sdfcad {version('sdfcad')}"
    except ImportError:
        peer = False
        note = "sdfcad is not installed: its rows are absent"
    lines = [
        f"Machine: {platform.machine()}, {platform.processor() or 'cpu'}; "
        f"Python {platform.python_version()}; {note}.",
        "",
        "| part | res | tool | lattice | seconds (evaluate, mesh, write) | wall s | triangles "
        "| boundary edges | Hausdorff to manifold3d (voxels) |",
        "|---|---|---|---|---|---|---|---|---|",
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
                f"| {name} | {res} | isokit | {dims} | {seconds:.3f} | {wall:.2f} | {len(F)} "
                f"| {boundary_edges(F)} | {h} |"
            )
            print(lines[-1], flush=True)
            if peer:
                (SV, SF), s_seconds = run_sdfcad(name, scene, stats)
                sh = "—"
                if ref is not None and len(SF):
                    d = hausdorff((SV, SF), ref)
                    sh = f"{d:.4f} ({d / stats['spacing']:.2f})"
                lines.append(
                    f"| {name} | {res} | sdfcad | same | {s_seconds:.3f} | {s_seconds:.2f} "
                    f"| {len(SF)} | {boundary_edges(SF)} | {sh} |"
                )
                print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    if a.out:
        a.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
