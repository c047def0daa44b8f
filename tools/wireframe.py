"""A flat-shaded wireframe PNG of a triangle mesh (a three-quarter orthographic view), for
looking at how a mesher places its triangles; numpy, trimesh (to read the mesh) and zlib.

    python tools/wireframe.py part.obj part.png [--width 640 --height 420]

Written for the pictures of adaptive dual contouring in README.md (`--mesher dual --error`).
"""
import struct
import zlib

import numpy as np
import trimesh


def png(path, img):
    """Writes an (H, W, 3) uint8 image as an 8-bit RGB PNG."""
    h, w = img.shape[:2]
    raw = b"".join(b"\x00" + img[y].tobytes() for y in range(h))
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))

def draw(mesh_path, out, W=640, H=420):
    """Faces flat-shaded by their normal (a z-buffer keeps the nearest), then the edges of
    front-facing triangles where no nearer face hides them."""
    m = trimesh.load(mesh_path, process=False)
    V, F = np.asarray(m.vertices), np.asarray(m.faces)
    # A three-quarter view: rotate about z then x.
    a, b = np.radians(35), np.radians(-55)
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    P = V @ (Rx @ Rz).T
    lo, hi = P[:, :2].min(0), P[:, :2].max(0)
    s = 0.92 * min(W / (hi[0] - lo[0]), H / (hi[1] - lo[1]))
    c = (lo + hi) / 2
    xy = (P[:, :2] - c) * s + [W / 2, H / 2]
    img = np.full((H, W, 3), 255, np.uint8)
    # Faces shaded by their normal's z (flat shading, painter's order), then edges.
    n = np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-30
    vis = n[:, 2] > 0
    order = np.argsort(P[F, 2].mean(1))
    yy, xx = np.mgrid[0:H, 0:W]
    zbuf = np.full((H, W), -np.inf)
    for f in order:
        if not vis[f]:
            continue
        t = xy[F[f]]
        x0, y0 = np.floor(t.min(0)).astype(int)
        x1, y1 = np.ceil(t.max(0)).astype(int)
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, W - 1), min(y1, H - 1)
        if x1 < x0 or y1 < y0:
            continue
        X, Y = xx[y0:y1 + 1, x0:x1 + 1] + 0.5, yy[y0:y1 + 1, x0:x1 + 1] + 0.5
        def e(p, q):
            return (q[0] - p[0]) * (Y - p[1]) - (q[1] - p[1]) * (X - p[0])
        w0, w1, w2 = e(t[1], t[2]), e(t[2], t[0]), e(t[0], t[1])
        inside = ((w0 >= 0) & (w1 >= 0) & (w2 >= 0)) | ((w0 <= 0) & (w1 <= 0) & (w2 <= 0))
        # w0 + w1 + w2 is twice the triangle's signed area, the same at every pixel.
        area = (t[2][0] - t[1][0]) * (t[0][1] - t[1][1]) - (t[2][1] - t[1][1]) * (t[0][0] - t[1][0])
        if area == 0:
            continue
        # Depth (larger z is nearer) interpolated over the face: the z-buffer keeps the
        # nearest face of each pixel, so hidden edges are not drawn below.
        z = (w0 * P[F[f, 0], 2] + w1 * P[F[f, 1], 2] + w2 * P[F[f, 2], 2]) / area
        zsub = zbuf[y0:y1 + 1, x0:x1 + 1]
        near = inside & (z > zsub)
        zsub[near] = z[near]
        g = int(90 + 150 * n[f, 2])
        img[y0:y1 + 1, x0:x1 + 1][near] = (g, g, min(255, g + 20))
    # An edge point is drawn where it is not behind the nearest face there (within two
    # pixels' worth of depth).
    eps = 2.0 / s
    for f in np.nonzero(vis)[0]:
        for i in range(3):
            a_, b_ = F[f, i], F[f, (i + 1) % 3]
            p, q = xy[a_], xy[b_]
            k = int(max(abs(q - p).max(), 1)) + 1
            u = np.linspace(0, 1, k)
            pts = np.round(p + u[:, None] * (q - p)).astype(int)
            z = P[a_, 2] + u * (P[b_, 2] - P[a_, 2])
            ok = (pts[:, 0] >= 0) & (pts[:, 0] < W) & (pts[:, 1] >= 0) & (pts[:, 1] < H)
            pts, z = pts[ok], z[ok]
            shown = z >= zbuf[pts[:, 1], pts[:, 0]] - eps
            img[pts[shown, 1], pts[shown, 0]] = (30, 30, 40)
    png(out, img[::-1].copy())

if __name__ == "__main__":
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mesh")
    ap.add_argument("png")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=420)
    a = ap.parse_args()
    draw(a.mesh, a.png, a.width, a.height)
