"""isokit: distance fields and implicit surfaces from Python.

Build shapes from primitives, meshes, point clouds and volumes; combine them with
``|`` (union), ``&`` (intersection), ``-`` (difference), ``~`` (complement) and the
methods ``smooth_union``, ``offset``, ``shell``, ``morph``, ``translate``, ``rotate``,
``scale``; evaluate them at points, sample them to fields, mesh and render them. Every
call runs the same pipeline as the ``isokit`` command, and ``shape.to_json()`` writes the
scene file that describes the same shape.

Conventions: signed distances are **negative inside** (as libigl; trimesh and pysdf are
positive inside: negate to compare); lengths in world units; field arrays have shape
``(nz, ny, nx)`` with x fastest in memory; images have row 0 at the top.

>>> import isokit, numpy as np
>>> part = isokit.rounded_box(half=(1.2, 0.2, 0.8), radius=0.05) - isokit.cylinder(
...     a=(0, -1, 0), b=(0, 1, 0), radius=0.3)
>>> float(part(np.array([[0.0, 0.0, 0.0]]))[0])  # inside the hole: 0.3 from its wall
0.30000001192092896
>>> V, F = part.mesh(res=64)
>>> frame = part.render(width=256, height=192)
"""

from __future__ import annotations

import inspect as _inspect
import os as _os
from dataclasses import dataclass as _dataclass

import numpy as _np

from . import _isokit
from ._isokit import (
    GBUFFER_CHANNELS,
    SHADING_MODES,
    Cancelled,
    Field,
    Frame,
    Molecule,
    Shape,
    difference,
    intersection,
    load_scene,
    molecule,
    morph_level_set,
    signed_distance,
    smooth_union,
    union,
)
from ._mesh import Mesh

__version__ = _isokit.__version__

__all__ = [
    "Camera", "Cancelled", "Field", "Frame", "GBUFFER_CHANNELS", "Mesh", "Molecule",
    "SHADING_MODES", "Shape", "box", "capsule", "cone", "cylinder", "difference",
    "ellipsoid", "intersection", "load_scene", "mesh", "molecule", "morph",
    "morph_level_set", "plane", "points", "rounded_box", "signed_distance",
    "smooth_union", "sphere", "torus", "union", "volume",
]


@_dataclass(frozen=True)
class Camera:
    """A look-at camera, the scene files' ``camera`` table: ``eye`` looks at ``target``
    with ``up`` upwards and a vertical field of view of ``fov`` degrees. Pass it (or the
    same keys as a dict) as ``render(camera=...)``."""

    eye: tuple = (2.0, 1.4, 2.8)
    target: tuple = (0.0, 0.0, 0.0)
    up: tuple = (0.0, 1.0, 0.0)
    fov: float = 45.0

    def to_dict(self) -> dict:
        """The scene files' form ``{"eye": …, "target": …, "up": …, "fov": …}``."""
        return {"eye": list(self.eye), "target": list(self.target), "up": list(self.up),
                "fov": float(self.fov)}


# --- primitives, from the one vocabulary (isokit_scene::primitives) -------------------

# Positional order of each primitive's parameters (the vocabulary gives names and
# defaults; these orders put the size first and the placement last).
_ORDER = {
    "sphere": ("radius", "center"),
    "box": ("half", "center"),
    "rounded_box": ("half", "radius", "center"),
    "torus": ("major", "minor", "center"),
    "capsule": ("a", "b", "radius"),
    "cylinder": ("a", "b", "radius"),
    "cone": ("a", "b", "ra", "rb"),
    "plane": ("normal", "offset"),
    "ellipsoid": ("radii", "center"),
}

_DOCS = {
    "sphere": ("A ball.", {"radius": "radius, > 0", "center": "centre"}),
    "box": ("An axis-aligned box.", {"half": "half extents (three numbers, or one for a cube), each > 0",
                                     "center": "centre"}),
    "rounded_box": ("A box of outer half extents `half` with edges and corners rounded by `radius`.",
                    {"half": "outer half extents, each > 0",
                     "radius": "rounding radius, from 0 to the smallest half extent",
                     "center": "centre"}),
    "torus": ("A torus around the z axis (rotate it with `.rotate`).",
              {"major": "distance from the centre to the tube's centre line, > 0",
               "minor": "tube radius, > 0", "center": "centre"}),
    "capsule": ("The points within `radius` of the segment `a`-`b`.",
                {"a": "one end of the segment", "b": "the other end", "radius": "radius, > 0"}),
    "cylinder": ("A cylinder with flat caps at `a` and `b`.",
                 {"a": "centre of one cap", "b": "centre of the other cap", "radius": "radius, > 0"}),
    "cone": ("A cone frustum with flat caps: radius `ra` at `a`, `rb` at `b`.",
             {"a": "centre of the first cap", "b": "centre of the second cap",
              "ra": "radius at `a`, >= 0", "rb": "radius at `b`, >= 0"}),
    "plane": ("The half-space ``normal · p <= offset`` (unbounded: give `bounds` when sampling, or intersect it).",
              {"normal": "outward normal (normalized)", "offset": "offset along the normal"}),
    "ellipsoid": ("An axis-aligned ellipsoid (exact distance, Eberly's method).",
                  {"radii": "semi-axes, each > 0", "center": "centre"}),
}


