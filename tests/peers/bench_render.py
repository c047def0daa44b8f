"""isokit's CPU ray caster against Open3D's CPU ray casting of a marching-cubes mesh of the same
field at the same resolution (issue 8): time per frame and image difference, in one run.

Three fields, sampled once by isokit to a NRRD volume of 256 samples along the longest side:

- sphere:  `isokit sample sphere` (radius 1), exact SDF;
- torus:   `isokit sample torus` (R 0.75, r 0.25, axis z), exact SDF;
- trefoil: `isokit sdf data/trefoil.ply` (kd-tree, every sample exact): a mesh's SDF.

For each field and the same 512x512 camera (isokit's default framing of a volume: 45 degree
vertical field of view from direction (1, 0.7, 1.4), reproduced here ray for ray from
`Camera::framing` and `subpixel_ray`: pixel centres, row 0 at the top, unit directions):

- isokit: `isokit render FIELD.nrrd --backend cpu --stats`, default (tricubic) and
  `--filter trilinear`, one run that also writes the G-buffer (`--gbuffer g.exr`, for the
  image comparison) then N runs of the image alone (normals, no Hessian); the time per frame is the
  median of the `trace_seconds` it reports (the ray casting, brick-cache fill included;
  the warm frame time is the median of the `warm_trace_seconds` of `--warm-frames N`, the
  same camera traced again in the process with the brick cache kept;
  loading the volume and shading are `prepare_seconds` / `shade_seconds`, not counted);
  depth (`Z`), position and normal come from the G-buffer (read by the small EXR reader below).
- Open3D: the same field meshed by `isokit mesh FIELD.nrrd` (marching cubes, same samples),
  `o3d.t.geometry.RaycastingScene`, the same rays in float32; the time per frame is the median
  of N `cast_rays` calls after a first call (the BVH is built on the first call: reported
  separately with `add_triangles`, as is the meshing).

Image difference against an exact reference: ray-sphere in closed form; ray-torus by sphere
tracing the exact SDF in float64 and Newton polishing; for the trefoil the original triangles
(the zero set of the mesh's exact SDF) ray cast by Open3D. Per renderer: pixels whose hit/miss
differs from the reference, |depth error| along the ray over pixels both hit (in voxels:
world / spacing; mean, 95th percentile), the distance of the hit point from the exact surface
(voxels), and the angle between normals (Open3D: flat triangle normals as `cast_rays` returns
them, and normals interpolated from area-weighted vertex normals at the hit's barycentric
coordinates). isokit against Open3D directly as well.

    python tests/peers/bench_render.py --isokit target/release/isokit \
        --out /tmp/bench_render

Writes results.md, results.json and side-by-side PNGs (isokit normals | Open3D normals |
|depth difference|) to --out. Needs numpy and open3d (tests/peers/requirements.txt). About
75 seconds on 2 cores, a third of it sampling the trefoil's SDF and writing NRRDs.
"""

import argparse
import datetime
import json
import os
import pathlib
import platform
import re
import statistics
import struct
import subprocess
import time
import zlib

import numpy as np
import open3d as o3d

ROOT = pathlib.Path(__file__).resolve().parents[2]
FROM = np.array([1.0, 0.7, 1.4])  # camera_for_scene's default direction
FOV = 45.0


# ---------------------------------------------------------------------------- file formats


def nrrd_header(path):
    """dims (x, y, z), origin and spacing of an isokit NRRD (axis-aligned, uniform)."""
    head = {}
    with open(path, "rb") as f:
        for line in f:
            line = line.decode().strip()
            if not line:
                break
            if ":" in line and not line.startswith("#"):
                k, v = line.split(":", 1)
                head[k.strip()] = v.strip()
    dims = [int(x) for x in head["sizes"].split()]
    dirs = [[float(x) for x in d.strip("()").split(",")] for d in head["space directions"].split()]
    spacing = np.array([dirs[i][i] for i in range(3)])
    origin = np.array([float(x) for x in head["space origin"].strip("()").split(",")])
    return dims, origin, spacing


