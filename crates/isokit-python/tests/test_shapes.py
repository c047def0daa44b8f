"""Shapes: the primitives against analytic distances, operators, transforms, evaluation
rules (dtypes, memory order, NaN rows), the keyword arguments of the scene files."""

import inspect
import json

import numpy as np
import pytest

import isokit

N = 4000


def f32_points(rng, n=N, lo=-2.0, hi=2.0):
    """Random points that float32 holds exactly (the pipeline's precision), as float64."""
    return rng.uniform(lo, hi, size=(n, 3)).astype(np.float32).astype(np.float64)


def norm(v):
    return np.linalg.norm(v, axis=-1)


def box_sdf(p, half):
    q = np.abs(p) - np.asarray(half)
    return norm(np.maximum(q, 0)) + np.minimum(q.max(axis=-1), 0)


def cylinder_sdf(p, a, b, r):
    a, b = np.asarray(a, float), np.asarray(b, float)
    ba = b - a
    L = np.linalg.norm(ba)
    u = ba / L
    pa = p - a
    h = pa @ u
    rho = norm(pa - h[:, None] * u)
    q = np.stack([rho - r, np.abs(h - L / 2) - L / 2], axis=-1)
    return norm(np.maximum(q, 0)) + np.minimum(q.max(axis=-1), 0)


def cone_sdf(p, a, b, ra, rb):
    """Inigo Quilez's exact capped cone."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    rba = rb - ra
    baba = (b - a) @ (b - a)
    papa = np.einsum("ij,ij->i", p - a, p - a)
    paba = (p - a) @ (b - a) / baba
    x = np.sqrt(np.maximum(papa - paba * paba * baba, 0))
    cax = np.maximum(0, x - np.where(paba < 0.5, ra, rb))
    cay = np.abs(paba - 0.5) - 0.5
    k = rba * rba + baba
    f = np.clip((rba * (x - ra) + paba * baba) / k, 0, 1)
    cbx = x - ra - f * rba
    cby = paba - f
    s = np.where((cbx < 0) & (cay < 0), -1.0, 1.0)
    return s * np.sqrt(np.minimum(cax * cax + cay * cay * baba, cbx * cbx + cby * cby * baba))


def ellipsoid_sdf(p, radii):
    """Exact distance by bisection on Eberly's root equation (float64, 200 steps)."""
    e = np.asarray(radii, float)
    order = np.argsort(-e)
    e = e[order]
    y = np.abs(p[:, order])
    inside = ((y / e) ** 2).sum(axis=1) < 1
    lo = -e[2] ** 2 + e[2] * y[:, 2]
    hi = -e[2] ** 2 + norm(e * y)
    for _ in range(200):
        t = 0.5 * (lo + hi)
        g = ((e * y / (t[:, None] + e**2)) ** 2).sum(axis=1) - 1
        lo, hi = np.where(g > 0, t, lo), np.where(g > 0, hi, t)
    t = 0.5 * (lo + hi)
    x = e**2 * y / (t[:, None] + e**2)
    d = norm(x - y)
    return np.where(inside, -d, d)


def r32(v):
    """A parameter as the shape stores it (float32), in float64."""
    return np.asarray(v, dtype=np.float32).astype(np.float64)


