"""A modeling script: a bracket with blended bosses, drilled holes and a mesh operand (a
knot read from data/trefoil.ply, or made here when the file is missing), meshed and
rendered, with its scene file written beside the results.

    pip install ./crates/isokit-python
    python examples/python/part.py [OUT_DIR]

Run in CI by tools/test.sh; it checks its own results.
"""

import pathlib
import sys

import numpy as np

import isokit

ROOT = pathlib.Path(__file__).resolve().parents[2]
out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "part-out")
out.mkdir(parents=True, exist_ok=True)

# The body: a rounded plate with two bosses blended into it.
plate = isokit.rounded_box(half=(1.2, 0.12, 0.7), radius=0.04)
bosses = isokit.union(*[isokit.cylinder(a=(x, 0, 0), b=(x, 0.45, 0), radius=0.28) for x in (-0.7, 0.7)])
body = plate.smooth_union(bosses, 0.12)

# Holes: a bore through each boss and four mounting holes through the plate.
bores = isokit.union(*[isokit.cylinder(a=(x, -1, 0), b=(x, 1, 0), radius=0.14) for x in (-0.7, 0.7)])
mounts = isokit.union(*[isokit.cylinder(a=(x, -1, z), b=(x, 1, z), radius=0.06)
                        for x in (-1.0, 1.0) for z in (-0.5, 0.5)])

# The mesh operand: a trefoil knot standing on the plate's centre, blended in.
knot_file = ROOT / "data" / "trefoil.ply"
if knot_file.exists():
    knot = isokit.mesh(knot_file)
else:  # a tube around a trefoil, made here
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    curve = np.stack([np.sin(t) + 2 * np.sin(2 * t), np.cos(t) - 2 * np.cos(2 * t), -np.sin(3 * t)], 1) / 6
    knot = isokit.union(*[isokit.sphere(0.08, center=tuple(c)) for c in curve])
knot = knot.scale(0.5).rotate("x", -90).translate(0, 0.45, 0)
part = (body - bores - mounts).smooth_union(knot, 0.05)

# Evaluate, mesh, render.
inside = part(np.array([[0.0, 0.0, 0.3], [-0.7, 0.2, 0.0], [1.0, 0.0, 0.5]]))
assert inside[0] < 0, "the plate is solid"
assert inside[1] > 0 and inside[2] > 0, "the bore and the mounting hole are open"

mesh = part.mesh(res=160)
V, F = mesh
print(f"mesh: {len(V)} vertices, {len(F)} triangles, volume {mesh.volume():.4f}, "
      f"dense fraction {mesh.stats['sampling']['dense_fraction']:.3f}")
assert len(F) > 10_000 and mesh.volume() > 0.3

frame = part.render(width=480, height=320, shading="curvature",
                    camera=isokit.Camera(eye=(2.2, 1.8, 2.6), target=(0, 0.15, 0)))
frame.save(out / "part.png")
hit = frame.gbuffer["A"] > 0
print(f"render: {hit.mean():.1%} of the pixels hit the part")
assert 0.1 < hit.mean() < 0.9

# The same part as a scene file (the knot's file referenced by path): `isokit scene
# part.json -o part.obj` gives this mesh.
part.save(out / "part.json")
again = isokit.load_scene(out / "part.json")
p = np.random.default_rng(0).uniform(-1.3, 1.3, size=(1000, 3))
assert np.array_equal(again(p), part(p))
if hasattr(mesh, "to_trimesh"):
    try:
        tm = mesh.to_trimesh()
        print(f"trimesh: watertight {tm.is_watertight}")
    except ImportError:
        pass
print(f"wrote {out / 'part.png'} and {out / 'part.json'}")