def read_exr(path):
    """A minimal OpenEXR reader for what isokit writes: one part, FLOAT channels, scan lines or
    one-level tiles, NO or RLE compression. Returns {channel: (h, w) float32 array}."""
    d = open(path, "rb").read()
    magic, ver = struct.unpack_from("<II", d, 0)
    if magic != 20000630 or ver & 0x1800:
        raise ValueError(f"{path}: not a single-part OpenEXR")
    tiled, i, attr = bool(ver & 0x200), 8, {}
    while d[i]:
        j = d.index(b"\0", i)
        k = d.index(b"\0", j + 1)
        (n,) = struct.unpack_from("<i", d, k + 1)
        attr[d[i:j].decode()] = d[k + 5:k + 5 + n]
        i = k + 5 + n
    i += 1
    chl, chans, p = attr["channels"], [], 0
    while chl[p]:
        q = chl.index(b"\0", p)
        chans.append((chl[p:q].decode(), struct.unpack_from("<i", chl, q + 1)[0]))
        p = q + 17
    comp = attr["compression"][0]
    if any(t != 2 for _, t in chans) or comp not in (0, 1):
        raise ValueError(f"{path}: only FLOAT channels with NO or RLE compression are read")
    x0, y0, x1, y1 = struct.unpack("<4i", attr["dataWindow"])
    W, H = x1 - x0 + 1, y1 - y0 + 1
    tw, th = struct.unpack_from("<II", attr["tiles"]) if tiled else (W, 1)
    out = {c: np.zeros((H, W), np.float32) for c, _ in chans}
    for off in np.frombuffer(d, "<u8", -(-W // tw) * -(-H // th), i):
        off = int(off)
        if tiled:
            tx, ty, _, _, n = struct.unpack_from("<5i", d, off)
            xa, ya, off = tx * tw, ty * th, off + 20
        else:
            ya, n = struct.unpack_from("<2i", d, off)
            xa, ya, off = 0, ya - y0, off + 8
        w, h = min(tw, W - xa), min(th, H - ya)
        size = w * h * 4 * len(chans)
        raw = d[off:off + n] if n == size else unrle(d[off:off + n], size)
        a = np.frombuffer(raw, "<f4").reshape(h, len(chans), w)
        for c, (name, _) in enumerate(chans):
            out[name][ya:ya + h, xa:xa + w] = a[:, c, :]
    return out


def unrle(src, size):
    """OpenEXR RLE: runs, then the byte predictor, then the two halves interleaved."""
    buf, i = bytearray(), 0
    while i < len(src):
        n = src[i] - 256 if src[i] > 127 else src[i]
        if n < 0:
            buf += src[i + 1:i + 1 - n]
            i += 1 - n
        else:
            buf += bytes([src[i + 1]]) * (n + 1)
            i += 2
    t = np.frombuffer(bytes(buf), np.uint8).astype(np.int64)
    if len(t) != size:
        raise ValueError("EXR: RLE block has the wrong size")
    t[1:] -= 128
    t = (np.cumsum(t) & 255).astype(np.uint8)
    o = np.empty(size, np.uint8)
    o[0::2], o[1::2] = t[:(size + 1) // 2], t[(size + 1) // 2:]
    return o.tobytes()


def write_png(path, rgb):
    """8-bit RGB PNG from an (h, w, 3) array in [0, 1]."""
    a = (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8)
    raw = b"".join(b"\0" + row.tobytes() for row in a)
    chunk = lambda t, b: struct.pack(">I", len(b)) + t + b + struct.pack(">I", zlib.crc32(t + b))  # noqa: E731
    head = struct.pack(">IIBBBBB", a.shape[1], a.shape[0], 8, 2, 0, 0, 0)
    pathlib.Path(path).write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", head)
                                   + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


# ---------------------------------------------------------------------------------- camera


def camera_rays(lo, hi, w, h):
    """isokit's `Camera::framing(bounds, FROM, 45 degrees)` and the pixel-centre rays of
    `subpixel_ray` (single view, perspective), in float64: eye and (h, w, 3) unit dirs."""
    radius = max(0.5 * np.linalg.norm(hi - lo), 1e-6)
    d = FROM / np.linalg.norm(FROM)
    aspect = w / h
    half = 0.5 * np.radians(FOV)
    if aspect < 1.0:
        half = np.arctan(np.tan(half) * aspect)
    dist = radius / max(np.sin(half), 1e-3) * 1.05
    up = np.array([0.0, 0.0, 1.0]) if np.linalg.norm(np.cross(d, [0, 1, 0])) < 1e-3 else np.array([0.0, 1.0, 0.0])
    c = 0.5 * (lo + hi)
    eye = c + d * dist
    fwd = (c - eye) / np.linalg.norm(c - eye)
    right = np.cross(fwd, up)
    right /= np.linalg.norm(right)
    tup = np.cross(right, fwd)
    hh = np.tan(0.5 * np.radians(FOV))
    px, py = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    sx = (2 * px / w - 1) * hh * aspect
    sy = (1 - 2 * py / h) * hh
    dirs = fwd + sx[..., None] * right + sy[..., None] * tup
    return eye, dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)


# ------------------------------------------------------------------------------ references


def sphere_sdf(p, r=1.0):
    return np.linalg.norm(p, axis=-1) - r


def sphere_normal(p):
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


def torus_sdf(p, R=0.75, r=0.25):
    q = np.linalg.norm(p[..., :2], axis=-1) - R
    return np.hypot(q, p[..., 2]) - r


def torus_normal(p, R=0.75):
    rho = np.linalg.norm(p[..., :2], axis=-1, keepdims=True)
    n = np.concatenate([p[..., :2] * (1 - R / rho), p[..., 2:]], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def ref_sphere(eye, dirs):
    b = dirs @ eye
    c = eye @ eye - 1.0
    disc = b * b - c
    t = np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)
    p = eye + t[..., None] * dirs
    return t, np.where(np.isfinite(t)[..., None], sphere_normal(np.nan_to_num(p)), 0)


def ref_trace(sdf, normal, eye, dirs, tmax, eps=1e-11, iters=6000):
    """Sphere tracing of an exact SDF in float64, then Newton steps on f(eye + t d) = 0."""
    D = dirs.reshape(-1, 3)
    t = np.zeros(len(D))
    hit = np.zeros(len(D), bool)
    best = np.full(len(D), np.inf)
    act = np.arange(len(D))
    for _ in range(iters):
        f = sdf(eye + t[act, None] * D[act])
        best[act] = np.minimum(best[act], f)
        done = f < eps
        hit[act[done]] = True
        t[act[~done]] += f[~done]
        act = act[~done & (t[act] < tmax)]
        if not len(act):
            break
    hit[act[best[act] < 1e-7]] = True  # grazing rays still creeping along the surface
    for _ in range(4):
        p = eye + t[hit, None] * D[hit]
        g = np.einsum("ij,ij->i", normal(p), D[hit])
        t[hit] -= sdf(p) / np.where(np.abs(g) > 1e-3, g, -1e-3)
    t[~hit] = np.inf
    p = eye + np.where(hit, t, 0)[:, None] * D
    n = np.where(hit[:, None], normal(p), 0)
    return t.reshape(dirs.shape[:-1]), n.reshape(dirs.shape)


# ---------------------------------------------------------------------------------- runners


def run(cmd):
    t = time.perf_counter()
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    wall = time.perf_counter() - t
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))}:\n{r.stderr}")
    return r, wall


