"""A dense narrow band of signed distance, side by side: isokit's prism scan conversion against
isokit's kd-tree and libigl's signed_distance on the same band samples.

The shape of 002 Tables 4.2-4.5: vary the mesh (Table 4.2: sphere, the trefoil knot of data/,
the bunny when tools/fetch-data.sh has fetched it), the triangle
count (4.3: icospheres of 1.3k-82k triangles), the band width (4.4: 0.1-0.8 of the extent) and
the resolution (4.5). Per case, in one run on one machine:

- isokit prism: `isokit sdf --method prism --backend cpu` (setup and scan times from its
  report: setup builds the kd-tree for signs, the pseudonormals and the prisms);
- isokit kd-tree on the grid: `isokit sdf --method kdtree --band W` (every sample queried, the
  search exiting early beyond the band: what a user would run without prisms);
- libigl `signed_distance` (pseudonormal sign) on exactly the band samples of the prism grid
  (|d| < W), including its AABB build: the per-sample cost of the band alone.

The grid is the one `isokit sdf` makes (res samples along the longest side of the bounds padded
by max(W, 5% of the extent)). Errors are max |d - d_kdtree| over the band samples, in units of
the spacing. Samples/s are band samples per second.

    python tests/peers/bench_prism.py --isokit target/release/isokit --out docs/bench_prism.md

Default run: 128^3 for Tables 4.2-4.4 and 64^3-256^3 for 4.5, about 6 minutes on 2 cores;
`--full` uses 256^3 throughout (the paper's) and adds 512^3 (about 30 minutes).
"""

import argparse
import pathlib
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from bench_query import icosphere, read_off, write_ply  # noqa: E402


