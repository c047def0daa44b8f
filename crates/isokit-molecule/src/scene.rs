//! Molecules as quadric scenes (002 Sec. 7.3): ball-and-stick and space-filling models of a
//! [`Molecule`] in CPK colours, and a camera that frames them. Radii and colours come from
//! [`crate::Element`] (Bondi / Mantina / Alvarez van der Waals radii, Jmol's CPK colours,
//! converted to linear RGB there).

use glam::Vec3;
use isokit_field::{Aabb, Camera, Projection};
use isokit_render::RenderError;
use isokit_render::quadric::Quadric;
use isokit_render::splat::{MAX_QUADRICS, SplatScene};

use crate::Molecule;

/// [`RenderError::BadParameter`] for a value out of range.
fn bad(name: &'static str, value: impl ToString, why: &'static str) -> RenderError {
    RenderError::BadParameter {
        name,
        value: value.to_string(),
        why,
    }
}

/// Largest coordinate magnitude (Å) [`molecule_scene`] accepts: at 1e5 Å an f32 still
/// resolves 0.01 Å; PDB files cannot exceed ±1e4.
pub const MAX_COORDINATE: f32 = 1e5;

/// How atoms and bonds are drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum MoleculeStyle {
    /// Ball-and-stick: small spheres joined by cylinders.
    #[default]
    Balls,
    /// Space-filling: van der Waals spheres.
    Spacefill,
}

impl std::str::FromStr for MoleculeStyle {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "balls" | "ball-and-stick" | "sticks" => Ok(Self::Balls),
            "spacefill" | "space-filling" | "cpk" => Ok(Self::Spacefill),
            _ => Err(format!(
                "unknown molecule style {s:?} (expected balls or spacefill)"
            )),
        }
    }
}

/// Sizes of the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoleculeOptions {
    /// The style.
    pub style: MoleculeStyle,
    /// Ball radius as a fraction of the van der Waals radius (ball-and-stick).
    pub ball_scale: f32,
    /// Bond cylinder radius, Å (ball-and-stick).
    pub bond_radius: f32,
}

impl Default for MoleculeOptions {
    fn default() -> Self {
        Self {
            style: MoleculeStyle::Balls,
            ball_scale: 0.25,
            bond_radius: 0.15,
        }
    }
}

