"""Shared helpers of the isokit Python package's tests (pytest).

Run: `pip install ./crates/isokit-python` (or `maturin develop`), then
`python -m pytest crates/isokit-python/tests` (tools/test.sh does both in .venv).
"""

import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]
SEED = 20261201


@pytest.fixture
def rng():
    return np.random.default_rng(SEED)


@pytest.fixture(scope="session")
def isokit_bin():
    """Runs the `isokit` command (ISOKIT_BIN, else target/{release,debug}/isokit)."""
    env = os.environ.get("ISOKIT_BIN")
    candidates = [pathlib.Path(env)] if env else []
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    candidates += [target / p / "isokit" for p in ("release", "debug")]
    exe = next((p for p in candidates if p.exists()), None)
    if exe is None:
        if os.environ.get("CI"):
            pytest.fail("the isokit binary is not built (set ISOKIT_BIN)")
        pytest.skip("the isokit binary is not built: run `cargo build` or set ISOKIT_BIN")

    def run(*args):
        r = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True)
        assert r.returncode == 0, f"isokit {' '.join(map(str, args))} failed: {r.stderr}"
        return r

    return run


def icosphere(level, radius=1.0):
    """A closed, outward-oriented icosphere (float64 vertices, int64 triangles)."""
    t = (1 + 5**0.5) / 2
    V = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    V = [list(np.array(v) / np.linalg.norm(v)) for v in V]
    F = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    for _ in range(level):
        mid = {}

        def m(a, b):
            k = (min(a, b), max(a, b))
            if k not in mid:
                p = np.array(V[a]) + np.array(V[b])
                V.append(list(p / np.linalg.norm(p)))
                mid[k] = len(V) - 1
            return mid[k]

        G = []
        for a, b, c in F:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            G += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        F = G
    return radius * np.array(V, dtype=np.float64), np.array(F, dtype=np.int64)


def mesh_volume(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)