def run(args):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, args))}: {r.stderr}")
    return r.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isokit", default="target/release/isokit")
    ap.add_argument("--full", action="store_true", help="256^3 everywhere, plus 512^3")
    ap.add_argument("--out", default=None, help="markdown file for the table")
    a = ap.parse_args()
    res = 256 if a.full else 128
    tmp = pathlib.Path(tempfile.mkdtemp())

    root = pathlib.Path(__file__).parents[2]
    trefoil = tmp / "trefoil.off"
    run([a.isokit, "convert", str(root / "data/trefoil.ply"), str(trefoil)])
    meshes = {"sphere5": icosphere(5), "trefoil": read_off(trefoil)}
    bunny = root / "data/external/bunny00.off"
    if bunny.exists():
        meshes["bunny"] = read_off(bunny)
    cases = [("4.2", m, res, 0.1) for m in meshes]
    for level in (3, 4, 5, 6):
        meshes[f"sphere{level}"] = icosphere(level)
        cases.append(("4.3", f"sphere{level}", res, 0.1))
    cases += [("4.4", "sphere5", res, b) for b in (0.1, 0.2, 0.4, 0.8)]
    cases += [("4.5", "sphere5", r, 0.1) for r in ((64, 128, 256, 512) if a.full else (64, 128, 256))]

    rows = []
    for table, name, r, band_rel in cases:
        V, F = meshes[name]
        V = V.astype(np.float32).astype(np.float64)
        extent = float((V.max(0) - V.min(0)).max())
        band = band_rel * extent
        pad = max(band, 0.05 * extent)
        mesh = tmp / f"{name}.ply"
        if not mesh.exists():
            write_ply(mesh, V, F)
        common = [a.isokit, "sdf", str(mesh), "--res", str(r), "--band", f"{band:.9g}",
                  "--padding", f"{pad:.9g}"]
        prism_out, kd_out = tmp / "prism.npy", tmp / "kd.npy"
        t0 = time.perf_counter()
        err = run(common + ["--method", "prism", "--backend", "cpu", "-o", str(prism_out)])
        prism_wall = time.perf_counter() - t0
        setup = float(re.search(r"built in ([\d.]+) s", err).group(1))
        scan = float(re.search(r"samples, spacing [\d.e-]+ in ([\d.]+) s", err).group(1))
        evals = re.search(r"([\d.]+) distance evaluations per band sample", err)
        t_prism = setup + scan
        g = np.load(prism_out).astype(np.float64)
        # Grid geometry as isokit makes it (Grid::covering, in f32), sample positions in f64.
        f = np.float32
        lo = V.min(0).astype(f) - f(pad)
        hi = V.max(0).astype(f) + f(pad)
        h = f((hi - lo).max()) / f(r - 1)
        nz, ny, nx = g.shape
        span = np.array([nx - 1, ny - 1, nz - 1], f) * h
        origin = (f(0.5) * (lo + hi) - f(0.5) * span).astype(np.float64)
        h = float(h)
        # Band samples: |d| below the band as the grid stores it (f32).
        mask = np.abs(g) < np.float32(band)
        kk, jj, ii = np.nonzero(mask)
        P = origin + h * np.stack([ii, jj, kk], 1)
        n = len(P)
        t0 = time.perf_counter()
        err_kd = run(common + ["--method", "kdtree", "-o", str(kd_out)])
        kd_wall = time.perf_counter() - t0
        kd_scan = float(re.search(r"samples, spacing [\d.e-]+ in ([\d.]+) s", err_kd).group(1))
        kd = np.load(kd_out).astype(np.float64)
        e_prism = np.abs(g[mask] - kd[mask]).max() / h if n else 0.0
        igl_t, igl_err = None, ""
        try:
            import igl
            t0 = time.perf_counter()
            s, _, _, _ = igl.signed_distance(P, V, F.astype(np.int64),
                                             sign_type=igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL)
            igl_t = time.perf_counter() - t0
            igl_err = f"{np.abs(s - kd[mask]).max() / h:.1e}"
        except ImportError as e:
            print(f"libigl missing: {e}", file=sys.stderr)
        row = dict(table=table, mesh=f"{name} ({len(F)})", res=f"{r}³", band=band_rel, n=n,
                   prism=t_prism, setup=setup, scan=scan, evals=evals.group(1) if evals else "",
                   kd=kd_scan, igl=igl_t, e_prism=e_prism, e_igl=igl_err,
                   wall=f"{prism_wall:.1f} / {kd_wall:.1f}")
        rows.append(row)
        print(f"{table} {row['mesh']} {r}^3 band {band_rel}: {n} band samples; prism "
              f"{t_prism:.2f} s ({setup:.2f} + {scan:.2f}), kd-tree grid {kd_scan:.2f} s, "
              f"libigl {igl_t if igl_t is None else round(igl_t, 2)} s", file=sys.stderr)

    head = ("| table | mesh (triangles) | grid | band | band samples | prism s (setup + scan) | "
            "prism Msamples/s | evals/sample | kd-tree grid s | ratio | libigl band samples s | "
            "ratio | libigl Msamples/s | prism err/h | libigl err/h |\n"
            "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | "
            "---: | ---: | ---: |\n")
    lines = []
    for x in rows:
        igl_s = f"{x['igl']:.2f}" if x["igl"] is not None else "–"
        igl_r = f"{x['igl'] / x['prism']:.1f}" if x["igl"] is not None else "–"
        igl_rate = f"{x['n'] / x['igl'] / 1e6:.2f}" if x["igl"] else "–"
        lines.append(
            f"| {x['table']} | {x['mesh']} | {x['res']} | {x['band']} | {x['n']} | "
            f"{x['prism']:.2f} ({x['setup']:.2f} + {x['scan']:.2f}) | "
            f"{x['n'] / x['prism'] / 1e6:.2f} | {x['evals']} | {x['kd']:.2f} | "
            f"{x['kd'] / x['prism']:.1f} | {igl_s} | {igl_r} | {igl_rate} | "
            f"{x['e_prism']:.1e} | {x['e_igl']} |")
    table = head + "\n".join(lines) + "\n"
    print(table)
    if a.out:
        pathlib.Path(a.out).write_text(table)


if __name__ == "__main__":
    main()
