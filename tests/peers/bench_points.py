"""Point cloud -> surface, side by side: isokit's partition of unity (and its Shepard and
[Nie04] variants) against Open3D's screened Poisson and libigl's fast winding number.

Same clouds, same machine, same run. Clouds are sampled uniformly by area from known shapes
(unit sphere, torus R = 1 r = 0.35, and the tube around a trefoil knot in data/trefoil.ply),
with the exact normals of the noiseless surface, in three conditions: clean, with Gaussian
noise of 0.5% of the bounding diagonal, and with a density varying 20:1 along x.

    python tests/peers/bench_points.py --isokit target/release/isokit --out docs/bench_points.md
    python tests/peers/bench_points.py --sizes 1000000 --shapes torus --conditions clean,noisy \
        --no-shepard-nie04 --out docs/bench_points_1m.md
    python tests/peers/bench_points.py --replot docs/bench_points.md   # redraw the .svg only

isokit's field is sampled with `isokit points --res R --band W` (the lazy brick path; W is
4 h or 3 grid cells), on a 128 grid and, for clean and non-uniform clouds of 100k points and
more, also on a 256 grid (--fine-res); noisy clouds also get the smoothing knobs
`--k 64 --damping 1`.

For every cloud and tool:
- "field RMS / max": the error of the sampled field against the exact signed distance at the
  grid nodes within two spacings of the surface (two mean sample spacings h or two grid
  spacings, whichever is larger). Only tools that produce a distance have one: Poisson and
  the winding number give an indicator (inside/outside), not a distance.
- "Chamfer / Hausdorff": between the meshed zero set and the true surface, from 30,000
  area-uniform samples on each (mean of the two mean distances; largest distance either
  way). isokit's field and the winding number (at 1/2) are meshed by `isokit mesh` on the
  same grid; Poisson meshes itself.
- "seconds": the time to the field or mesh, without file I/O: isokit's build + band
  sampling as it reports them; Poisson's `create_from_point_cloud_poisson`; the winding
  number's point areas + evaluation at the grid nodes. Meshing and metrics are not timed.

libigl's pip bindings have no `point_areas` (it needs CGAL), so the winding number's point
areas are pi r^2 / 15 with r the distance to the 15th nearest other sample (scipy kd-tree;
their sum is within 0.1% of the sphere's area at 100k samples), timed with it. Never run in CI: it needs the peers of tests/peers/requirements.txt.
"""

import argparse
import datetime
import gzip
import os
import pathlib
import platform
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]


# ---------------------------------------------------------------- shapes


def sphere_sdf(x):
    return np.linalg.norm(x, axis=1) - 1.0


def torus_sdf(x):
    q = np.hypot(x[:, 0], x[:, 1]) - 1.0
    return np.hypot(q, x[:, 2]) - 0.35


def sample_sphere(n, rng):
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return v, v.copy()


def sample_torus(n, rng):
    out_p, out_n = [], []
    got = 0
    while got < n:
        m = 2 * (n - got) + 16
        phi, th, u = rng.random((3, m))
        phi *= 2 * np.pi
        th *= 2 * np.pi
        keep = u <= (1 + 0.35 * np.cos(th)) / 1.35
        phi, th = phi[keep], th[keep]
        nrm = np.stack([np.cos(th) * np.cos(phi), np.cos(th) * np.sin(phi), np.sin(th)], 1)
        c = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], 1)
        out_p.append(c + 0.35 * nrm)
        out_n.append(nrm)
        got += len(phi)
    return np.concatenate(out_p)[:n], np.concatenate(out_n)[:n]


