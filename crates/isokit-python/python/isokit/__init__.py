"""isokit: distance fields and implicit surfaces from Python.

Build shapes from primitives, meshes, point clouds and volumes; combine them with
``|`` (union), ``&`` (intersection), ``-`` (difference), ``~`` (complement) and the
methods ``smooth_union``, ``offset``, ``shell``, ``morph``, ``translate``, ``rotate``,
``scale``; evaluate them at points, sample them to fields, mesh and render them. Every
call runs the same pipeline as the ``isokit`` command, and ``shape.to_json()`` writes the
scene file that describes the same shape.

The modeling vocabulary of the scene files is here too, with the scene files' keys as
argument names: 2D profiles (``circle``, ``rectangle``, ``rounded_rectangle``,
``polygon``, ``ellipse``, ``slot``, ``hexagon``; ``shape.dim == 2``) made solids by
``profile.extrude(height)`` and ``profile.revolve(offset)``; ``transform(scale=(sx, sy,
sz))``, ``mirror``, ``orient``, ``affine``; ``repeat``, ``array``, ``circular_array``;
``twist``, ``bend``, ``taper``, ``elongate``, ``round``, ``onion``; the chamfer and stairs
blends; ``with_color((r, g, b))``; and named numbers, ``isokit.param("r", 0.3)``, that
``to_json`` writes as ``"$r"`` with a ``params`` table.

>>> r = isokit.param("r", 0.1)
>>> hole = isokit.circle(radius=r, center=(0.6, 0)).extrude(height=1).circular_array(count=6)
>>> flange = isokit.circle(radius=1).extrude(height=0.2) - hole

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
    Param,
    Shape,
    TetGrid,
    difference,
    intersection,
    load_scene,
    mesh_labels,
    molecule,
    morph_level_set,
    read_tets,
    signed_distance,
    smooth_union,
    union,
)
from ._mesh import Mesh

__version__ = _isokit.__version__

__all__ = [
    "Camera", "Cancelled", "Field", "Frame", "GBUFFER_CHANNELS", "Mesh", "Molecule",
    "Param", "SHADING_MODES", "Shape", "TetGrid", "box", "capsule", "chamfer_difference",
    "chamfer_intersection", "chamfer_union", "circle", "cone", "cylinder", "difference",
    "ellipse", "ellipsoid", "hexagon", "intersection", "load_scene", "mesh", "mesh_labels", "molecule",
    "morph", "morph_level_set", "param", "plane", "points", "polygon", "read_tets", "rectangle",
    "rounded_box", "rounded_rectangle", "signed_distance", "slot", "smooth_union", "sphere",
    "stairs_difference", "stairs_intersection", "stairs_union", "torus", "union", "view",
    "Viewer", "volume",
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
    return "(" + ", ".join(f"{x:g}" for x in v) + ")" if isinstance(v, tuple) else f"{v:g}"


def _signature(key, defaults, order, keyword_only=()):
    """The signature of a vocabulary function: `order`'s parameters with the library's
    defaults, then `keyword_only` ones defaulting to None."""
    if set(order) != set(defaults):  # the vocabulary changed: keep Python in step
        raise ImportError(f"isokit: parameters of {key} are {sorted(defaults)}, expected {sorted(order)}")
    return _inspect.Signature(
        [_inspect.Parameter(n, _inspect.Parameter.POSITIONAL_OR_KEYWORD, default=defaults[n])
         for n in order]
        + [_inspect.Parameter(n, _inspect.Parameter.KEYWORD_ONLY, default=None) for n in keyword_only])


def _parameter_lines(order, defaults, pdoc):
    lines = []
    for n in order:
        v = defaults[n]
        kind = f"{len(v)} floats" if isinstance(v, tuple) else "float"
        lines += [f"{n} : {kind}, default {_fmt(v)}", f"    {pdoc[n].capitalize()}."]
    return lines


def _named(fn, key, sig, lines):
    fn.__name__ = fn.__qualname__ = key
    fn.__module__ = "isokit"
    fn.__signature__ = sig
    fn.__doc__ = "\n".join(lines)
    return fn


def _make_primitive(key, params):
    defaults = dict(params)
    order = _ORDER[key]
    sig = _signature(key, defaults, order)

    def primitive(*args, **kwargs):
        bound = sig.bind(*args, **kwargs)
        bound.apply_defaults()
        if _holds_param(bound.arguments.values()):
            # A named number: the node is read from its scene-file form, references kept.
            return _isokit._node(key, {
                n: (v,) * 3 if isinstance(defaults[n], tuple) and isinstance(v, (int, float, Param))
                else v
                for n, v in bound.arguments.items()})
        return _isokit._primitive(key, dict(bound.arguments))

    summary, pdoc = _DOCS[key]
    lines = [summary, "", "Parameters", "----------"] + _parameter_lines(order, defaults, pdoc)
    example = ", ".join(f"{n}={_fmt(defaults[n])}" for n in order)
    lines += ["", "Any number may be an ``isokit.param``. Colour it with ``.with_color((r, g, b))``.",
              "", "Returns", "-------", "Shape",
              f"    The scene files' ``{{\"{key}\": {{...}}}}`` node (missing parameters take the",
              "    same defaults there). Exact signed distance, negative inside.",
              "", "Example", "-------", f">>> isokit.{key}({example})"]
    return _named(primitive, key, sig, lines)


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


# --- named numbers, 2D profiles, blends (the modeling vocabulary) ----------------------

def param(name: str, value: float) -> Param:
    """A named number: pass it wherever a shape takes a number (a radius, a count, one
    component of a vector) and ``to_json()`` writes ``"$name"`` there, with the scene's
    ``params`` table ``{name: value}`` (a scene file's parameters, which a viewer can offer
    as sliders). The shape uses ``value``. One name stands for one value in a shape.

    >>> r = isokit.param("r", 0.3)
    >>> s = isokit.sphere(radius=r)
    >>> json.loads(s.to_json())["shape"]
    {'sphere': {'center': [0.0, 0.0, 0.0], 'radius': '$r'}}
    """
    return Param(name, value)


def _holds_param(values) -> bool:
    return any(isinstance(v, Param) or (isinstance(v, (tuple, list)) and _holds_param(v))
               for v in values)


_PROFILE_ORDER = {
    "circle": ("radius", "center"),
    "rectangle": ("half", "center"),
    "rounded_rectangle": ("half", "radius", "center"),
    "ellipse": ("radii", "center"),
    "slot": ("a", "b", "radius"),
    "hexagon": ("radius", "center"),
}

_PROFILE_DOCS = {
    "circle": ("A disk in the xy-plane.", {"radius": "radius, > 0", "center": "centre (x, y)"}),
    "rectangle": ("An axis-aligned rectangle.", {"half": "half extents (a, b), each > 0",
                                                 "center": "centre (x, y)"}),
    "rounded_rectangle": ("A rectangle with corners rounded by `radius`.",
                          {"half": "outer half extents (a, b), each > 0",
                           "radius": "corner radius, from 0 to the smaller half extent",
                           "center": "centre (x, y)"}),
    "ellipse": ("An axis-aligned ellipse (exact distance).",
                {"radii": "semi-axes (a, b), each > 0", "center": "centre (x, y)"}),
    "slot": ("The points within `radius` of the segment `a`-`b` (a stadium).",
             {"a": "one end (x, y)", "b": "the other end (x, y)", "radius": "radius, > 0"}),
    "hexagon": ("A regular hexagon with a vertex on +x.",
                {"radius": "circumradius (centre to vertex), > 0", "center": "centre (x, y)"}),
}


def _make_profile(key, defaults):
    order = _PROFILE_ORDER[key]
    sig = _signature(key, defaults, order, keyword_only=("color",))

    def profile(*args, **kwargs):
        bound = sig.bind(*args, **kwargs)
        bound.apply_defaults()
        args = dict(bound.arguments)
        color = args.pop("color")
        return _isokit._node(key, args, None, color)

    summary, pdoc = _PROFILE_DOCS[key]
    lines = [summary, "", "A 2D profile (``dim == 2``): an exact 2D signed distance in the xy-plane.",
             "Combine profiles with the same CSG, blends, offsets and transforms (about z) as",
             "solids; make a solid with ``.extrude(height)`` or ``.revolve(offset)``.",
             "", "Parameters", "----------"] + _parameter_lines(order, defaults, pdoc)
    lines += ["color : (r, g, b), optional", "    Linear RGB, each in [0, 1] (the node's ``\"color\"``)."]
    example = ", ".join(f"{n}={_fmt(defaults[n])}" for n in order)
    lines += ["", "Any number may be an ``isokit.param``.", "", "Returns", "-------", "Shape",
              f"    The scene files' ``{{\"{key}\": {{...}}}}`` node (missing parameters take the",
              "    same defaults there).", "", "Example", "-------",
              f">>> isokit.{key}({example}).extrude(height=0.5)"]
    return _named(profile, key, sig, lines)


_PROFILES = {key: dict(params) for key, params in _isokit._profiles()}
circle = _make_profile("circle", _PROFILES["circle"])
rectangle = _make_profile("rectangle", _PROFILES["rectangle"])
rounded_rectangle = _make_profile("rounded_rectangle", _PROFILES["rounded_rectangle"])
ellipse = _make_profile("ellipse", _PROFILES["ellipse"])
slot = _make_profile("slot", _PROFILES["slot"])
hexagon = _make_profile("hexagon", _PROFILES["hexagon"])


def polygon(points, *, color=None) -> Shape:
    """A polygon from its vertices ``points`` ((n, 2): a list of (x, y) or an array), any
    simple polygon in either orientation: an exact 2D signed distance (``dim == 2``).

    >>> tri = isokit.polygon([(0, 0), (1, 0), (0, 1)])
    >>> prism = tri.extrude(height=0.2)
    """
    return _isokit._node("polygon", {"points": points}, None, color)


def _blend(kind, shapes, radius, steps=None, color=None):
    args = {"radius": radius} if steps is None else {"radius": radius, "steps": steps}
    return _isokit._node(kind, args, list(shapes), color)


def chamfer_union(*shapes, radius, color=None) -> Shape:
    """The union of all with a 45° chamfer of size `radius` where they meet (hg_sdf's
    ``fOpUnionChamfer``). ``{"chamfer_union": {"radius": r, "of": [...]}}``."""
    return _blend("chamfer_union", shapes, radius, color=color)


def chamfer_intersection(*shapes, radius, color=None) -> Shape:
    """The intersection of all, chamfered by `radius` (hg_sdf)."""
    return _blend("chamfer_intersection", shapes, radius, color=color)


def chamfer_difference(*shapes, radius, color=None) -> Shape:
    """The first shape minus the others, chamfered by `radius` (hg_sdf)."""
    return _blend("chamfer_difference", shapes, radius, color=color)


def stairs_union(*shapes, radius, steps=4, color=None) -> Shape:
    """The union of all with `steps` stairs over `radius` where they meet (hg_sdf's
    ``fOpUnionStairs``). ``{"stairs_union": {"radius": r, "steps": n, "of": [...]}}``."""
    return _blend("stairs_union", shapes, radius, steps, color)


def stairs_intersection(*shapes, radius, steps=4, color=None) -> Shape:
    """The intersection of all with stairs (hg_sdf)."""
    return _blend("stairs_intersection", shapes, radius, steps, color)


def stairs_difference(*shapes, radius, steps=4, color=None) -> Shape:
    """The first shape minus the others with stairs (hg_sdf)."""
    return _blend("stairs_difference", shapes, radius, steps, color)


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


def points(source, k=None, normals="auto", sign="winding") -> Shape:
    """A point cloud as a partition-of-unity distance field (Sigg 2006, Sec. 4.3).

    Parameters
    ----------
    source : path, P or (P, N)
        A cloud file (PLY, XYZ), or points ``P`` ((n, 3) floats) with optional normals
        ``N`` ((n, 3) floats) held in memory.
    k : int, optional
        Neighbours per evaluation (default: chosen from the cloud's noise estimate, with the
        solve's damping: 16, or 64 and damping 1 on a noisy cloud).
    normals : {"auto", "given", "estimate"}
        The given normals when there are any, else estimated (PCA and
        minimum-spanning-tree orientation).
    sign : {"winding", "nearest", "winding_everywhere"}
        Where the field gets its sign far from the surface: the fast winding number of the
        oriented cloud (Barill et al. 2018) where the nearest samples disagree on the side
        (the default), the closest sample's tangent plane (wrong beside sharp edges and
        concave pockets), or the winding number everywhere.
    """
    if _is_path(source):
        return _existing(_isokit._points_path(_os.fsdecode(source), k, normals, sign), source)
    if isinstance(source, tuple) and len(source) == 2:
        P, N = source
    else:
        P, N = source, None
    N = None if N is None else _float_array(N, "N")
    return _isokit._points_arrays(_float_array(P, "P"), N, k, normals, sign)


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


class Viewer:
    """A live viewer window following a shape (what ``isokit.view`` opens).

    The shape is written as a scene file (in-memory sources beside it) that the window, the
    same one as ``isokit view``, watches: :meth:`update` rewrites the file and the window
    renders only what changed. The window runs in a child process (it needs a main thread of
    its own) and stays open when the script ends, until it is closed; the scene file's folder
    is removed when the window closes.

    Raises ``OSError`` at once where there is no display to open a window on (on Linux
    neither ``DISPLAY`` nor a Wayland display set); other failures to open the window end the
    child process with its message on stderr (:meth:`wait` returns its non-zero status).

    >>> v = isokit.view(isokit.sphere(0.5))            # doctest: +SKIP
    >>> v.update(isokit.sphere(0.6) - isokit.box())    # doctest: +SKIP
    """

    def __init__(self, shape, *, width=512, height=512, backend="auto", events=None,
                 screenshot=None, exit_after_frames=None, exit_after_seconds=None):
        import json
        import subprocess
        import sys
        import tempfile

        if not isinstance(shape, Shape):
            raise TypeError(f"view shows a Shape, not {type(shape).__name__}")
        if sys.platform.startswith("linux") and not any(
                _os.environ.get(k) for k in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET")):
            raise OSError("isokit.view: no display to open a window on (neither DISPLAY nor "
                          "WAYLAND_DISPLAY is set; under CI use xvfb-run)")
        self._dir = tempfile.mkdtemp(prefix="isokit-view-")
        #: The scene file the window watches.
        self.path = _os.path.join(self._dir, "scene.json")
        self._write(shape)
        args = {
            "path": self.path, "width": int(width), "height": int(height), "backend": backend,
            "events": None if events is None else _os.fspath(events),
            "screenshot": None if screenshot is None else _os.fspath(screenshot),
            "exit_after_frames": exit_after_frames, "exit_after_seconds": exit_after_seconds,
        }
        # The child removes the scene's folder when its window closes (also after the script
        # that opened it has ended).
        code = ("import json, os, shutil, sys\n"
                "from isokit import _isokit\n"
                "args = json.loads(sys.argv[1])\n"
                "try:\n"
                "    _isokit._view_main(**args)\n"
                "except ValueError as e:\n"
                "    sys.exit(f'isokit.view: {e}')\n"
                "finally:\n"
                "    shutil.rmtree(os.path.dirname(args['path']), ignore_errors=True)\n")
        #: The child process that shows the window.
        self.process = subprocess.Popen([sys.executable, "-c", code, json.dumps(args)])

    def _write(self, shape):
        if not isinstance(shape, Shape):
            raise TypeError(f"view shows a Shape, not {type(shape).__name__}")
        _os.makedirs(self._dir, exist_ok=True)
        text = shape.to_json(save_sources_to=self._dir, relative_to=self._dir)
        tmp = self.path + ".tmp"
        with open(tmp, "w") as f:
            f.write(text)
        _os.replace(tmp, self.path)

    @property
    def running(self) -> bool:
        """Whether the window is still open."""
        return self.process.poll() is None

    def update(self, shape) -> "Viewer":
        """Shows ``shape`` instead (the window renders again what changed)."""
        self._write(shape)
        return self

    def wait(self, timeout=None) -> int:
        """Waits for the window to close; returns the child's exit status."""
        return self.process.wait(timeout)

    def close(self):
        """Closes the window and removes the scene file."""
        import shutil

        if self.running:
            self.process.terminate()
            self.process.wait()
        shutil.rmtree(self._dir, ignore_errors=True)


