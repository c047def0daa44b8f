//! The shape options of `isokit sample` and `isokit octree`, one flag per parameter name of
//! the primitive vocabulary (`isokit_scene::primitives`).

use super::parse_vec3;
use glam::Vec3;
use isokit_scene::primitives::Param;

/// Shape options; each primitive takes its own (see `isokit sample --help`).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ShapeOptions {
    /// Centre (sphere, box, rounded-box, torus, ellipsoid), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub center: Option<Vec3>,
    /// Radius (sphere, capsule, cylinder) or edge rounding radius (rounded-box).
    #[arg(long, allow_hyphen_values = true)]
    pub radius: Option<f32>,
    /// Half extents (box, rounded-box), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub half: Option<Vec3>,
    /// Major radius (torus).
    #[arg(long, allow_hyphen_values = true)]
    pub major: Option<f32>,
    /// Minor (tube) radius (torus).
    #[arg(long, allow_hyphen_values = true)]
    pub minor: Option<f32>,
    /// First end point (capsule, cylinder, cone), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub a: Option<Vec3>,
    /// Second end point (capsule, cylinder, cone), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub b: Option<Vec3>,
    /// Radius at `a` (cone).
    #[arg(long, allow_hyphen_values = true)]
    pub ra: Option<f32>,
    /// Radius at `b` (cone).
    #[arg(long, allow_hyphen_values = true)]
    pub rb: Option<f32>,
    /// Normal (plane), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub normal: Option<Vec3>,
    /// Offset along the normal (plane: n·p = offset).
    #[arg(long, allow_hyphen_values = true)]
    pub offset: Option<f32>,
    /// Semi-axes (ellipsoid), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub radii: Option<Vec3>,
}

/// Every shape option (the union over the vocabulary), in the order of `--help`.
pub const SHAPE_OPTIONS: [&str; 12] = [
    "center", "radius", "half", "major", "minor", "a", "b", "ra", "rb", "normal", "offset", "radii",
];

impl ShapeOptions {
    /// The options given, in the order of [`SHAPE_OPTIONS`].
    pub fn given(&self) -> Vec<(&'static str, Param)> {
        SHAPE_OPTIONS
            .iter()
            .filter_map(|o| self.get(o).map(|v| (*o, v)))
            .collect()
    }

    /// The option called `name`, if given.
    pub fn get(&self, name: &str) -> Option<Param> {
        let n = |x: Option<f32>| x.map(Param::Number);
        let v = |x: Option<Vec3>| x.map(|v| Param::Vector(v.to_array()));
        match name {
            "center" => v(self.center),
            "radius" => n(self.radius),
            "half" => v(self.half),
            "major" => n(self.major),
            "minor" => n(self.minor),
            "a" => v(self.a),
            "b" => v(self.b),
            "ra" => n(self.ra),
            "rb" => n(self.rb),
            "normal" => v(self.normal),
            "offset" => n(self.offset),
            "radii" => v(self.radii),
            _ => None,
        }
    }
}
