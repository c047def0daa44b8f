"""Exact signed-distance queries side by side: isokit against libigl, pysdf, Open3D, trimesh.

Same meshes, same query points, same machine, same run. Meshes: icospheres of growing size
(generated here) plus any OFF meshes given with --mesh (e.g. data/external/*.off from
tools/fetch-data.sh). Query points: half within 5% of the bounding diagonal of the surface,
half uniform in the bounds padded by 10%.

    python tests/peers/bench_query.py --isokit target/release/isokit --out docs/bench_query.md

The reference for errors is isokit's exact f64 distance (checked against brute force and
libigl in the tests); a peer's error is max |d_peer - d_isokit| over the points it ran on.
"""

import argparse
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

import numpy as np


def icosphere(level):
    t = (1 + 5**0.5) / 2
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                  [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
                  [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
                  [8, 6, 7], [9, 8, 1]], np.int64)
    for _ in range(level):
        e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
        e.sort(axis=1)
        uniq, inv = np.unique(e, axis=0, return_inverse=True)
        mid = V[uniq[:, 0]] + V[uniq[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        base = len(V)
        V = np.concatenate([V, mid])
        n = len(F)
        ab, bc, ca = (inv.reshape(-1)[i * n:(i + 1) * n] + base for i in range(3))
        a, b, c = F[:, 0], F[:, 1], F[:, 2]
        F = np.concatenate([np.stack(x, 1) for x in
                            ([a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca])])
    return V, F


def read_off(path):
    with open(path) as f:
        words = [w for line in f for w in line.split("#")[0].split()]
    assert words[0].endswith("OFF")
    nv, nf = int(words[1]), int(words[2])
    V = np.array(words[4:4 + 3 * nv], float).reshape(nv, 3)
    rest = np.array(words[4 + 3 * nv:], np.int64)
    F, i = [], 0
    for _ in range(nf):
        k = rest[i]
        poly = rest[i + 1:i + 1 + k]
        F += [[poly[0], poly[j], poly[j + 1]] for j in range(1, k - 1)]
        i += 1 + k
    return V, np.array(F, np.int64)


def write_ply(path, V, F):
    with open(path, "wb") as f:
        f.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(V)}\n"
                "property float x\nproperty float y\nproperty float z\n"
                f"element face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n"
                .encode())
        f.write(V.astype("<f4").tobytes())
        rec = np.zeros(len(F), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"], rec["i"] = 3, F
        f.write(rec.tobytes())


def query_points(V, F, n, rng):
    lo, hi = V.min(0), V.max(0)
    diag = np.linalg.norm(hi - lo)
    tri = rng.integers(0, len(F), n // 2)
    r1, r2 = rng.random((2, n // 2))
    s = np.sqrt(r1)
    on = (1 - s)[:, None] * V[F[tri, 0]] + (s * (1 - r2))[:, None] * V[F[tri, 1]] \
        + (s * r2)[:, None] * V[F[tri, 2]]
    d = rng.normal(size=(n // 2, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    near = on + d * (rng.random((n // 2, 1)) * 0.05 * diag)
    pad = 0.1 * (hi - lo)
    far = rng.uniform(lo - pad, hi + pad, size=(n - n // 2, 3))
    return np.concatenate([near, far]).astype(np.float32).astype(np.float64)


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def run_isokit(exe, mesh, pts, out, extra):
    r = subprocess.run([exe, "query", mesh, "--points", pts, "-o", out, "--stats", *extra],
                       capture_output=True, text=True, check=True)
    m = re.search(r"tree built in ([\d.]+) s .*\n(\d+) queries in ([\d.]+) s: .*?([\d.]+) nodes "
                  r"visited and ([\d.]+) triangles", r.stderr, re.S)
    build, q = float(m.group(1)), float(m.group(3))
    return np.load(out).astype(np.float64), build, q, float(m.group(4)), float(m.group(5))


def write_svg(rows, path):
    """A grouped bar chart of queries/s (log scale) per mesh and tool, as plain SVG."""
    import math
    meshes = list(dict.fromkeys(r[0] for r in rows))
    tools = list(dict.fromkeys(r[2] for r in rows))
    colors = ["#1b9e77", "#66a61e", "#d95f02", "#7570b3", "#e7298a", "#e6ab02", "#a6761d", "#666"]
    bw, gap, h, top, left = 12, 24, 300, 30, 60
    width = left + len(meshes) * (len(tools) * bw + gap) + 220
    lo, hi = 3.0, 7.0  # 1e3 .. 1e7 queries/s
    y = lambda q: top + h - h * (min(max(math.log10(max(q, 1)), lo), hi) - lo) / (hi - lo)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{h + 120}" '
           'font-family="sans-serif" font-size="11">',
           f'<text x="{left}" y="18" font-size="13">Exact signed-distance queries per second '
           '(log scale; same machine, same run)</text>']
    for e in range(int(lo), int(hi) + 1):
        out.append(f'<line x1="{left}" x2="{width - 220}" y1="{y(10**e)}" y2="{y(10**e)}" stroke="#ddd"/>'
                   f'<text x="{left - 8}" y="{y(10**e) + 4}" text-anchor="end">1e{e}</text>')
    for i, m in enumerate(meshes):
        x0 = left + i * (len(tools) * bw + gap)
        for j, t in enumerate(tools):
            q = next((r[3] for r in rows if r[0] == m and r[2] == t), None)
            if q:
                out.append(f'<rect x="{x0 + j * bw}" y="{y(q)}" width="{bw - 2}" height="{top + h - y(q)}" '
                           f'fill="{colors[j % len(colors)]}"><title>{t}: {q:,.0f}/s</title></rect>')
        out.append(f'<text x="{x0}" y="{top + h + 16}" transform="rotate(20 {x0} {top + h + 16})">{m}</text>')
    for j, t in enumerate(tools):
        yy = top + 14 * j
        out.append(f'<rect x="{width - 210}" y="{yy}" width="10" height="10" fill="{colors[j % len(colors)]}"/>'
                   f'<text x="{width - 195}" y="{yy + 9}">{t}</text>')
    out.append("</svg>")
    pathlib.Path(path).write_text("\n".join(out) + "\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isokit", default="target/release/isokit")
    ap.add_argument("--levels", default="3,5,7,8", help="icosphere levels (20*4^L triangles)")
    ap.add_argument("--mesh", action="append", default=[], help="extra OFF meshes")
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--slow-points", type=int, default=20_000, help="points for trimesh")
    ap.add_argument("--out", default=None, help="markdown file for the table")
    a = ap.parse_args()
    rng = np.random.default_rng(2026)
    meshes = [(f"icosphere L{L}", *icosphere(int(L))) for L in a.levels.split(",") if L]
    meshes += [(pathlib.Path(p).stem, *read_off(p)) for p in a.mesh]
    rows = []
    tmp = pathlib.Path(tempfile.mkdtemp())
    for name, V, F in meshes:
        V = V.astype(np.float32).astype(np.float64)
        diag = np.linalg.norm(V.max(0) - V.min(0))
        P = query_points(V, F, a.points, rng)
        mesh, pts, out = tmp / "m.ply", tmp / "p.npy", tmp / "d.npy"
        write_ply(mesh, V, F)
        np.save(pts, P.astype(np.float32))
        print(f"== {name}: {len(F)} triangles, {len(P)} points", file=sys.stderr)

        def row(tool, secs, n, d=None, note="", want=None):
            """One table row; errors against isokit's exact distances `want` (default: all)."""
            want = ref if want is None else want
            err = signs = ""
            if d is not None:
                err = f"{np.abs(d - want).max():.1e}"
                far = np.abs(want) > 1e-4 * diag
                signs = f"{np.count_nonzero(np.sign(d[far]) != np.sign(want[far]))}"
            rows.append((name, len(F), tool, n / secs, err, signs, note))
            print(f"  {tool:28s} {n / secs:12.0f} q/s  max err {err:8s} sign mismatches {signs} {note}",
                  file=sys.stderr)

        (ref, build, q, nodes, tris), wall = timed(lambda: run_isokit(a.isokit, mesh, pts, out, []))
        row("isokit (overlap kd-tree)", q, len(P), None,
            f"build {build:.2f} s; {nodes:.0f} nodes, {tris:.0f} tris/query; wall {wall:.1f} s incl. I/O")
        (dc, build, q, nodes, tris), _ = timed(lambda: run_isokit(
            a.isokit, mesh, pts, out, ["--max-overlap", "0"]))
        row("isokit (classic kd-tree)", q, len(P), dc,
            f"build {build:.2f} s; {nodes:.0f} nodes, {tris:.0f} tris/query")
        try:
            import igl
            Fi = F.astype(np.int64)
            (s, _, _, _), t = timed(lambda: igl.signed_distance(
                P, V, Fi, sign_type=igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL))
            row("libigl pseudonormal", t, len(P), s)
            (s, _, _, _), t = timed(lambda: igl.signed_distance(
                P, V, Fi, sign_type=igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER))
            row("libigl fast winding number", t, len(P), s)
        except ImportError as e:
            print(f"  libigl missing: {e}", file=sys.stderr)
        try:
            import open3d as o3d
            scene = o3d.t.geometry.RaycastingScene()
            scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)),
                                o3d.core.Tensor(F.astype(np.uint32)))
            d, t = timed(lambda: scene.compute_signed_distance(
                o3d.core.Tensor(P.astype(np.float32))).numpy().astype(np.float64))
            row("Open3D RaycastingScene", t, len(P), d, "f32; sign by ray parity")
        except ImportError as e:
            print(f"  Open3D missing: {e}", file=sys.stderr)
        try:
            from pysdf import SDF
            f = SDF(V.astype(np.float32), F.astype(np.uint32))
            d, t = timed(lambda: -f(P.astype(np.float32)).astype(np.float64))
            row("pysdf", t, len(P), d, "f32; positive inside, negated")
        except ImportError as e:
            print(f"  pysdf missing: {e}", file=sys.stderr)
        try:
            import trimesh
            if a.slow_points <= 0:
                raise ImportError("skipped (--slow-points 0)")
            tm = trimesh.Trimesh(V, F, process=False)
            m = min(a.slow_points, len(P) // 2)
            # Same mix: half near, half uniform.
            sub = np.concatenate([P[:m // 2], P[len(P) // 2:len(P) // 2 + m - m // 2]])
            d, t = timed(lambda: -trimesh.proximity.signed_distance(tm, sub))
            want = np.concatenate([ref[:m // 2], ref[len(P) // 2:len(P) // 2 + m - m // 2]])
            row("trimesh", t, len(sub), d, f"{len(sub)} points; positive inside, negated", want)
        except ImportError as e:
            print(f"  trimesh missing: {e}", file=sys.stderr)
    lines = ["| mesh | triangles | tool | queries/s | isokit ÷ tool | max error | sign mismatches | notes |",
             "| --- | ---: | --- | ---: | ---: | ---: | ---: | --- |"]
    for name, nf, tool, qps, err, signs, note in rows:
        ours = next(r[3] for r in rows if r[0] == name and r[2].startswith("isokit (overlap"))
        lines.append(f"| {name} | {nf} | {tool} | {qps:,.0f} | {ours / qps:.2f} | {err} | {signs} | {note} |")
    table = "\n".join(lines)
    print(table)
    if a.out:
        pathlib.Path(a.out).write_text(table + "\n")
        write_svg(rows, pathlib.Path(a.out).with_suffix(".svg"))


if __name__ == "__main__":
    main()