_viewer = None


def view(shape, *, width=512, height=512, backend="auto", events=None, screenshot=None,
         exit_after_frames=None, exit_after_seconds=None) -> Viewer:
    """Shows ``shape`` in a live window, or, when this process already opened one that is
    still open, shows it there instead (so calling ``view`` again after an edit updates the
    picture, recomputing only what the edit changed).

    ``backend`` is ``"auto"``, ``"cpu"`` or ``"gpu"``; ``events`` (a ``.jsonl`` file),
    ``screenshot`` (a ``.png`` written on exit), ``exit_after_frames`` and
    ``exit_after_seconds`` are the flags of ``isokit view``, for scripts and tests
    (``exit_after_frames`` counts finished frames: the coarse frame an edit may show first
    does not count, so a script that shows one edit and exits passes 2). Needs a display (on
    Linux an X server; under CI ``xvfb-run``): raises ``OSError`` without one.

    >>> v = isokit.view(isokit.sphere(0.5))   # doctest: +SKIP
    >>> isokit.view(isokit.sphere(0.6))       # doctest: +SKIP  (the same window)
    """
    global _viewer
    if _viewer is not None and _viewer.running:
        return _viewer.update(shape)
    _viewer = Viewer(shape, width=width, height=height, backend=backend, events=events,
                     screenshot=screenshot, exit_after_frames=exit_after_frames,
                     exit_after_seconds=exit_after_seconds)
    return _viewer