class MeshShape:
    """A triangle mesh: area-uniform samples with face normals, exact signed distance."""

    def __init__(self, V, F):
        self.V, self.F = V.astype(np.float64), F.astype(np.int64)
        a, b, c = (self.V[self.F[:, i]] for i in range(3))
        cr = np.cross(b - a, c - a)
        area = 0.5 * np.linalg.norm(cr, axis=1)
        ok = area > 0
        self.a, self.b, self.c = a[ok], b[ok], c[ok]
        self.n = cr[ok] / np.linalg.norm(cr[ok], axis=1, keepdims=True)
        self.cum = np.cumsum(area[ok])

    def sample(self, n, rng):
        t = np.searchsorted(self.cum, rng.random(n) * self.cum[-1], side="right")
        t = np.minimum(t, len(self.cum) - 1)
        r1, r2 = np.sqrt(rng.random(n)), rng.random(n)
        p = ((1 - r1)[:, None] * self.a[t] + (r1 * (1 - r2))[:, None] * self.b[t]
             + (r1 * r2)[:, None] * self.c[t])
        return p, self.n[t].copy()

    def sdf(self, x, within=np.inf):
        """Exact signed distance; with `within`, points provably farther than that from the
        mesh (nearest vertex beyond `within` + the largest vertex-to-triangle reach) get
        +-inf instead, which saves the exact query on most of a grid."""
        import igl
        from scipy.spatial import cKDTree
        x = np.ascontiguousarray(x, np.float64)
        out = np.full(len(x), np.inf)
        todo = np.arange(len(x))
        if np.isfinite(within):
            if not hasattr(self, "_tree"):
                self._tree = cKDTree(self.V)
                cen = (self.a + self.b + self.c) / 3
                self._reach = max(np.linalg.norm(v - cen, axis=1).max() for v in (self.a, self.b, self.c))
                self._reach *= 2  # any point of a triangle is within 2x that of a vertex
            dv, _ = self._tree.query(x, distance_upper_bound=within + self._reach)
            todo = np.flatnonzero(np.isfinite(dv))
        if len(todo):
            s, _, _, _ = igl.signed_distance(x[todo], self.V, self.F,
                                             sign_type=igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL)
            out[todo] = s
        return out


def unsigned_to_mesh(x, V, F):
    import igl
    d2, _, _ = igl.point_mesh_squared_distance(np.ascontiguousarray(x, np.float64),
                                               np.ascontiguousarray(V, np.float64),
                                               np.ascontiguousarray(F, np.int64))
    return np.sqrt(d2)


def load_trefoil():
    import trimesh
    m = trimesh.load(ROOT / "data" / "trefoil.ply", process=False)
    return MeshShape(np.asarray(m.vertices), np.asarray(m.faces))


def shapes(names):
    out = {}
    for s in names:
        if s == "sphere":
            out[s] = (sample_sphere, sphere_sdf)
        elif s == "torus":
            out[s] = (sample_torus, torus_sdf)
        elif s == "trefoil":
            m = load_trefoil()
            out[s] = (m.sample, m.sdf)
        else:
            sys.exit(f"unknown shape {s}")
    return out


def make_cloud(sampler, n, condition, rng):
    if condition == "nonuniform":
        # Keep a sample with probability 0.05 + 0.95 t, t = x rescaled to [0, 1].
        ps, ns, got = [], [], 0
        while got < n:
            p, q = sampler(2 * (n - got) + 64, rng)
            t = (p[:, 0] - p[:, 0].min()) / np.ptp(p[:, 0])
            keep = rng.random(len(p)) < 0.05 + 0.95 * t
            ps.append(p[keep])
            ns.append(q[keep])
            got += keep.sum()
        return np.concatenate(ps)[:n], np.concatenate(ns)[:n]
    p, q = sampler(n, rng)
    if condition == "noisy":
        diag = np.linalg.norm(np.ptp(p, axis=0))
        p = p + rng.normal(size=p.shape) * 0.005 * diag
    return p, q


# ---------------------------------------------------------------- files


def write_cloud_ply(path, P, N):
    rec = np.zeros(len(P), dtype=[("p", "<f4", 3), ("n", "<f4", 3)])
    rec["p"], rec["n"] = P, N
    with open(path, "wb") as f:
        f.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(P)}\n"
                "property float x\nproperty float y\nproperty float z\n"
                "property float nx\nproperty float ny\nproperty float nz\nend_header\n".encode())
        f.write(rec.tobytes())