def _fmt(v):
    return f"({v[0]:g}, {v[1]:g}, {v[2]:g})" if isinstance(v, tuple) else f"{v:g}"


def _make_primitive(key, params):
    defaults = dict(params)
    order = _ORDER[key]
    if set(order) != set(defaults):  # the vocabulary changed: keep Python in step
        raise ImportError(f"isokit: parameters of {key} are {sorted(defaults)}, expected {sorted(order)}")
    sig = _inspect.Signature([
        _inspect.Parameter(n, _inspect.Parameter.POSITIONAL_OR_KEYWORD, default=defaults[n])
        for n in order
    ])

    def primitive(*args, **kwargs):
        bound = sig.bind(*args, **kwargs)
        bound.apply_defaults()
        return _isokit._primitive(key, dict(bound.arguments))

    summary, pdoc = _DOCS[key]
    lines = [summary, "", "Parameters", "----------"]
    for n in order:
        kind = "3 floats" if isinstance(defaults[n], tuple) else "float"
        lines += [f"{n} : {kind}, default {_fmt(defaults[n])}", f"    {pdoc[n].capitalize()}."]
    example = ", ".join(f"{n}={_fmt(defaults[n])}" for n in order)
    lines += ["", "Returns", "-------", "Shape",
              f"    The scene files' ``{{\"{key}\": {{...}}}}`` node (missing parameters take the",
              "    same defaults there). Exact signed distance, negative inside.",
              "", "Example", "-------", f">>> isokit.{key}({example})"]
    primitive.__name__ = primitive.__qualname__ = key
    primitive.__module__ = "isokit"
    primitive.__signature__ = sig
    primitive.__doc__ = "\n".join(lines)
    return primitive


_VOCABULARY = {key: params for key, params, _note in _isokit._primitives()}
sphere = _make_primitive("sphere", _VOCABULARY["sphere"])
box = _make_primitive("box", _VOCABULARY["box"])
rounded_box = _make_primitive("rounded_box", _VOCABULARY["rounded_box"])
torus = _make_primitive("torus", _VOCABULARY["torus"])
capsule = _make_primitive("capsule", _VOCABULARY["capsule"])
cylinder = _make_primitive("cylinder", _VOCABULARY["cylinder"])
cone = _make_primitive("cone", _VOCABULARY["cone"])
plane = _make_primitive("plane", _VOCABULARY["plane"])
ellipsoid = _make_primitive("ellipsoid", _VOCABULARY["ellipsoid"])


# --- sources ----------------------------------------------------------------------------

def _is_path(x) -> bool:
    return isinstance(x, (str, bytes, _os.PathLike))


def _existing(shape, source):
    """`shape` made from the file `source`, refused at once when the file is missing (it
    is read lazily, when the shape is first evaluated; a typo should not wait for that).
    Called after the shape is made, so that bad parameters are named first."""
    path = _os.fsdecode(source)
    if not _os.path.exists(path):
        raise FileNotFoundError(2, "no such file", path)
    return shape


def _float_array(x, name):
    """float32/float64 arrays as they are (no copy); anything else as float64."""
    if isinstance(x, _np.ndarray) and x.dtype in (_np.float32, _np.float64):
        return x
    a = _np.asarray(x)
    if a.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a numeric (n, 3) array, got dtype {a.dtype}")
    return a.astype(_np.float64)