# Parameters are dyadic (float32-exact) except the plane's normal, which the library
# normalizes: the reference takes the float32 values it was given.
PLANE_N = r32((0, 0.6, 0.8)) / np.linalg.norm(r32((0, 0.6, 0.8)))
CASES = [
    ("sphere", dict(radius=0.8125, center=(0.125, -0.25, 0.375)),
     lambda p: norm(p - [0.125, -0.25, 0.375]) - 0.8125),
    ("box", dict(half=(1.0, 0.625, 0.375), center=(0.25, 0.0, -0.125)),
     lambda p: box_sdf(p - [0.25, 0.0, -0.125], (1.0, 0.625, 0.375))),
    ("rounded_box", dict(half=(0.75, 0.5, 0.25), radius=0.125),
     lambda p: box_sdf(p, (0.625, 0.375, 0.125)) - 0.125),  # outer half extents
    ("torus", dict(major=0.875, minor=0.3125),
     lambda p: norm(np.stack([norm(p[:, :2]) - 0.875, p[:, 2]], axis=-1)) - 0.3125),
    ("capsule", dict(a=(-0.5, 0, 0), b=(0.5, 0.25, 0), radius=0.375),
     lambda p: norm(p - [-0.5, 0, 0] - np.clip((p - [-0.5, 0, 0]) @ [1, 0.25, 0] / 1.0625, 0, 1)[:, None]
                    * [1, 0.25, 0]) - 0.375),
    ("cylinder", dict(a=(0, -0.75, 0), b=(0.25, 0.75, 0.125), radius=0.4375),
     lambda p: cylinder_sdf(p, (0, -0.75, 0), (0.25, 0.75, 0.125), 0.4375)),
    ("cone", dict(a=(0, 0, -0.75), b=(0, 0.25, 0.75), ra=0.6875, rb=0.1875),
     lambda p: cone_sdf(p, (0, 0, -0.75), (0, 0.25, 0.75), 0.6875, 0.1875)),
    ("plane", dict(normal=(0, 0.6, 0.8), offset=0.25),
     lambda p: p @ PLANE_N - 0.25),
    ("ellipsoid", dict(radii=(1.125, 0.6875, 0.375)),
     lambda p: ellipsoid_sdf(p, (1.125, 0.6875, 0.375))),
]


@pytest.mark.parametrize("name,kwargs,ref", CASES, ids=[c[0] for c in CASES])
def test_primitives_match_analytic_distances(rng, name, kwargs, ref):
    shape = getattr(isokit, name)(**kwargs)
    p = f32_points(rng)
    d = shape(p)
    want = ref(p)
    assert d.dtype == np.float64 and d.shape == (N,)
    # Exact to one float32 rounding of the result (the points are float32-exact).
    err = np.abs(d - want) / np.maximum(np.abs(want), 1e-3)
    assert err.max() < 1e-6, f"{name}: max relative error {err.max():.2e}"
    assert (np.sign(d) == np.sign(want))[np.abs(want) > 1e-6].all()