def isokit_fixed(exe, vol, tmp, filt, runs):
    """Median trace seconds of an 8x8 frame: the per-frame cost that does not scale with the
    rays (mostly filling the brick cache with the active bricks)."""
    cmd = [exe, "render", vol, "-o", tmp / "fixed.png", "--backend", "cpu", "--stats",
           "--filter", filt, "--width", 8, "--height", 8]
    return statistics.median(json.loads(run(cmd)[0].stdout)["trace_seconds"] for _ in range(runs))


def isokit_render(exe, vol, tmp, filt, runs):
    png, exr = tmp / f"{vol.stem}_{filt}.png", tmp / f"{vol.stem}_{filt}.exr"
    cmd = [exe, "render", vol, "-o", png, "--backend", "cpu", "--stats",
           "--filter", filt, "--width", 512, "--height", 512, "--warm-frames", runs]
    # The first run writes the G-buffer (with its curvature channels, the Hessian per pixel)
    # and warms the page cache; the timed runs render the image alone, as a user looking at
    # it does (normals only: Open3D's `cast_rays` returns depths and normals).
    run(cmd[:5] + ["--gbuffer", exr] + cmd[5:])
    stats = []
    for _ in range(runs):
        r, wall = run(cmd)
        s = json.loads(r.stdout)
        s["wall"] = wall
        stats.append(s)
    g = read_exr(exr)
    hit = g["A"] > 0
    P = np.stack([g["P.X"], g["P.Y"], g["P.Z"]], -1).astype(float)
    N = np.stack([g["N.X"], g["N.Y"], g["N.Z"]], -1).astype(float)
    t = np.where(hit, g["Z"].astype(float), np.inf)
    med = lambda k: statistics.median(s[k] for s in stats)  # noqa: E731
    # Warm frames: the same camera traced again in the same process, the brick cache kept.
    warm = [w for s in stats for w in s["warm_trace_seconds"]]
    timing = dict(frame_s=med("trace_seconds"), frame_all=[s["trace_seconds"] for s in stats],
                  warm_s=statistics.median(warm), warm_all=warm,
                  prepare_s=med("prepare_seconds"), wall_s=med("wall"),
                  samples_per_ray=stats[0]["samples_per_ray"], caps=stats[0]["caps"],
                  bricks=stats[0]["bricks_loaded"], fixed_s=isokit_fixed(exe, vol, tmp, filt, runs))
    return dict(t=t, P=P, N=N, hit=hit, timing=timing, png=png)


