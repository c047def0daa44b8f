"""Sharp features: dual contouring (``mesher="dual"``) against marching cubes on a box, and
the winding-number sign of point clouds (``sign=``) against the exact sign of a sharp box."""

import numpy as np
import pytest

import isokit

HALF = np.array([0.5, 0.4, 0.3])
CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * HALF


def box_sdf(p, half=HALF):
    q = np.abs(p) - half
    return np.linalg.norm(np.maximum(q, 0), axis=-1) + np.minimum(q.max(axis=-1), 0)


def corner_gap(V):
    """The largest distance from a box corner to the mesh vertex nearest it."""
    return max(np.linalg.norm(V - c, axis=1).min() for c in CORNERS)


def test_dual_contouring_keeps_the_corners_marching_cubes_cuts():
    # A box off the lattice (its faces between samples), so neither mesher gets the corners
    # for free.
    box = isokit.box(half=tuple(HALF), center=(0.013, -0.007, 0.011))
    shift = np.array([0.013, -0.007, 0.011])
    mc = box.mesh(res=40)
    dual = box.mesh(res=40, mesher="dual")
    assert dual.stats["mesher"] == "dual" and mc.stats["mesher"] == "mc"
    spacing = mc.stats["sampling"]["spacing"]
    gap_mc, gap_dual = corner_gap(mc.vertices - shift), corner_gap(dual.vertices - shift)
    print(f"corner gap: mc {gap_mc / spacing:.3f}, dual {gap_dual / spacing:.3f} spacings")
    assert gap_dual < 0.01 * spacing < 0.2 * spacing < gap_mc
    # Every vertex on the surface; the mesh closed and oriented (positive volume).
    assert np.abs(box_sdf(dual.vertices - shift)).max() < 1e-3 * spacing
    tm = dual.to_trimesh()
    assert tm.is_watertight and tm.is_winding_consistent
    assert abs(tm.volume - np.prod(2 * HALF)) < 1e-4
    # From samples alone (a Field): dual contouring on the central-difference gradients
    # still comes closer to the corners than marching cubes.
    f = box.sample(res=40)
    Vm, _ = f.mesh()
    Vd, Fd = f.mesh(mesher="dual")
    assert len(Fd) > 0 and corner_gap(Vd - shift) < corner_gap(Vm - shift)
    with pytest.raises(ValueError, match="mesher"):
        box.mesh(res=16, mesher="marching")
    with pytest.raises(ValueError, match="mesher"):
        f.mesh(mesher="")


def box_cloud(rng, n=12000):
    """Area-uniform samples of the box's faces with their exact outward normals."""
    areas = np.array([HALF[1] * HALF[2], HALF[0] * HALF[2], HALF[0] * HALF[1]]) * 4
    axis = rng.choice(3, size=n, p=np.repeat(areas, 1) / areas.sum())
    side = rng.choice([-1.0, 1.0], size=n)
    P = rng.uniform(-1, 1, size=(n, 3)) * HALF
    P[np.arange(n), axis] = side * HALF[axis]
    N = np.zeros((n, 3))
    N[np.arange(n), axis] = side
    return P, N


def test_cloud_sign_rules_far_from_a_sharp_box(rng):
    P, N = box_cloud(rng)
    wrong = {}
    for sign in ["nearest", "winding", "winding_everywhere"]:
        f = isokit.points((P, N), sign=sign).sample(res=48, bounds=((-1, -1, -1), (1, 1, 1)))
        nz, ny, nx = f.values.shape
        k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
        pos = np.asarray(f.origin) + f.spacing * np.stack([i, j, k], axis=-1)
        exact = box_sdf(pos)
        far = np.abs(exact) > 3 * f.spacing
        wrong[sign] = int(np.sum(far & (np.sign(np.asarray(f.values)) != np.sign(exact))))
    print("wrong signs beyond 3 spacings:", wrong)
    assert wrong["winding"] == 0 and wrong["winding_everywhere"] == 0
    # The option reaches the field: the closest sample's side is wrong here.
    assert wrong["nearest"] > 0
    with pytest.raises(ValueError, match="sign"):
        isokit.points((P, N), sign="majority")


def test_adaptive_dual_contouring_merges_the_flat_faces():
    # error= merges cells into octree nodes where one vertex serves them: a box keeps its
    # corners exactly with a handful of triangles instead of thousands.
    box = isokit.box(half=tuple(HALF), center=(0.013, -0.007, 0.011))
    shift = np.array([0.013, -0.007, 0.011])
    uniform = box.mesh(res=48, mesher="dual")
    spacing = uniform.stats["sampling"]["spacing"]
    adaptive = box.mesh(res=48, mesher="dual", error=0.01 * spacing)
    assert adaptive.stats["merged_cells"] > 0 and "merged_cells" not in uniform.stats
    print(f"box at 48: {len(uniform.faces)} triangles uniform, {len(adaptive.faces)} adaptive")
    assert 10 * len(adaptive.faces) < len(uniform.faces)
    assert corner_gap(adaptive.vertices - shift) < 1e-3 * spacing
    assert np.abs(box_sdf(adaptive.vertices - shift)).max() <= 0.01 * spacing + 1e-7
    tm = adaptive.to_trimesh()
    assert tm.is_watertight and tm.is_winding_consistent
    assert abs(tm.volume - np.prod(2 * HALF)) < 1e-4
    # A sampled Field takes the same knob.
    V, F = box.sample(res=48).mesh(mesher="dual", error=0.05 * spacing)
    assert 0 < len(F) < len(uniform.faces)
    with pytest.raises(ValueError, match="error"):
        box.mesh(res=16, error=0.01)
    with pytest.raises(ValueError, match="error"):
        box.mesh(res=16, mesher="dual", error=-1.0)
