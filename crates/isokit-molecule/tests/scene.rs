//! Molecule scenes built quadric by quadric: on a two-atom molecule, every ball, half-bond
//! and colour of the ball-and-stick and space-filling models is where, as large and as
//! coloured as 002 Sec. 7.3's models say.

use glam::{DVec3, Vec3};
use isokit_molecule::{
    Atom, DEFAULT_BOND_TOLERANCE, Element, Molecule, MoleculeOptions, MoleculeStyle, molecule_scene,
};
use isokit_render::quadric::{Quadric, QuadricKind};

/// Relative step inside and outside a surface for the containment checks.
const EPS: f64 = 1e-3;

/// A carbon at `c` and an oxygen at `c + 1.2 Å · dir`, with the one bond inferred.
fn carbon_monoxide(c: Vec3, dir: Vec3) -> Molecule {
    let mut m = Molecule::default();
    m.atoms.push(Atom::new(Element::C, c));
    m.atoms
        .push(Atom::new(Element::O, c + 1.2 * dir.normalize()));
    m.infer_bonds(DEFAULT_BOND_TOLERANCE);
    assert_eq!(m.bonds, vec![[0, 1]], "C–O at 1.2 Å is one bond");
    m
}

/// Directions to probe a sphere along: the axes both ways, diagonals, and a skew one.
fn directions() -> Vec<DVec3> {
    let mut d = vec![
        DVec3::X,
        -DVec3::X,
        DVec3::Y,
        -DVec3::Y,
        DVec3::Z,
        -DVec3::Z,
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(0.3, -0.8, 0.5),
    ];
    for v in &mut d {
        *v = v.normalize();
    }
    d
}

/// `q` is an ellipsoid holding every point just inside radius `r` of `centre` and none just
/// outside it, along each probe direction.
fn assert_sphere(q: &Quadric, centre: DVec3, r: f64, what: &str) {
    assert_eq!(q.kind(), QuadricKind::Ellipsoid, "{what}");
    assert!(q.contains(centre), "{what}: centre");
    for d in directions() {
        let inside = centre + (1.0 - EPS) * r * d;
        let outside = centre + (1.0 + EPS) * r * d;
        assert!(q.contains(inside), "{what}: {inside} (just inside r = {r})");
        assert!(
            !q.contains(outside),
            "{what}: {outside} (just outside r = {r})"
        );
    }
}

/// `q` is a cylinder of radius `r` from `from` to `to`: it holds the axis between them, not
/// the axis beyond either end, and around the axis just inside `r` but not just outside.
fn assert_cylinder(q: &Quadric, from: DVec3, to: DVec3, r: f64, what: &str) {
    assert_eq!(q.kind(), QuadricKind::Cylinder, "{what}");
    let axis = to - from;
    let at = |t: f64| from + t * axis;
    for t in [0.01, 0.25, 0.5, 0.75, 0.99] {
        assert!(q.contains(at(t)), "{what}: axis at t = {t} ({})", at(t));
    }
    for t in [-0.5, -0.01, 1.01, 1.1, 1.5, 2.0] {
        assert!(!q.contains(at(t)), "{what}: axis at t = {t} ({})", at(t));
    }
    let (u, v) = axis.normalize().any_orthonormal_pair();
    for t in [0.1, 0.5, 0.9] {
        for p in [u, v, -u, -v, (u + v).normalize(), (u - 2.0 * v).normalize()] {
            let inside = at(t) + (1.0 - EPS) * r * p;
            let outside = at(t) + (1.0 + EPS) * r * p;
            assert!(q.contains(inside), "{what}: {inside} (just inside r = {r})");
            assert!(
                !q.contains(outside),
                "{what}: {outside} (just outside r = {r})"
            );
        }
    }
}

fn cpk(e: Element) -> Vec3 {
    Vec3::from_array(e.cpk_color())
}

/// Checks the ball-and-stick scene of [`carbon_monoxide`] built with `opts`, whose ball
/// scale the caller states as `ball_scale` (so the default's value is checked too).
fn check_ball_and_stick(mol: &Molecule, opts: &MoleculeOptions, ball_scale: f32) {
    let scene = molecule_scene(mol, opts).unwrap();
    assert_eq!(scene.len(), 4, "2 balls + 2 half-bonds");
    assert_eq!(scene.colors.len(), 4);
    let (c, o) = (mol.atoms[0].position, mol.atoms[1].position);
    let (pc, po) = (c.as_dvec3(), o.as_dvec3());
    let mid = 0.5 * (pc + po);
    let rc = f64::from(ball_scale * Element::C.vdw_radius());
    let ro = f64::from(ball_scale * Element::O.vdw_radius());
    assert_sphere(&scene.quadrics[0], pc, rc, "carbon ball");
    assert_sphere(&scene.quadrics[1], po, ro, "oxygen ball");
    let rb = f64::from(opts.bond_radius);
    assert_cylinder(&scene.quadrics[2], pc, mid, rb, "carbon half-bond");
    assert_cylinder(&scene.quadrics[3], po, mid, rb, "oxygen half-bond");
    // Each ball and half-bond in its own atom's colour (and the two colours differ, so a
    // swap would show).
    assert_ne!(cpk(Element::C), cpk(Element::O));
    assert_eq!(
        scene.colors,
        vec![
            cpk(Element::C),
            cpk(Element::O),
            cpk(Element::C),
            cpk(Element::O)
        ]
    );
}

#[test]
fn ball_and_stick_of_two_atoms_is_two_balls_and_two_half_bonds() {
    let opts = MoleculeOptions::default();
    assert_eq!(opts.style, MoleculeStyle::Balls);
    // C at the origin, O at (1.2, 0, 0), with the default sizes (balls of 0.25 × vdW).
    let mol = carbon_monoxide(Vec3::ZERO, Vec3::X);
    check_ball_and_stick(&mol, &opts, 0.25);
    // The same off the axes and away from the origin.
    let tilted = carbon_monoxide(Vec3::new(3.0, -2.0, 5.0), Vec3::new(1.0, 2.0, -0.5));
    check_ball_and_stick(&tilted, &opts, 0.25);
    // Sizes other than the default are honoured.
    let big = MoleculeOptions {
        ball_scale: 0.4,
        bond_radius: 0.2,
        ..opts
    };
    check_ball_and_stick(&mol, &big, 0.4);
}

#[test]
fn spacefill_of_two_atoms_is_two_van_der_waals_spheres() {
    let opts = MoleculeOptions {
        style: MoleculeStyle::Spacefill,
        ..Default::default()
    };
    for mol in [
        carbon_monoxide(Vec3::ZERO, Vec3::X),
        carbon_monoxide(Vec3::new(3.0, -2.0, 5.0), Vec3::new(1.0, 2.0, -0.5)),
    ] {
        let scene = molecule_scene(&mol, &opts).unwrap();
        assert_eq!(scene.len(), 2, "one sphere per atom, no bonds");
        let (pc, po) = (
            mol.atoms[0].position.as_dvec3(),
            mol.atoms[1].position.as_dvec3(),
        );
        assert_sphere(
            &scene.quadrics[0],
            pc,
            f64::from(Element::C.vdw_radius()),
            "carbon sphere",
        );
        assert_sphere(
            &scene.quadrics[1],
            po,
            f64::from(Element::O.vdw_radius()),
            "oxygen sphere",
        );
        assert_eq!(scene.colors, vec![cpk(Element::C), cpk(Element::O)]);
    }
}
