"""isokit's fast winding number for oriented point clouds against libigl's, on the same
cloud, the same per-point areas and the same query points.

    ISOKIT_SIGN_CLOUDS=/tmp/clouds cargo test -p isokit-points --test sign winding
    python tests/peers/check_winding.py /tmp/clouds

The test writes the cloud (20,000 area-uniform samples of a pocketed blob with exact face
normals) with isokit's Voronoi areas, and 2000 random query points in and around it with
isokit's tree at beta 2 and 8 and the direct sum. Here libigl's
`igl.fast_winding_number(P, N, A, Q, expansion_order, beta)` runs on the same input at
orders 1-3, beta 2 (order 3 raised MemoryError in the pip build tried), and exactly
(beta 0). Never run in CI: it needs the peers of
tests/peers/requirements.txt.
"""

import sys
import time

import numpy as np


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else "/tmp/clouds"
    import igl
    c = np.loadtxt(f"{d}/winding-cloud.txt")
    q = np.loadtxt(f"{d}/winding-queries.txt")
    P, N, A = (np.ascontiguousarray(c[:, 0:3]), np.ascontiguousarray(c[:, 3:6]),
               np.ascontiguousarray(c[:, 6]))
    Q = np.ascontiguousarray(q[:, 0:3])
    tree2, tree8, direct = q[:, 3], q[:, 4], q[:, 5]
    t = time.perf_counter()
    exact = igl.fast_winding_number(P, N, A, Q, 2, 0.0)
    te = time.perf_counter() - t
    print(f"{len(P)} samples, {len(Q)} queries")

    def row(name, v):
        e = np.abs(v - direct)
        sign = int(np.sum((v > 0.5) != (direct > 0.5)))
        print(f"{name:34s} max |w - direct sum| {e.max():.2e}  RMS {np.sqrt(np.mean(e**2)):.2e}"
              f"  inside/outside differs at {sign}")

    row("libigl exact (beta 0)", exact)
    row("isokit tree, beta 2 (order 1)", tree2)
    row("isokit tree, beta 8 (order 1)", tree8)
    for order in (1, 2, 3):
        t = time.perf_counter()
        try:
            v = igl.fast_winding_number(P, N, A, Q, order, 2.0)
        except MemoryError as e:  # order 3 fails this way in the pip build tried
            print(f"libigl order {order}, beta 2: failed ({e!r})")
            continue
        row(f"libigl order {order}, beta 2 ({time.perf_counter() - t:.3f} s)", v)
    print(f"(libigl exact: {te:.3f} s)")


if __name__ == "__main__":
    main()
