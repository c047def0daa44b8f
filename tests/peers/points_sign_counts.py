"""Wrong signs far from the surface in a sampled point-cloud field, against a mesh's exact
signed distance (libigl, pseudonormal sign): the nodes farther than 3 grid spacings from the
surface whose field sign differs.

    cargo run --release -p isokit-points --example points_grid -- CLOUD.ply 64 winding F.npy
    python tests/peers/points_sign_counts.py MESH.ply F.npy X0 Y0 Z0 SPACING

(origin and spacing as the example prints them). Never run in CI: it needs the peers of
tests/peers/requirements.txt.
"""

import sys

import numpy as np


def main():
    import igl
    import trimesh
    mesh, field = sys.argv[1], np.load(sys.argv[2])
    o = np.array([float(v) for v in sys.argv[3:6]])
    h = float(sys.argv[6])
    m = trimesh.load(mesh, process=False)
    nz, ny, nx = field.shape
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    x = o + h * np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1).astype(np.float64)
    d, _, _, _ = igl.signed_distance(x, np.asarray(m.vertices, np.float64),
                                     np.asarray(m.faces, np.int64),
                                     sign_type=igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL)
    f = field.ravel()
    far = np.abs(d) > 3 * h
    wrong = far & ((f < 0) != (d < 0))
    print(f"{int(wrong.sum())} wrong of {int(far.sum())} nodes beyond 3 spacings "
          f"({int((wrong & (f < 0)).sum())} reported inside)")


if __name__ == "__main__":
    main()
