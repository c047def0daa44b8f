"""`isokit.Mesh`: the `(V, F)` pair that `Shape.mesh` and `Field.mesh` return."""

from __future__ import annotations

import numpy as np


class Mesh(tuple):
    """A triangle mesh as the pair ``(V, F)``: float64 ``(n, 3)`` vertices and int64
    ``(m, 3)`` triangles, counter-clockwise seen from outside. Unpacks as a tuple
    (``V, F = shape.mesh()``); ``.vertices``, ``.faces``, ``.stats`` (what the meshing
    reported, a dict or None), ``.volume()``, ``.to_trimesh()``."""

    def __new__(cls, vertices, faces, stats=None):
        self = super().__new__(cls, (vertices, faces))
        self.stats = stats
        return self

    def __getnewargs__(self):
        return (self[0], self[1], self.stats)

    @property
    def vertices(self) -> np.ndarray:
        """The ``(n, 3)`` float64 vertices."""
        return self[0]

    @property
    def faces(self) -> np.ndarray:
        """The ``(m, 3)`` int64 triangles."""
        return self[1]

    def volume(self) -> float:
        """The enclosed volume (divergence theorem; positive for a closed, outward-oriented
        mesh)."""
        v, f = self
        if len(f) == 0:
            return 0.0
        a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)

    def to_trimesh(self, **kwargs):
        """The mesh as a ``trimesh.Trimesh`` (needs trimesh: ``pip install trimesh``);
        keyword arguments go to its constructor (``process=False`` by default, keeping the
        vertices as they are)."""
        try:
            import trimesh
        except ImportError as e:
            raise ImportError("to_trimesh needs trimesh: pip install trimesh") from e
        kwargs.setdefault("process", False)
        return trimesh.Trimesh(vertices=self[0], faces=self[1], **kwargs)

    def __repr__(self):
        return f"isokit.Mesh({len(self[0])} vertices, {len(self[1])} triangles)"
