"""Band fields on Dask: each block of the lattice is one job of the Rust sampler.

>>> import isokit, isokit.dask
>>> part = isokit.load_scene("examples/scenes/demo.json")
>>> field = isokit.dask.sample(part, res=384, chunks=64)    # a dask array (nz, ny, nx)
>>> isokit.dask.to_zarr(field, "part.zarr")                 # the store `isokit` reads
>>> V, F = isokit.dask.mesh(part, res=384, chunks=64)       # one watertight mesh

``sample`` plans the lattice exactly as ``shape.sample`` does (same ``res``, ``band``,
``bounds``, ``brick``) and makes a dask array whose blocks are computed by the extension
with the GIL released: every block equals the same block of ``shape.sample(...).values``
bit for bit (the sampler computes each sample's position from the whole lattice). The
shape travels to the workers as its scene file (``shape.to_json()``), and each worker
process compiles it once and keeps it (a mesh's kd-tree, a cloud's solve), not once per
block. Paths in the scene must be readable by the workers (absolute; the same machine, or
a shared file system). Shapes holding arrays in memory are saved to files first
(``save_sources_to``).

``to_zarr`` writes the store layout of ``isokit ... -o field.zarr`` (a group with the
lattice attributes, the ``field`` array and ``x``, ``y``, ``z`` coordinates), into
``PATH.partial`` first and renamed when every block is written; chunks that hold only the
fill value ``+band`` are not written.

Needs ``dask[array]`` (and ``distributed`` for clusters) and ``zarr>=3``; none is imported
until used.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import threading
import time
from typing import Any

import numpy as np

from . import _isokit

__all__ = ["sample", "mesh", "lattice_of", "to_zarr"]

# Per process (per Dask worker): scene text -> compiled shape, so that a worker builds a
# mesh's kd-tree once for all the blocks it computes.
_SHAPES: dict[str, Any] = {}
_SHAPES_LOCK = threading.Lock()
_SHAPES_LIMIT = 8

# The lattice of each array `sample` made, by the array's name.
_LATTICES: dict[str, dict] = {}


def _shape_of(text: str):
    with _SHAPES_LOCK:
        shape = _SHAPES.get(text)
        if shape is None:
            if len(_SHAPES) >= _SHAPES_LIMIT:
                _SHAPES.clear()
            shape = _isokit._shape_from_json(text)
            _SHAPES[text] = shape
        return shape


def _block(text: str, kw: dict, block_info=None):
    (z0, z1), (y0, y1), (x0, x1) = block_info[None]["array-location"]
    shape = _shape_of(text)
    return shape._sample_block((x0, y0, z0), (x1 - x0, y1 - y0, z1 - z0), **kw)


def _scene_text(shape) -> str:
    try:
        return shape.to_json()
    except ValueError:
        # Arrays held in memory: written to files the workers read (this machine).
        folder = tempfile.mkdtemp(prefix="isokit-dask-sources-")
        return shape.to_json(save_sources_to=folder)


def sample(shape, res=None, band=None, bounds=None, chunks=64, brick=None):
    """The lazily sampled band of ``shape`` as a dask array of shape ``(nz, ny, nx)``.

    ``res``, ``band``, ``bounds``, ``brick``: as for ``shape.sample`` (the same lattice).
    ``chunks``: the blocks, as dask takes them (an int for cubes, default 64³: a whole
    number of bricks keeps the sampler's brick decisions those of the whole sampling).
    Values are exact within ``band`` and ``±band`` beyond (negative inside).
    ``lattice_of(array)`` gives the lattice (origin, spacing, dims, band).
    """
    import dask.array as da

    text = _scene_text(shape)
    kw = {"res": res, "band": band, "bounds": bounds, "brick": brick}
    plan = shape._plan(**kw)
    nx, ny, nz = plan["dims"]
    blocks = da.core.normalize_chunks(chunks, shape=(nz, ny, nx), dtype=np.float32)
    token = da.core.tokenize(text, kw, blocks)
    arr = da.map_blocks(
        _block,
        text,
        kw,
        chunks=blocks,
        dtype=np.float32,
        meta=np.empty((0, 0, 0), dtype=np.float32),
        name=f"isokit-sample-{token}",
    )
    _LATTICES[arr.name] = {
        "origin": list(plan["origin"]),
        "spacing": [plan["spacing"]] * 3,
        "dims": [nx, ny, nz],
        "axis_order": "zyx",
        "band": plan["band"],
        "inside": "below",
        "sign": None,
    }
    return arr


def _mesh_piece(text: str, kw: dict, first, owned, iso):
    return _shape_of(text)._mesh_block(first, owned, iso=iso, **kw)


def mesh(shape, res=None, band=None, bounds=None, chunks=64, brick=None, iso=0.0):
    """The surface of ``shape`` meshed block by block on Dask: marching cubes of the lazily
    sampled band (as ``shape.sample(...).mesh(iso)``), each block's cells meshed by a job
    that samples only that block and the layer after it, the pieces welded by the key of
    the lattice edge each vertex lies on. The result is ``shape.sample(...).mesh(iso)``:
    the same vertices in the same order, the same triangles (in another order), one
    watertight mesh (an ``isokit.Mesh``). ``res``, ``band``, ``bounds``, ``brick`` as for
    ``sample``; ``chunks``: the blocks (an int for cubes, or dask's chunk forms). Runs on
    the current Dask scheduler (a ``distributed.Client`` when one is active)."""
    import dask
    import dask.array as da

    from ._mesh import Mesh

    text = _scene_text(shape)
    kw = {"res": res, "band": band, "bounds": bounds, "brick": brick}
    plan = shape._plan(**kw)
    nx, ny, nz = plan["dims"]
    cz, cy, cx = da.core.normalize_chunks(chunks, shape=(nz, ny, nx), dtype=np.float32)
    starts = [np.concatenate([[0], np.cumsum(c)[:-1]]).astype(int) for c in (cx, cy, cz)]
    jobs = []
    for z0, dz in zip(starts[2], cz):
        for y0, dy in zip(starts[1], cy):
            for x0, dx in zip(starts[0], cx):
                job = dask.delayed(_mesh_piece, pure=True)(
                    text, kw, (int(x0), int(y0), int(z0)), (int(dx), int(dy), int(dz)), iso)
                jobs.append(job)
    pieces = dask.compute(*jobs)
    keys = np.concatenate([p[0] for p in pieces]) if pieces else np.zeros(0, np.uint64)
    if len(keys) == 0:
        return Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64),
                    {"blocks": len(jobs), "vertices": 0, "triangles": 0, "piece_vertices": 0})
    positions = np.concatenate([p[1] for p in pieces])
    offsets = np.cumsum([0] + [len(p[0]) for p in pieces[:-1]])
    triangles = np.concatenate([p[2].astype(np.int64) + o for p, o in zip(pieces, offsets)])
    # Welded by key: the vertices sorted by key, as the single-process mesher orders them.
    unique, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    V = positions[first].astype(np.float64)
    F = inverse.reshape(-1)[triangles]
    stats = {"blocks": len(jobs), "vertices": len(unique), "triangles": len(F),
             "piece_vertices": len(keys)}
    return Mesh(V, F, stats)


def lattice_of(array) -> dict:
    """The lattice of an array made by ``sample``: ``origin``, ``spacing``, ``dims`` (x, y,
    z), ``axis_order``, ``band``, ``inside``, ``sign`` (the keys of the stores' attributes)."""
    try:
        return dict(_LATTICES[array.name])
    except (AttributeError, KeyError):
        raise ValueError(
            "this array was not made by isokit.dask.sample (pass lattice=... to to_zarr)"
        ) from None


def to_zarr(array, path, lattice=None, compute=True, gzip_level=1, **kwargs):
    """Writes ``array`` (from ``sample``, or any 3-D float32 dask array with ``lattice``
    given: a dict like ``lattice_of``'s) as an isokit Zarr store at ``path``. The store is made at ``PATH.partial`` and
    renamed over ``path`` when complete (an existing store is moved aside, replaced, then
    removed); an existing directory that is not a Zarr store is refused. A failed write
    removes the partial store. With ``compute=False`` a ``dask.delayed`` is returned that
    writes and renames when computed. Extra keyword arguments go to ``dask.array.store``.
    The path is made absolute here, since the workers write it."""
    import dask
    import dask.array as da
    import zarr
    from zarr.codecs import BytesCodec, GzipCodec

    meta = dict(lattice) if lattice is not None else lattice_of(array)
    path = os.path.abspath(os.fspath(path)).rstrip(os.sep) or os.sep
    if os.path.exists(path) and not (
        os.path.isfile(os.path.join(path, "zarr.json"))
        or os.path.isfile(os.path.join(path, ".zarray"))
    ):
        raise ValueError(f"{path}: exists and is not a Zarr store: not replaced")
    if array.ndim != 3:
        raise ValueError(f"a field is 3-D (nz, ny, nx), not {array.ndim}-D")
    nz, ny, nx = array.shape
    if list(meta["dims"]) != [nx, ny, nz]:
        raise ValueError(f"lattice dims {meta['dims']} do not match the array's shape (z, y, x) {array.shape}")
    partial = path + ".partial"
    shutil.rmtree(partial, ignore_errors=True)
    fill = float(meta["band"]) if meta.get("band") is not None else 0.0
    # Dask writes whole blocks: the Zarr chunks are the blocks (regular ones).
    chunks = tuple(c[0] for c in array.chunks)
    if any(len(set(c[:-1])) > 1 or c[-1] > c[0] for c in array.chunks):
        array = array.rechunk(chunks)
    root = zarr.open_group(partial, mode="w", zarr_format=3)
    root.attrs.update({**meta, "isokit": {"complete": False}})
    for axis, name in enumerate("xyz"):
        n = meta["dims"][axis]
        c = root.create_array(name, shape=(n,), chunks=(n,), dtype="float64",
                              dimension_names=[name], compressors=None)
        c[:] = float(meta["origin"][axis]) + float(meta["spacing"][axis]) * np.arange(n)
    field = root.create_array(
        "field",
        shape=array.shape,
        chunks=chunks,
        dtype="float32",
        fill_value=np.float32(fill),
        dimension_names=["z", "y", "x"],
        serializer=BytesCodec(endian="little"),
        compressors=[GzipCodec(level=gzip_level)] if gzip_level is not None else None,
        attributes=dict(meta),
    )
    stored = da.store(array, field, lock=False, compute=False, **kwargs)

    def finish(_):
        zarr.open_group(partial, mode="r+").attrs["isokit"] = {"complete": True}
        old = None
        if os.path.exists(path):
            old = f"{path}.old-{os.getpid()}-{time.time_ns()}"
            os.rename(path, old)
        try:
            os.rename(partial, path)
        except OSError:
            if old:
                os.rename(old, path)
            raise
        if old:
            shutil.rmtree(old, ignore_errors=True)
        return path

    done = dask.delayed(finish)(stored)
    if not compute:
        return done
    try:
        return done.compute()
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)
        raise