def read_nrrd(path):
    """isokit's NRRD: (values [nz, ny, nx], origin, spacing)."""
    raw = pathlib.Path(path).read_bytes()
    head, _, body = raw.partition(b"\n\n")
    h = {}
    for line in head.decode().splitlines()[1:]:
        if ":" in line and not line.startswith("#"):
            k, v = line.split(":", 1)
            h[k.strip()] = v.strip()
    sizes = [int(s) for s in h["sizes"].split()]
    data = gzip.decompress(body) if h["encoding"] == "gzip" else body
    vals = np.frombuffer(data, "<f4").reshape(sizes[::-1])
    origin = np.array([float(t) for t in h["space origin"].strip("()").split(",")])
    spacing = float(h["space directions"].split(")")[0].strip("( ").split(",")[0])
    return vals, origin, spacing


def write_nrrd(path, vals, origin, spacing):
    nz, ny, nx = vals.shape
    g = spacing
    with open(path, "wb") as f:
        f.write((f"NRRD0004\ntype: float\ndimension: 3\nspace dimension: 3\nsizes: {nx} {ny} {nz}\n"
                 f"space directions: ({g},0,0) (0,{g},0) (0,0,{g})\nkinds: domain domain domain\n"
                 f"endian: little\nencoding: raw\nspace origin: ({origin[0]},{origin[1]},{origin[2]})\n\n")
                .encode())
        f.write(np.ascontiguousarray(vals, "<f4").tobytes())


def read_mesh(path):
    import trimesh
    m = trimesh.load(path, process=False, force="mesh")
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)


def grid_points(vals, origin, spacing):
    nz, ny, nx = vals.shape
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    return origin + spacing * np.stack([i.ravel(), j.ravel(), k.ravel()], 1)


# ---------------------------------------------------------------- metrics


def area_samples(V, F, n, rng):
    if len(F) == 0:
        return np.zeros((0, 3))
    return MeshShape(V, F).sample(n, rng)[0]


def surface_metrics(V, F, truth_pts, truth_dist, m, rng):
    """Chamfer (mean of the two mean distances) and Hausdorff between a mesh and the truth."""
    if len(F) == 0:
        return float("nan"), float("nan")
    on_mesh = area_samples(V, F, m, rng)
    d1 = truth_dist(on_mesh)
    d2 = unsigned_to_mesh(truth_pts, V, F)
    return 0.5 * (d1.mean() + d2.mean()), max(d1.max(), d2.max())


def field_error(vals, exact, band):
    near = np.abs(exact) <= band
    e = vals.ravel()[near].astype(np.float64) - exact[near]
    return np.sqrt((e * e).mean()), np.abs(e).max(), int(near.sum())


# ---------------------------------------------------------------- tools


def run_isokit(exe, cloud, out, res, band, extra):
    t = time.perf_counter()
    r = subprocess.run([exe, "points", cloud, "--res", str(res), "--band", f"{band}", "-o", out,
                        *extra], capture_output=True, text=True)
    wall = time.perf_counter() - t
    if r.returncode != 0:
        raise RuntimeError(r.stderr.strip())
    build = float(re.search(r"build: ([\d.]+) s", r.stderr).group(1))
    m = re.search(r"band [^:]+: ([\d.]+)% of the dense samples evaluated .* in ([\d.]+) s", r.stderr)
    frac, sample = float(m.group(1)), float(m.group(2))
    solve = re.search(r"solve: .*?(\d+) iterations \((\w+(?: \w+)?)\), relative residual ([\d.e+-]+), "
                      r"max \|f\| at the samples ([\d.e+-]+)", r.stderr)
    note = f"band {frac:.0f}% evaluated"
    if solve:
        note += f"; {solve.group(1)} it., max \\|f(p_i)\\| {float(solve.group(4)):.1e}"
    return build + sample, wall, note