def o3d_cast(V, F, rays, runs):
    """Open3D: BVH build (+ first cast) timed apart, then `runs` casts; median per frame."""
    t0 = time.perf_counter()
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(V), o3d.core.Tensor(F))
    ans = scene.cast_rays(rays)
    build = time.perf_counter() - t0
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        ans = scene.cast_rays(rays)
        times.append(time.perf_counter() - t)
    return scene, {k: v.numpy() for k, v in ans.items()}, build, times


def vertex_normals(V, F):
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])  # area-weighted
    vn = np.zeros_like(V)
    for k in range(3):
        np.add.at(vn, F[:, k], n)
    return vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-30)


def o3d_frame(ans, V, F):
    t = ans["t_hit"].astype(float)
    hit = np.isfinite(t)
    prim = np.where(hit, ans["primitive_ids"], 0).astype(np.int64)
    flat = np.where(hit[..., None], ans["primitive_normals"].astype(float), 0)
    uv = ans["primitive_uvs"].astype(float)
    vn = vertex_normals(V.astype(float), F.astype(np.int64))[F[prim]]  # (h, w, 3 vertices, 3)
    smooth = (1 - uv[..., :1] - uv[..., 1:]) * vn[..., 0, :] + uv[..., :1] * vn[..., 1, :] \
        + uv[..., 1:] * vn[..., 2, :]
    smooth /= np.maximum(np.linalg.norm(smooth, axis=-1, keepdims=True), 1e-30)
    return dict(t=np.where(hit, t, np.inf), hit=hit, N=flat, N_smooth=np.where(hit[..., None], smooth, 0))


# ---------------------------------------------------------------------------------- metrics


def angle(a, b):
    return np.degrees(np.arccos(np.clip(np.einsum("...i,...i->...", a, b), -1, 1)))


