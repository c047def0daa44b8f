"""Meshed CSG scripts against manifold3d's exact booleans: volumes within 0.5%."""

import numpy as np
import pytest

import isokit
from conftest import mesh_volume

mf = pytest.importorskip("manifold3d")
SEG = 256
RES = 112


def manifold_volume(m):
    mesh = m.to_mesh()
    V = np.asarray(mesh.vert_properties)[:, :3].astype(np.float64)
    F = np.asarray(mesh.tri_verts).astype(np.int64)
    return mesh_volume(V, F)


def check(name, shape, ref):
    V, F = shape.mesh(res=RES)
    ours, theirs = mesh_volume(V, F), manifold_volume(ref)
    rel = abs(ours - theirs) / theirs
    print(f"{name}: isokit {ours:.5f} manifold3d {theirs:.5f} rel {rel:.2e}")
    assert rel < 0.005, f"{name}: volumes differ by {rel:.3%}"


def test_sphere_minus_box():
    shape = isokit.sphere(1.0) - isokit.box(half=0.6, center=(0.6, 0.6, 0.6))
    ref = mf.Manifold.sphere(1.0, SEG) - mf.Manifold.cube([1.2, 1.2, 1.2])
    check("sphere - box", shape, ref)


def test_plate_with_holes_and_boss():
    plate = isokit.box(half=(1.0, 0.15, 0.7))
    boss = isokit.cylinder(a=(0, 0, 0), b=(0, 0.6, 0), radius=0.35)
    holes = isokit.union(*[isokit.cylinder(a=(x, -1, z), b=(x, 1, z), radius=0.12)
                           for x in (-0.7, 0.7) for z in (-0.4, 0.4)])
    bore = isokit.cylinder(a=(0, -1, 0), b=(0, 1, 0), radius=0.18)
    shape = (plate | boss) - holes - bore
    ref_plate = mf.Manifold.cube([2.0, 0.3, 1.4], center=True)
    ref_boss = mf.Manifold.cylinder(0.6, 0.35, 0.35, SEG).rotate([-90, 0, 0])
    ref = ref_plate + ref_boss
    for x in (-0.7, 0.7):
        for z in (-0.4, 0.4):
            ref -= mf.Manifold.cylinder(2.0, 0.12, 0.12, SEG, center=True).rotate([-90, 0, 0]).translate([x, 0, z])
    ref -= mf.Manifold.cylinder(2.0, 0.18, 0.18, SEG, center=True).rotate([-90, 0, 0])
    check("plate", shape, ref)


def test_intersection_of_sphere_and_rotated_box():
    shape = isokit.sphere(1.0) & isokit.box(half=0.75).rotate("z", 30).translate(0.2, 0, 0)
    ref = mf.Manifold.sphere(1.0, SEG) ^ mf.Manifold.cube([1.5, 1.5, 1.5], center=True).rotate([0, 0, 30]).translate([0.2, 0, 0])
    check("sphere & box", shape, ref)


def test_mesh_operand_minus_cylinder():
    torus = mf.CrossSection.circle(0.35, SEG).translate([0.9, 0.0]).revolve(2 * SEG)
    mesh = torus.to_mesh()
    V = np.asarray(mesh.vert_properties)[:, :3].astype(np.float64)
    F = np.asarray(mesh.tri_verts).astype(np.int64)
    shape = isokit.mesh((V, F)) - isokit.cylinder(a=(0.9, 0, -1), b=(0.9, 0, 1), radius=0.2)
    ref = torus - mf.Manifold.cylinder(2.0, 0.2, 0.2, SEG, center=True).translate([0.9, 0.0, 0.0])
    check("mesh - cylinder", shape, ref)