def mesh(source, sign="auto", method="kdtree") -> Shape:
    """A triangle mesh as an exact signed distance field.

    Parameters
    ----------
    source : path or (V, F)
        A mesh file (OBJ, glTF/GLB, PLY, STL, OFF), or vertices ``V`` ((n, 3) floats)
        and triangles ``F`` ((m, 3) integers) held in memory (a ``trimesh.Trimesh``
        works too). Arrays are copied into the shape (as float32).
    sign : {"auto", "pseudonormal", "winding", "unsigned"}
        How the distance is signed: ``"auto"`` uses angle-weighted pseudonormals on a
        watertight, consistently oriented mesh and the generalized winding number
        otherwise (open meshes, self-intersections).
    method : {"kdtree", "prism", "prism_cpu", "prism_gpu"}
        How the mesh becomes a band when the shape is sampled: a kd-tree query per
        sample, or prism scan conversion on the sampling lattice.

    A shape holding arrays is written to a scene file with
    ``shape.to_json(save_sources_to=DIR)``.
    """
    if _is_path(source):
        return _existing(_isokit._mesh_path(_os.fsdecode(source), sign, method), source)
    if hasattr(source, "vertices") and hasattr(source, "faces"):
        source = (source.vertices, source.faces)
    try:
        V, F = source
    except (TypeError, ValueError):
        raise TypeError("mesh takes a path or a pair (V, F) of arrays") from None
    return _isokit._mesh_arrays(_float_array(V, "V"), _np.asarray(F), sign, method)


def points(source, k=None, normals="auto") -> Shape:
    """A point cloud as a partition-of-unity distance field (Sigg 2006, Sec. 4.3).

    Parameters
    ----------
    source : path, P or (P, N)
        A cloud file (PLY, XYZ), or points ``P`` ((n, 3) floats) with optional normals
        ``N`` ((n, 3) floats) held in memory.
    k : int, optional
        Neighbours per evaluation (default: the library's).
    normals : {"auto", "given", "estimate"}
        The given normals when there are any, else estimated (PCA and
        minimum-spanning-tree orientation).
    """
    if _is_path(source):
        return _existing(_isokit._points_path(_os.fsdecode(source), k, normals), source)
    if isinstance(source, tuple) and len(source) == 2:
        P, N = source
    else:
        P, N = source, None
    N = None if N is None else _float_array(N, "N")
    return _isokit._points_arrays(_float_array(P, "P"), N, k, normals)


def volume(source, origin=None, spacing=None, inside="below", iso=0.0, filter="trilinear") -> Shape:
    """A sampled volume read as a field (its isosurface ``f = iso`` is the surface).

    Parameters
    ----------
    source : path, array or Field
        A volume file (NRRD, NHDR, NPY with its ``.npy.json`` lattice sidecar, NIfTI), a
        ``(nz, ny, nx)`` array of samples (``values[k, j, i]`` at
        ``origin + spacing * (i, j, k)``), or an ``isokit.Field``.
    origin : 3 floats, default (0, 0, 0)
        Position of sample (0, 0, 0), for arrays (files carry their own).
    spacing : float, default 1
        Distance between samples, for arrays (one spacing for all axes).
    inside : {"below", "above"}
        Which side of ``iso`` is inside: ``"below"`` for distance fields, ``"above"`` for
        densities such as CT.
    iso : float, default 0
        The isovalue that is the surface.
    filter : {"trilinear", "cubic_bspline", "catmull_rom"}
        Reconstruction filter.
    """
    if _is_path(source):
        if origin is not None or spacing is not None:
            raise ValueError(
                "origin and spacing come from the file (its NRRD header or .npy.json sidecar); "
                "for a bare .npy, load it with numpy and pass the array")
        return _existing(_isokit._volume_path(_os.fsdecode(source), iso, inside, filter), source)
    if isinstance(source, Field):
        if origin is not None or spacing is not None:
            raise ValueError("a Field has its own origin and spacing")
        if inside != source.inside:
            raise ValueError(f"the field's inside is {source.inside!r}")
        return source.to_shape(filter=filter, iso=iso)
    return _isokit._volume_array(
        _np.asarray(source), (0.0, 0.0, 0.0) if origin is None else origin,
        1.0 if spacing is None else spacing, iso, inside, filter)


def morph(a, b, t):
    """The linear morph ``(1 - t)·a + t·b`` of two shapes (a shape) or of two fields on
    the same lattice (a field); ``t = 0`` gives ``a``, 1 gives ``b``. For a level-set morph
    that moves one surface onto another see ``morph_level_set``."""
    if isinstance(a, Shape) and isinstance(b, Shape):
        return a.morph(b, t)
    if isinstance(a, Field) and isinstance(b, Field):
        return a.morph(b, t)
    raise TypeError("morph takes two shapes or two fields")