def compare(a, b, h, dist=None, eye=None, dirs=None, normal="N"):
    """a against b (the reference when dist is given): mask disagreement, depth, normals."""
    both = a["hit"] & b["hit"]
    dz = np.abs(a["t"][both] - b["t"][both]) / h
    na = angle(a[normal][both], b["N"][both])
    r = dict(hits=int(a["hit"].sum()), mask=int((a["hit"] != b["hit"]).sum()),
             dz_mean=float(dz.mean()), dz_p95=float(np.percentile(dz, 95)), dz_max=float(dz.max()),
             n_mean=float(na.mean()), n_p95=float(np.percentile(na, 95)))
    if dist is not None:
        p = eye + a["t"][a["hit"]][:, None] * dirs[a["hit"]]
        s = np.abs(dist(p)) / h
        r.update(s_mean=float(s.mean()), s_p95=float(np.percentile(s, 95)))
    return r


def panel(frames, both_hit_dz, vmax):
    imgs = [np.where(f["hit"][..., None], 0.5 + 0.5 * f["N"], 0.1) for f in frames]
    heat = np.clip(both_hit_dz / vmax, 0, 1)
    imgs.append(np.stack([heat, heat * 0.3, 1 - heat], -1) * (both_hit_dz >= 0)[..., None])
    return np.concatenate(imgs, axis=1)


# ------------------------------------------------------------------------------------ main