def run_mesh(exe, field, out, iso=0.0, inside="below"):
    r = subprocess.run([exe, "mesh", field, "-o", out, "--iso", str(iso), "--inside", inside],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(r.stderr.strip())
    return read_mesh(out)


def fwn_field(P, N, Q):
    import igl
    from scipy.spatial import cKDTree
    k = 16
    d, _ = cKDTree(P).query(P, k)
    A = np.pi * d[:, -1] ** 2 / (k - 1)  # k - 1 other samples in the disc
    return igl.fast_winding_number(np.ascontiguousarray(P, np.float64),
                                   np.ascontiguousarray(N, np.float64), A,
                                   np.ascontiguousarray(Q, np.float64))


# ---------------------------------------------------------------- plot


def write_svg(rows, path):
    """Chamfer distance against seconds (log-log), one panel per cloud condition, one colour
    per tool, one marker per cloud."""
    import math
    tools = list(dict.fromkeys(r["tool"] for r in rows))
    conds = list(dict.fromkeys(r["cloud"].split()[-1] for r in rows))
    colors = ["#1b9e77", "#66a61e", "#a6d854", "#e6ab02", "#d95f02", "#e7298a", "#7570b3",
              "#a6761d", "#666"]
    pts = [(r["seconds"], r["chamfer"], r["tool"], r["cloud"]) for r in rows
           if r["seconds"] > 0 and r["chamfer"] == r["chamfer"] and r["chamfer"] > 0]
    if not pts:
        return
    pw, ph, left, top, gap, legend = 260, 300, 60, 40, 30, 230
    W = left + len(conds) * (pw + gap) + legend
    H = top + ph + 60
    x0 = math.floor(min(math.log10(p[0]) for p in pts))
    x1 = math.ceil(max(math.log10(p[0]) for p in pts))
    y0 = math.floor(min(math.log10(p[1]) for p in pts))
    y1 = math.ceil(max(math.log10(p[1]) for p in pts))
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
           'font-family="sans-serif" font-size="11">',
           f'<text x="{left}" y="16" font-size="13">Chamfer distance of the meshed surface against '
           'seconds to the field or mesh (log-log; same machine, same run; lower left is better)'
           '</text>']
    for c, cond in enumerate(conds):
        ox = left + c * (pw + gap)
        X = lambda v: ox + pw * (math.log10(v) - x0) / max(x1 - x0, 1)
        Y = lambda v: top + ph * (1 - (math.log10(v) - y0) / max(y1 - y0, 1))
        out.append(f'<rect x="{ox}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="#999"/>'
                   f'<text x="{ox + pw / 2}" y="{top - 6}" text-anchor="middle">{cond}</text>')
        for e in range(x0, x1 + 1):
            out.append(f'<line x1="{X(10**e)}" x2="{X(10**e)}" y1="{top}" y2="{top + ph}" stroke="#eee"/>'
                       f'<text x="{X(10**e)}" y="{top + ph + 14}" text-anchor="middle">1e{e} s</text>')
        for e in range(y0, y1 + 1):
            out.append(f'<line x1="{ox}" x2="{ox + pw}" y1="{Y(10**e)}" y2="{Y(10**e)}" stroke="#eee"/>')
            if c == 0:
                out.append(f'<text x="{ox - 4}" y="{Y(10**e) + 4}" text-anchor="end">1e{e}</text>')
        for sec, ch, tool, cloud in pts:
            if cloud.split()[-1] != cond:
                continue
            j = tools.index(tool)
            out.append(f'<circle cx="{X(sec):.1f}" cy="{Y(ch):.1f}" r="3.5" '
                       f'fill="{colors[j % len(colors)]}" fill-opacity="0.85"><title>{tool}, {cloud}: '
                       f'{sec:.2f} s, Chamfer {ch:.2e}</title></circle>')
    for j, t in enumerate(tools):
        yy = top + 16 * j
        lx = left + len(conds) * (pw + gap)
        out.append(f'<circle cx="{lx + 6}" cy="{yy + 5}" r="4" fill="{colors[j % len(colors)]}"/>'
                   f'<text x="{lx + 16}" y="{yy + 9}">{t}</text>')
    out.append("</svg>")
    pathlib.Path(path).write_text("\n".join(out) + "\n")