/// The quadrics of a molecule: first the atoms (quadric `i` is atom `i`), then for
/// ball-and-stick two half-bonds per bond, each a cylinder from its atom to the bond's
/// midpoint in that atom's colour (bonds between coincident atoms are left out). Errors
/// for an empty molecule, bad sizes, atoms beyond [`MAX_COORDINATE`], a bond naming a
/// missing atom, or more quadrics than [`MAX_QUADRICS`].
///
/// ```
/// use isokit_molecule::{
///     Atom, DEFAULT_BOND_TOLERANCE, Element, Molecule, MoleculeOptions, MoleculeStyle,
///     molecule_scene,
/// };
/// use glam::Vec3;
/// let mut water = Molecule::default();
/// water.atoms.push(Atom::new(Element::O, Vec3::ZERO));
/// water.atoms.push(Atom::new(Element::H, Vec3::new(0.757, 0.586, 0.0)));
/// water.atoms.push(Atom::new(Element::H, Vec3::new(-0.757, 0.586, 0.0)));
/// water.infer_bonds(DEFAULT_BOND_TOLERANCE);
/// let scene = molecule_scene(&water, &MoleculeOptions::default()).unwrap();
/// assert_eq!(scene.len(), 3 + 2 * 2); // 3 balls, 2 bonds of 2 half-sticks
/// let filled = molecule_scene(&water, &MoleculeOptions {
///     style: MoleculeStyle::Spacefill, ..Default::default() }).unwrap();
/// assert_eq!(filled.len(), 3);
/// ```
pub fn molecule_scene(mol: &Molecule, opts: &MoleculeOptions) -> Result<SplatScene, RenderError> {
    if mol.atoms.is_empty() {
        return Err(bad("molecule", &mol.name, "has no atoms"));
    }
    if !(opts.ball_scale.is_finite() && opts.ball_scale > 0.0 && opts.ball_scale <= 2.0) {
        return Err(bad("ball scale", opts.ball_scale, "must be in (0, 2]"));
    }
    if !(opts.bond_radius.is_finite() && opts.bond_radius > 0.0 && opts.bond_radius <= 2.0) {
        return Err(bad("bond radius", opts.bond_radius, "must be in (0, 2] Å"));
    }
    if let Some(a) = mol
        .atoms
        .iter()
        .find(|a| !(a.position.is_finite() && a.position.abs().max_element() <= MAX_COORDINATE))
    {
        return Err(bad(
            "atom position",
            a.position,
            "must be finite and within ±100,000 Å (beyond it f32 rendering loses the atoms)",
        ));
    }
    let sticks = opts.style == MoleculeStyle::Balls;
    let total = mol.atoms.len() + if sticks { 2 * mol.bonds.len() } else { 0 };
    if total > MAX_QUADRICS {
        return Err(bad(
            "molecule",
            format!("{} atoms and {} bonds", mol.atoms.len(), mol.bonds.len()),
            "needs more than 16,777,216 quadrics",
        ));
    }
    // The scene, and the per-quadric set-up and bins a splat of it holds.
    isokit_field::memory::check(
        &format!(
            "the scene of {} atoms and {} bonds ({total} quadrics)",
            mol.atoms.len(),
            mol.bonds.len()
        ),
        total as u128
            * (std::mem::size_of::<Quadric>() + std::mem::size_of::<Vec3>() + 160) as u128,
        "render the space-filling style (no bonds) or a part of the molecule, or raise the budget",
    )?;
    let mut scene = SplatScene {
        quadrics: Vec::with_capacity(total),
        colors: Vec::with_capacity(total),
    };
    for a in &mol.atoms {
        let r = a.element.vdw_radius() * if sticks { opts.ball_scale } else { 1.0 };
        scene.push(
            Quadric::sphere(a.position.as_dvec3(), f64::from(r))?,
            Vec3::from_array(a.element.cpk_color()),
        );
    }
    if sticks {
        let rb = f64::from(opts.bond_radius);
        for &[i, j] in &mol.bonds {
            let (Some(a), Some(b)) = (mol.atoms.get(i as usize), mol.atoms.get(j as usize)) else {
                return Err(bad(
                    "bond",
                    format!("{i}-{j}"),
                    "names an atom the molecule does not have",
                ));
            };
            let (pa, pb) = (a.position.as_dvec3(), b.position.as_dvec3());
            if (pb - pa).length() <= 1e-6 {
                continue;
            }
            let mid = 0.5 * (pa + pb);
            for (p, e) in [(pa, a.element), (pb, b.element)] {
                scene.push(
                    Quadric::cylinder(p, mid, rb)?,
                    Vec3::from_array(e.cpk_color()),
                );
            }
        }
    }
    Ok(scene)
}

/// A perspective camera (30° vertical field of view) framing a scene, looking along −z with
/// y up (the file's own orientation): the bounding sphere about the centre of the scene's box
/// that holds every solid's box fills the view.
pub fn framing_camera(scene: &SplatScene, width: u32, height: u32) -> Result<Camera, RenderError> {
    let (lo, hi) = scene
        .bounds()
        .ok_or_else(|| bad("scene", "empty", "nothing to frame"))?;
    let centre = 0.5 * (lo + hi);
    let radius = scene
        .quadrics
        .iter()
        .map(|q| {
            let (a, b) = q.bounds();
            (0.5 * (a + b) - centre).length() + 0.5 * (b - a).length()
        })
        .fold(0.0, f64::max)
        .max(1e-6);
    // `Camera::framing` fits the sphere through the box's corners: a cube of half-diagonal
    // `radius`.
    let half = Vec3::splat((radius / 3f64.sqrt()) as f32);
    let bounds = Aabb::from_center_half(centre.as_vec3(), half);
    Ok(Camera::framing(
        bounds,
        Vec3::Z,
        Projection::Perspective {
            fov_y_degrees: 30.0,
        },
        width,
        height,
    )?)
}