def machine():
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo")
                if l.startswith("model name")), platform.machine())
    mem = next((int(l.split()[1]) / 2**20 for l in open("/proc/meminfo")
                if l.startswith("MemTotal")), 0)
    return f"{os.cpu_count()} cores, {cpu}, {mem:.0f} GiB"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--isokit", default=str(ROOT / "target/release/isokit"))
    ap.add_argument("--out", default="/tmp/bench_render")
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--runs", type=int, default=5, help="timed frames per renderer (median)")
    ap.add_argument("--fields", nargs="+", default=["sphere", "torus", "trefoil"])
    a = ap.parse_args()
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    exe, W, H = a.isokit, 512, 512
    trefoil_mesh = o3d.io.read_triangle_mesh(str(ROOT / "data/trefoil.ply"))
    TV = np.asarray(trefoil_mesh.vertices, np.float32)
    TF = np.asarray(trefoil_mesh.triangles, np.uint32)
    make = {
        "sphere": [exe, "sample", "sphere", "--res", a.res, "--pad", 0.05],
        "torus": [exe, "sample", "torus", "--res", a.res, "--pad", 0.05],
        "trefoil": [exe, "sdf", ROOT / "data/trefoil.ply", "--res", a.res, "--padding", 0.05],
    }
    results, rows, diffs = {}, [], []
    for name in a.fields:
        vol = out / f"{name}.nrrd"
        _, field_s = run(make[name] + ["-o", vol])
        dims, origin, spacing = nrrd_header(vol)
        h = float(spacing[0])
        lo, hi = origin, origin + (np.array(dims) - 1) * spacing
        eye, dirs = camera_rays(lo, hi, W, H)
        tmax = np.linalg.norm(eye - 0.5 * (lo + hi)) + np.linalg.norm(hi - lo)
        # Exact reference.
        if name == "sphere":
            rt, rn = ref_sphere(eye, dirs)
            dist = sphere_sdf
        elif name == "torus":
            rt, rn = ref_trace(torus_sdf, torus_normal, eye, dirs, tmax)
            dist = torus_sdf
        else:
            rscene, rans, _, _ = o3d_cast(TV, TF, o3d.core.Tensor(
                np.concatenate([np.broadcast_to(eye, dirs.shape), dirs], -1).astype(np.float32)), 0)
            rt = np.where(np.isfinite(rans["t_hit"]), rans["t_hit"].astype(float), np.inf)
            rn = rans["primitive_normals"].astype(float)

            def dist(p, s=rscene):
                return s.compute_distance(o3d.core.Tensor(p.astype(np.float32))).numpy()
        ref = dict(t=rt, N=rn, hit=np.isfinite(rt))
        # isokit.
        iso = {f: isokit_render(exe, vol, out, f, a.runs) for f in ("tricubic", "trilinear")}
        # Check the reconstructed camera against isokit's own G-buffer.
        g = iso["tricubic"]
        v = g["P"][g["hit"]] - eye
        cam_dev = float(angle(v / np.linalg.norm(v, axis=1, keepdims=True), dirs[g["hit"]]).max())
        z_dev = float(np.abs(np.linalg.norm(v, axis=1) - g["t"][g["hit"]]).max() / h)
        # Open3D on isokit's marching-cubes mesh of the same field.
        mc = out / f"{name}_mc.ply"
        r, mc_s = run([exe, "mesh", vol, "-o", mc])
        mc_core = float(re.search(r"triangles in ([0-9.]+) s", r.stderr).group(1))
        m = o3d.io.read_triangle_mesh(str(mc))
        V, F = np.asarray(m.vertices, np.float32), np.asarray(m.triangles, np.uint32)
        rays = o3d.core.Tensor(np.concatenate([np.broadcast_to(eye, dirs.shape), dirs], -1).astype(np.float32))
        _, ans, build_s, casts = o3d_cast(V, F, rays, a.runs)
        o3 = o3d_frame(ans, V, F)
        flip = np.einsum("...i,...i->...", o3["N"], dirs)[o3["hit"]].mean() > 0
        if flip:  # normals must face the eye, as isokit's outward ones do
            o3["N"], o3["N_smooth"] = -o3["N"], -o3["N_smooth"]
        field = f"{name} ({'×'.join(map(str, dims))}, h = {h:.4g})"
        for label, fr, tm in [
            ("isokit tricubic (default)", iso["tricubic"], iso["tricubic"]["timing"]),
            ("isokit trilinear", iso["trilinear"], iso["trilinear"]["timing"]),
            ("Open3D, flat normals", o3, dict(frame_s=statistics.median(casts), frame_all=casts,
                                               build_s=build_s, mc_s=mc_s, mc_core_s=mc_core,
                                               triangles=len(F))),
        ]:
            r = compare(fr, ref, h, dist, eye, dirs)
            r.update(field=field, renderer=label, **tm)
            rows.append(r)
            print(json.dumps({k: v for k, v in r.items() if k != "frame_all"}), flush=True)
        r = compare(o3, ref, h, dist, eye, dirs, normal="N_smooth")
        rows.append(dict(rows[-1], renderer="Open3D, interpolated normals", n_mean=r["n_mean"],
                         n_p95=r["n_p95"], same=True))
        for label, fr in [("tricubic", iso["tricubic"]), ("trilinear", iso["trilinear"])]:
            d = compare(fr, o3, h)
            d.update(field=field, pair=f"isokit {label} vs Open3D",
                     slower=fr["timing"]["frame_s"] / statistics.median(casts),
                     warm_ratio=fr["timing"]["warm_s"] / statistics.median(casts))
            diffs.append(d)
            print(json.dumps(d), flush=True)
        both = iso["tricubic"]["hit"] & o3["hit"]
        dz = np.where(both, np.abs(iso["tricubic"]["t"] - np.where(both, o3["t"], 0)) / h, -1)
        write_png(out / f"{name}_isokit_open3d.png", panel([iso["tricubic"], o3], dz, 0.25))
        results[name] = dict(dims=dims, spacing=h, field_s=field_s, cam_dev_deg=cam_dev,
                             z_dev_vox=z_dev, mc_triangles=len(F), flipped_o3d_normals=bool(flip),
                             ref_hits=int(ref["hit"].sum()), eye=eye.tolist())
        print(json.dumps({name: results[name]}), flush=True)

    cmd = (f"python tests/peers/bench_render.py --isokit {a.isokit} "
           f"--out {a.out} --res {a.res} --runs {a.runs}")
    ver = subprocess.run([exe, "--version"], capture_output=True, text=True).stdout.strip()
    lines = [
        f"Machine: {machine()}; {platform.system()} {platform.release()}. Date: "
        f"{datetime.date.today()}. {ver}, Open3D {o3d.__version__}, numpy {np.__version__}, "
        f"Python {platform.python_version()}.",
        "",
        f"Command: `{cmd}`",
        "",
        f"512×512 pixels, one ray per pixel; frame seconds are medians of {a.runs} frames "
        "(isokit: `trace_seconds` of `--stats`, one process per frame, filling the brick cache "
        "included; *fixed* = the same for an 8×8 frame, the part that does not scale with the "
        "rays; Open3D: `cast_rays` after a first call that builds the BVH). *Setup*: isokit "
        "loading the NRRD and building its volume (and the whole process's wall time); Open3D "
        "marching cubes by `isokit mesh` (and its wall time with reading the NRRD and writing "
        "the PLY), then `add_triangles` and the first `cast_rays`. Errors in "
        "voxels (world / spacing h) against the exact surface; *mask* = pixels whose hit/miss "
        "differs from the exact one; depth = |t − t_exact| along the ray over pixels both hit; "
        "surface = distance of the hit point from the exact surface.",
        "",
        "| field (samples, h) | renderer | frame s (median) | setup s | hits | mask ≠ exact "
        "| depth err mean / p95 (vox) | surface err mean / p95 (vox) | normal err mean / p95 (°) |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        if "prepare_s" in r:
            frame = f"{r['frame_s']:.3f} ({r['fixed_s']:.3f} fixed; warm {r['warm_s']:.4f})"
            setup = f"{r['prepare_s']:.2f} load (wall {r['wall_s']:.2f})"
        else:
            frame = f"{r['frame_s']:.4f}"
            setup = (f"{r['mc_core_s']:.2f} MC ({r['mc_s']:.2f} with I/O) + {r['build_s']:.2f} BVH, "
                     f"{r['triangles'] / 1e3:.0f}k tris")
        cells = [frame, setup, r["hits"], r["mask"], f"{r['dz_mean']:.4f} / {r['dz_p95']:.4f}",
                 f"{r['s_mean']:.4f} / {r['s_p95']:.4f}"]
        if r.get("same"):  # the same cast, other normals
            cells = ["″"] * len(cells)
        lines.append(f"| {r['field']} | {r['renderer']} | " + " | ".join(map(str, cells))
                     + f" | {r['n_mean']:.3f} / {r['n_p95']:.3f} |")
    lines += [
        "",
        "isokit against Open3D directly (same pixels; normals: isokit's against Open3D's flat "
        "ones); *isokit ÷ Open3D* is isokit's frame time over Open3D's, from the same run "
        "(cold: one process per frame, the brick cache filled; warm: further frames of the same "
        "camera in the process, `--warm-frames`, against `cast_rays` after the BVH build):",
        "",
        "| field | pair | isokit ÷ Open3D time (cold) | warm | mask ≠ | depth diff mean / p95 / max (vox) "
        "| normal diff mean / p95 (°) |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for d in diffs:
        lines.append(f"| {d['field']} | {d['pair']} | {d['slower']:.1f}× | {d['warm_ratio']:.1f}× | {d['mask']} | "
                     f"{d['dz_mean']:.4f} / {d['dz_p95']:.4f} / {d['dz_max']:.3f} | "
                     f"{d['n_mean']:.2f} / {d['n_p95']:.2f} |")
    lines += ["", "Camera check (isokit's G-buffer hit points against the rays rebuilt here): "
              + "; ".join(f"{k}: max ray angle {v['cam_dev_deg']:.1e}°, max |Z − |P − eye|| "
                          f"{v['z_dev_vox']:.1e} vox" for k, v in results.items())]
    text = "\n".join(lines) + "\n"
    (out / "results.md").write_text(text)
    (out / "results.json").write_text(json.dumps(dict(rows=rows, diffs=diffs, fields=results), indent=1))
    print(text)


if __name__ == "__main__":
    main()