def rows_from_markdown(path):
    """The rows of a table this script wrote (for --replot)."""
    rows = []
    for line in pathlib.Path(path).read_text().splitlines():
        f = [c.strip() for c in line.split(" | ")]
        if len(f) < 8 or not line.startswith("| ") or f[0] in ("| cloud", "| ---"):
            continue
        try:
            rows.append(dict(cloud=f[0].lstrip("| "), tool=f[1], seconds=float(f[2]),
                             chamfer=float(f[5]), hausdorff=float(f[6])))
        except ValueError:
            continue
    return rows


# ---------------------------------------------------------------- main


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--isokit", default=str(ROOT / "target" / "release" / "isokit"))
    ap.add_argument("--sizes", default="10000,100000", help="points per cloud (e.g. 1000000)")
    ap.add_argument("--shapes", default="sphere,torus,trefoil")
    ap.add_argument("--conditions", default="clean,noisy,nonuniform")
    ap.add_argument("--res", type=int, default=128, help="grid samples along the longest side")
    ap.add_argument("--fine-res", type=int, default=256,
                    help="an extra isokit PU run on this grid for clean and non-uniform clouds of "
                         "100k points and more (0: none)")
    ap.add_argument("--depths", default="8,9,10", help="Poisson octree depths")
    ap.add_argument("--metric-samples", type=int, default=30_000)
    ap.add_argument("--no-shepard-nie04", action="store_true", help="skip the comparison variants")
    ap.add_argument("--out", default=None, help="markdown file for the table (and .svg)")
    ap.add_argument("--replot", default=None, metavar="MD",
                    help="only redraw the .svg next to a table this script wrote")
    a = ap.parse_args()
    if a.replot:
        write_svg(rows_from_markdown(a.replot), pathlib.Path(a.replot).with_suffix(".svg"))
        return
    rng = np.random.default_rng(2026)
    tmp = pathlib.Path(tempfile.mkdtemp())
    rows = []
    started = time.perf_counter()
    try:
        import open3d as o3d
        o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    except ImportError as e:
        o3d = None
        print(f"Open3D missing: {e}", file=sys.stderr)
    try:
        import igl  # noqa: F401
        has_igl = True
    except ImportError as e:
        has_igl = False
        print(f"libigl missing: {e}", file=sys.stderr)

    for shape, (sampler, sdf) in shapes(a.shapes.split(",")).items():
        for n in [int(s) for s in a.sizes.split(",") if s]:
            for cond in a.conditions.split(","):
                P, N = make_cloud(sampler, n, cond, rng)
                P32 = P.astype(np.float32).astype(np.float64)
                from scipy.spatial import cKDTree
                h = cKDTree(P32).query(P32, 2)[0][:, 1].mean()
                truth_pts, truth_n = sampler(a.metric_samples, rng)
                truth_dist = lambda x: np.abs(sdf(x))
                cloud = str(tmp / "c.ply")
                write_cloud_ply(cloud, P32, N)
                name = f"{shape} {n // 1000}k {cond}"
                print(f"== {name}: h = {h:.4g}", file=sys.stderr)

                def add(tool, secs, V=None, F=None, ferr=None, note=""):
                    ch, hd = surface_metrics(V, F, truth_pts, truth_dist, a.metric_samples, rng) \
                        if V is not None else (float("nan"), float("nan"))
                    rows.append(dict(cloud=name, tool=tool, seconds=secs, chamfer=ch, hausdorff=hd,
                                     rms=ferr[0] if ferr else None, max=ferr[1] if ferr else None,
                                     note=note, h=h))
                    fe = f"{ferr[0]:.2e}/{ferr[1]:.2e}" if ferr else "-"
                    print(f"  {tool:28s} {secs:7.2f} s  field {fe:19s} chamfer {ch:.2e} "
                          f"hausdorff {hd:.2e}  {note}", file=sys.stderr)

                variants = [("isokit PU", [], a.res)]
                if not a.no_shepard_nie04:
                    variants += [("isokit Shepard", ["--weights", "shepard"], a.res),
                                 ("isokit Nie04", ["--weights", "nie04"], a.res)]
                if cond == "noisy":
                    variants.append(("isokit PU k 64, damping 1", ["--k", "64", "--damping", "1"],
                                     a.res))
                if a.fine_res and n >= 100_000 and cond != "noisy":
                    variants.append((f"isokit PU, grid {a.fine_res}", [], a.fine_res))
                grid, exact = {}, {}
                for tool, extra, res in variants:
                    # The grid isokit will use (Grid::covering, padding 10% of the diagonal),
                    # so the band can be set before the run: 4 h or 3 grid cells.
                    lo, hi = P32.min(0), P32.max(0)
                    g_est = (np.ptp(P32, axis=0).max() + 0.2 * np.linalg.norm(hi - lo)) / (res - 1)
                    band = max(4 * h, 3 * g_est)
                    field, mesh = str(tmp / "f.nrrd"), str(tmp / "m.ply")
                    try:
                        secs, wall, note = run_isokit(a.isokit, cloud, field, res, band, extra)
                        vals, origin, g = read_nrrd(field)
                        grid[res] = (vals.shape, origin, g)
                        eband = max(2 * h, 2 * g)
                        if res not in exact:
                            pts = grid_points(vals, origin, g)
                            exact[res] = sdf(pts, eband) if shape == "trefoil" else sdf(pts)
                        ferr = field_error(vals, exact[res], eband)
                        V, F = run_mesh(a.isokit, field, mesh)
                        add(tool, secs, V, F, ferr[:2], note + f"; wall {wall:.1f} s")
                    except Exception as e:  # noqa: BLE001
                        add(tool, float("nan"), note=f"failed: {e}")
                if o3d is not None:
                    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(P32))
                    pcd.normals = o3d.utility.Vector3dVector(N)
                    for depth in [int(d) for d in a.depths.split(",") if d]:
                        t = time.perf_counter()
                        m, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pcd, depth=depth)
                        secs = time.perf_counter() - t
                        V, F = np.asarray(m.vertices), np.asarray(m.triangles, np.int64)
                        add(f"Open3D Poisson depth {depth}", secs, V, F, None,
                            f"{len(F)} triangles; indicator, no distance")
                if has_igl and a.res in grid:
                    shape_, origin, g = grid[a.res]
                    Q = grid_points(np.zeros(shape_), origin, g)
                    t = time.perf_counter()
                    w = fwn_field(P32, N, Q)
                    secs = time.perf_counter() - t
                    field, mesh = str(tmp / "w.nrrd"), str(tmp / "wm.ply")
                    write_nrrd(field, w.reshape(shape_), origin, g)
                    try:
                        V, F = run_mesh(a.isokit, field, mesh, iso=0.5, inside="above")
                        add("libigl fast winding number", secs, V, F, None,
                            "indicator, meshed at 1/2")
                    except Exception as e:  # noqa: BLE001
                        add("libigl fast winding number", secs, note=f"meshing failed: {e}")
    total = time.perf_counter() - started

    lines = ["| cloud | tool | seconds | field RMS / h | field max / h | Chamfer | Hausdorff | notes |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | --- |"]
    for r in rows:
        fr = f"{r['rms'] / r['h']:.3f}" if r["rms"] is not None else "-"
        fm = f"{r['max'] / r['h']:.2f}" if r["max"] is not None else "-"
        lines.append(f"| {r['cloud']} | {r['tool']} | {r['seconds']:.2f} | {fr} | {fm} | "
                     f"{r['chamfer']:.2e} | {r['hausdorff']:.2e} | {r['note']} |")
    table = "\n".join(lines)
    cpu = "unknown CPU"
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    head = (f"Machine: {cpu}, {os.cpu_count()} cores, {platform.system()}; Python "
            f"{platform.python_version()}, numpy {np.__version__}. Date: {datetime.date.today()}. "
            f"Command: `python tests/peers/bench_points.py {' '.join(sys.argv[1:])}`; "
            f"grid {a.res} along the longest side; total run {total:.0f} s.\n")
    print(head)
    print(table)
    if a.out:
        pathlib.Path(a.out).write_text(head + "\n" + table + "\n")
        write_svg(rows, pathlib.Path(a.out).with_suffix(".svg"))


if __name__ == "__main__":
    main()