@pytest.mark.parametrize("name,kwargs,ref", CASES[:4], ids=[c[0] for c in CASES[:4]])
def test_gradients_are_unit_and_point_away_from_the_surface(rng, name, kwargs, ref):
    shape = getattr(isokit, name)(**kwargs)
    p = f32_points(rng, 500)
    g = shape.gradient(p)
    assert g.shape == (500, 3) and g.dtype == np.float64
    h = 1e-3
    fd = np.stack([(ref(p + h * e) - ref(p - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)
    ok = np.abs(norm(fd) - 1) < 1e-3  # away from the medial axis and edges
    assert np.allclose(g[ok], fd[ok], atol=5e-3)


def test_keyword_arguments_and_defaults_are_the_scene_files():
    vocabulary = {k: dict(p) for k, p, _ in isokit._isokit._primitives()}
    assert set(vocabulary) == {"sphere", "box", "rounded_box", "torus", "capsule", "cylinder",
                               "cone", "plane", "ellipsoid"}
    for key, params in vocabulary.items():
        sig = inspect.signature(getattr(isokit, key))
        assert {n: p.default for n, p in sig.parameters.items()} == params
        # The default shape is the scene file's `{"key": {}}`.
        text = getattr(isokit, key)().to_json()
        assert json.loads(text)["shape"][key] == {
            n: list(v) if isinstance(v, tuple) else v for n, v in params.items()
        }
    assert "radius : float, default 1" in isokit.sphere.__doc__
    assert "Parameters" in isokit.rounded_box.__doc__
    assert isokit.sphere(0.5) is not None and isokit.box(0.5).to_json()


def test_stubs_name_every_public_name_with_the_vocabularys_defaults():
    import ast
    import pathlib
    stub = pathlib.Path(isokit.__file__).with_name("__init__.pyi")
    tree = ast.parse(stub.read_text())
    names = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    names |= {t.id for n in tree.body if isinstance(n, ast.AnnAssign) for t in [n.target]}
    missing = set(isokit.__all__) - names
    assert not missing, f"not in __init__.pyi: {missing}"
    vocabulary = {k: dict(p) for k, p, _ in isokit._isokit._primitives()}
    for fn in tree.body:
        if isinstance(fn, ast.FunctionDef) and fn.name in vocabulary:
            args = fn.args.args
            defaults = dict(zip([a.arg for a in args[-len(fn.args.defaults):]],
                                [ast.literal_eval(d) for d in fn.args.defaults]))
            assert defaults == vocabulary[fn.name], fn.name


def test_operators_follow_the_sign_convention(rng):
    a = isokit.sphere(radius=1.0)
    b = isokit.box(half=(0.5, 0.5, 0.5), center=(1.0, 0, 0))
    p = f32_points(rng, 1000)
    fa, fb = a(p), b(p)
    assert np.allclose((a | b)(p), np.minimum(fa, fb), atol=1e-7)
    assert np.allclose((a & b)(p), np.maximum(fa, fb), atol=1e-7)
    assert np.allclose((a - b)(p), np.maximum(fa, -fb), atol=1e-7)
    assert np.allclose((~a)(p), -fa, atol=1e-7)
    assert np.allclose(isokit.union(a, b, isokit.sphere(0.3))(p),
                       np.minimum(np.minimum(fa, fb), isokit.sphere(0.3)(p)), atol=1e-7)
    assert (a | b | a).kind == "union" and json.loads((a | b | a).to_json())["shape"]["union"][2]
    assert np.allclose(a.offset(0.25)(p), fa - 0.25, atol=1e-6)
    assert np.allclose(a.shell(0.2)(p), np.abs(fa) - 0.1, atol=1e-6)
    assert np.allclose(a.morph(b, 0.25)(p), 0.75 * fa + 0.25 * fb, atol=1e-6)
    assert np.allclose(isokit.morph(a, b, 0.25)(p), 0.75 * fa + 0.25 * fb, atol=1e-6)
    # Smooth union: below both operands where they blend, equal to the union far away.
    su = a.smooth_union(b, 0.2)(p)
    assert (su <= np.minimum(fa, fb) + 1e-6).all()
    far = np.abs(fa - fb) > 0.25
    assert np.allclose(su[far], np.minimum(fa, fb)[far], atol=1e-6)
    assert np.allclose(a.smooth_intersection(b, 0.0)(p), np.maximum(fa, fb), atol=1e-6)
    assert np.allclose(a.smooth_difference(b, 0.0)(p), np.maximum(fa, -fb), atol=1e-6)
    with pytest.raises(TypeError):
        a | 1.0


def test_transforms(rng):
    t = isokit.torus(major=0.8, minor=0.2)
    p = f32_points(rng, 1000)
    moved = t.translate(0.5, -0.25, 1.0)
    assert np.allclose(moved(p), t(p - [0.5, -0.25, 1.0]), atol=1e-6)
    assert np.allclose(t.translate((0.5, -0.25, 1.0))(p), moved(p))
    # 90 degrees about x: the torus around z now lies around -y... (x, y, z) -> (x, -z, y).
    r = t.rotate("x", 90)
    q = np.stack([p[:, 0], p[:, 2], -p[:, 1]], axis=-1)
    assert np.allclose(r(p), t(q), atol=2e-6)
    assert np.allclose(t.rotate((1, 0, 0), 90)(p), r(p), atol=1e-6)
    s = t.scale(2.0)
    assert np.allclose(s(p), 2 * t(p / 2), atol=2e-6)
    with pytest.raises(TypeError, match="uniform"):
        t.scale((1, 2, 1))
    with pytest.raises(ValueError, match="axis"):
        t.rotate("w", 10)


def test_results_keep_the_input_precision_and_any_memory_order(rng):
    s = isokit.sphere(radius=0.7)
    p = f32_points(rng, 300)
    d64 = s(p)
    d32 = s(p.astype(np.float32))
    assert d32.dtype == np.float32 and d64.dtype == np.float64
    assert np.array_equal(d32.astype(np.float64), d64)
    fortran = np.asfortranarray(p)
    strided = np.zeros((300, 6))[:, ::2]
    strided[:] = p
    reversed_rows = p[::-1]
    assert np.array_equal(s(fortran), d64)
    assert np.array_equal(s(strided), d64)
    assert np.array_equal(s(reversed_rows), d64[::-1])
    assert s.gradient(p.astype(np.float32)).dtype == np.float32
    assert s(np.zeros((0, 3))).shape == (0,)


def test_nan_rows_give_nan():
    s = isokit.sphere(radius=1.0) | isokit.box(half=0.5, center=(2, 0, 0))
    p = np.array([[0, 0, 0], [np.nan, 0, 0], [0, np.inf, 0], [2, 0, 0]], dtype=np.float64)
    d = s(p)
    assert d[0] == -1.0 and d[3] == -0.5
    assert np.isnan(d[1]) and np.isnan(d[2])
    g = s.gradient(p)
    assert np.isnan(g[1]).all() and np.isfinite(g[0]).all()


def test_bounds_and_repr():
    s = isokit.sphere(radius=0.5, center=(1, 0, 0))
    lo, hi = s.bounds
    assert np.allclose(lo, [0.5, -0.5, -0.5]) and np.allclose(hi, [1.5, 0.5, 0.5])
    assert isokit.plane().bounds is None
    assert "sphere" in repr(s)


def test_mesh_sources_from_arrays_and_files(tmp_path):
    from conftest import icosphere
    V, F = icosphere(3)
    m = isokit.mesh((V, F))
    p = np.array([[0.0, 0, 0], [2.0, 0, 0]])
    d = m(p)
    assert -1.0 < d[0] < -0.99 and 0.99 < d[1] <= 1.0
    assert m.kind == "mesh"
    # The same mesh from a file.
    isokit_obj = tmp_path / "s.obj"
    with open(isokit_obj, "w") as f:
        for v in V.astype(np.float32):
            f.write(f"v {float(v[0])!r} {float(v[1])!r} {float(v[2])!r}\n")
        for t in F + 1:
            f.write(f"f {t[0]} {t[1]} {t[2]}\n")
    assert np.allclose(isokit.mesh(isokit_obj)(p), d, atol=1e-6)
    # trimesh objects work too.
    trimesh = pytest.importorskip("trimesh")
    tm = trimesh.Trimesh(V, F, process=False)
    assert np.allclose(isokit.mesh(tm)(p), d)


def test_points_sources(rng):
    from conftest import icosphere
    V, _ = icosphere(3)
    cloud = isokit.points((V, V))  # unit sphere, outward normals
    d = cloud(np.array([[0.0, 0, 0], [0, 0, 1.5]]))
    assert d[0] < 0 < d[1]
    assert abs(d[1] - 0.5) < 0.05
    assert isokit.points(V)(np.array([[0, 0, 1.5]]))[0] > 0


def test_volume_sources_from_arrays(rng):
    n = 33
    x = np.linspace(-1, 1, n)
    Z, Y, X = np.meshgrid(x, x, x, indexing="ij")
    values = np.sqrt(X**2 + Y**2 + Z**2) - 0.6  # (nz, ny, nx)
    v = isokit.volume(values, origin=(-1, -1, -1), spacing=2 / (n - 1))
    p = rng.uniform(-0.8, 0.8, size=(200, 3))
    assert np.allclose(v(p), norm(p) - 0.6, atol=0.01)
    # A density (inside above its isovalue).
    dens = isokit.volume(1.0 - values, origin=(-1, -1, -1), spacing=2 / (n - 1), inside="above", iso=1.0)
    assert np.allclose(dens(p), norm(p) - 0.6, atol=0.01)
    # Axis order: a field that only grows along x.
    ramp = isokit.volume(np.broadcast_to(x[None, None, :], (n, n, n)), origin=(-1, -1, -1),
                         spacing=2 / (n - 1))
    q = np.array([[0.5, -0.3, 0.2]])
    assert abs(ramp(q)[0] - 0.5) < 1e-5
