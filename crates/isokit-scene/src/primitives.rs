//! The one vocabulary of analytic primitives: every primitive's name in scene files and on
//! the command line, its parameters with their defaults, and how it is built. Scene files
//! (`{"sphere": {"radius": 2}}`, missing parameters take the defaults), `isokit sample
//! sphere --radius 2`, `isokit octree sphere` and the Python bindings all read this table.
//!
//! ```
//! use isokit_scene::primitives::{Param, PrimitiveKind};
//! let sphere = PrimitiveKind::from_name("sphere").unwrap();
//! assert_eq!(sphere.params()[1], ("radius", Param::Number(1.0)));
//! let mut node = sphere.default_node();
//! node.set("radius", Param::Number(0.5)).unwrap();
//! assert!(node.set("half", Param::Number(1.0)).is_err());
//! ```

use glam::Vec3;
use isokit_field::FieldError;
use isokit_field::primitives::{
    CappedCone, CappedCylinder, Capsule, Cuboid, Ellipsoid, Plane, Primitive, RoundedBox, Sphere,
    Torus,
};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The value of a primitive's parameter: a number or a vector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Param {
    /// A number.
    Number(f32),
    /// A vector `[x, y, z]`.
    Vector([f32; 3]),
}

impl std::fmt::Display for Param {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Param::Number(x) => write!(f, "{x}"),
            Param::Vector([x, y, z]) => write!(f, "{x},{y},{z}"),
        }
    }
}

/// A parameter type: `f32` or `[f32; 3]`.
pub trait ParamType: Sized {
    /// From a parameter value (a single number fills all three components of a vector).
    fn from_param(p: Param) -> Option<Self>;
    /// As a parameter value.
    fn to_param(&self) -> Param;
}

impl ParamType for f32 {
    fn from_param(p: Param) -> Option<Self> {
        match p {
            Param::Number(x) => Some(x),
            Param::Vector(_) => None,
        }
    }
    fn to_param(&self) -> Param {
        Param::Number(*self)
    }
}

impl ParamType for [f32; 3] {
    fn from_param(p: Param) -> Option<Self> {
        Some(match p {
            Param::Number(x) => [x; 3],
            Param::Vector(v) => v,
        })
    }
    fn to_param(&self) -> Param {
        Param::Vector(*self)
    }
}

macro_rules! primitives {
    ($(
        $(#[$doc:meta])*
        $kind:ident, $node:ident, $key:literal, cli $cli:literal, aliases [$($alias:literal),*],
        note $note:literal,
        { $( $(#[$fdoc:meta])* $field:ident : $ty:tt = $default:expr ),* $(,)? }
        => |$n:ident, $v:ident| $build:expr;
    )*) => {
        $(
            $(#[$doc])*
            ///
            #[doc = concat!("Scene files: `{\"", $key, "\": {…}}`; `isokit sample ", $cli, "`.")]
            /// Missing parameters take their defaults.
            #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
            #[serde(default, deny_unknown_fields)]
            pub struct $node {
                $( $(#[$fdoc])* pub $field: $ty, )*
            }

            impl Default for $node {
                fn default() -> Self {
                    Self { $( $field: $default, )* }
                }
            }

            impl $node {
                /// The parameters and their values, in help order.
                pub fn params(&self) -> Vec<(&'static str, Param)> {
                    vec![$( (stringify!($field), ParamType::to_param(&self.$field)), )*]
                }

                /// Sets the parameter `name`; an error names the parameters it has.
                pub fn set(&mut self, name: &str, value: Param) -> Result<(), String> {
                    match name {
                        $( stringify!($field) => {
                            self.$field = ParamType::from_param(value).ok_or_else(|| {
                                format!("{} of {} takes a number, not a vector", name, $key)
                            })?;
                            Ok(())
                        } )*
                        _ => Err(unknown_param($key, name, &[$( stringify!($field), )*])),
                    }
                }

                /// The primitive (an error for invalid parameters, e.g. a negative radius).
                pub fn build(&self) -> Result<Primitive, FieldError> {
                    let $n = self;
                    let $v = |a: [f32; 3]| Vec3::from_array(a);
                    Ok($build.into())
                }
            }
        )*

        /// The kinds of primitive (one per row of the vocabulary).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum PrimitiveKind {
            $( $(#[$doc])* $kind, )*
        }

        /// A primitive node of any kind, with its parameters.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub enum PrimitiveNode {
            $( $(#[$doc])* $kind($node), )*
        }

        impl PrimitiveKind {
            /// Every kind, in the order of the documentation.
            pub const ALL: &'static [PrimitiveKind] = &[$( PrimitiveKind::$kind, )*];

            /// The key in scene files (`rounded_box`).
            pub fn key(self) -> &'static str {
                match self { $( PrimitiveKind::$kind => $key, )* }
            }

            /// The name on the command line (`rounded-box`).
            pub fn cli_name(self) -> &'static str {
                match self { $( PrimitiveKind::$kind => $cli, )* }
            }

            /// Other accepted names.
            pub fn aliases(self) -> &'static [&'static str] {
                match self { $( PrimitiveKind::$kind => &[$( $alias, )*], )* }
            }

            /// A note on the parameters for help texts (may be empty).
            pub fn note(self) -> &'static str {
                match self { $( PrimitiveKind::$kind => $note, )* }
            }

            /// The primitive with every parameter at its default.
            pub fn default_node(self) -> PrimitiveNode {
                match self { $( PrimitiveKind::$kind => PrimitiveNode::$kind($node::default()), )* }
            }

            /// The parameters and their defaults.
            pub fn params(self) -> Vec<(&'static str, Param)> {
                self.default_node().params()
            }
        }

        impl PrimitiveNode {
            /// Its kind.
            pub fn kind(&self) -> PrimitiveKind {
                match self { $( PrimitiveNode::$kind(_) => PrimitiveKind::$kind, )* }
            }
            /// The parameters and their values.
            pub fn params(&self) -> Vec<(&'static str, Param)> {
                match self { $( PrimitiveNode::$kind(n) => n.params(), )* }
            }
            /// Sets a parameter by name.
            pub fn set(&mut self, name: &str, value: Param) -> Result<(), String> {
                match self { $( PrimitiveNode::$kind(n) => n.set(name, value), )* }
            }
            /// The primitive.
            pub fn build(&self) -> Result<Primitive, FieldError> {
                match self { $( PrimitiveNode::$kind(n) => n.build(), )* }
            }
        }
    };
}

fn unknown_param(key: &str, name: &str, params: &[&str]) -> String {
    format!(
        "{key} has no parameter `{name}`; its parameters are {}",
        params.join(", ")
    )
}

impl PrimitiveKind {
    /// The kind called `name`: its scene-file key, its command-line name or an alias.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .iter()
            .copied()
            .find(|k| k.key() == name || k.cli_name() == name || k.aliases().contains(&name))
    }

    /// `--center 0,0,0 --radius 1`: the parameters with their defaults, as options.
    pub fn usage(self) -> String {
        self.params()
            .iter()
            .map(|(o, d)| format!("--{o} {d}"))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// The primitive with the parameters `given` (name and value, any order) and the defaults
    /// for the others, built once to check the values. Parameters the kind does not take are
    /// an error naming them and the ones it does take ([`ParamError::NotTaken`]), all at
    /// once, so a user sees every mistake in one message.
    pub fn node_with(self, given: &[(&str, Param)]) -> Result<PrimitiveNode, ParamError> {
        let takes: Vec<&'static str> = self.params().iter().map(|(n, _)| *n).collect();
        let unused: Vec<String> = given
            .iter()
            .filter(|(n, _)| !takes.contains(n))
            .map(|(n, _)| (*n).to_owned())
            .collect();
        if !unused.is_empty() {
            return Err(ParamError::NotTaken {
                kind: self.cli_name(),
                unused,
                takes,
            });
        }
        let mut node = self.default_node();
        for (n, v) in given {
            node.set(n, *v).map_err(ParamError::Invalid)?;
        }
        node.build()?;
        Ok(node)
    }
}

/// Why [`PrimitiveKind::node_with`] refused its parameters.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// Parameters the primitive does not take; the message names them as options
    /// (`--radius`), as [`PrimitiveKind::usage`] does.
    #[error(
        "{kind} does not take {}; its options are {}",
        options(unused),
        options(takes)
    )]
    NotTaken {
        /// The primitive's command-line name.
        kind: &'static str,
        /// The parameters it does not take, in the order given.
        unused: Vec<String>,
        /// The parameters it takes, in help order.
        takes: Vec<&'static str>,
    },
    /// A value of the wrong type (a vector for a number).
    #[error("{0}")]
    Invalid(String),
    /// A value out of range (a negative radius).
    #[error(transparent)]
    Build(#[from] FieldError),
}

fn options<S: AsRef<str>>(names: &[S]) -> String {
    names
        .iter()
        .map(|n| format!("--{}", n.as_ref()))
        .collect::<Vec<_>>()
        .join(", ")
}

primitives! {
    /// A ball.
    Sphere, SphereNode, "sphere", cli "sphere", aliases [], note "",
    {
        /// Centre.
        center: [f32; 3] = [0.0; 3],
        /// Radius, > 0.
        radius: f32 = 1.0,
    } => |n, v| Sphere::new(v(n.center), n.radius)?;

    /// An axis-aligned box.
    Box, BoxNode, "box", cli "box", aliases ["cuboid"], note "half extents",
    {
        /// Centre.
        center: [f32; 3] = [0.0; 3],
        /// Half extents, each > 0.
        half: [f32; 3] = [1.0, 0.75, 0.5],
    } => |n, v| Cuboid::new(v(n.center), v(n.half))?;

    /// A box of outer half extents `half` with its edges and corners rounded by `radius`
    /// (the points within `radius` of the box of half extents `half − radius`).
    RoundedBox, RoundedBoxNode, "rounded_box", cli "rounded-box", aliases ["rounded_box"],
    note "half: outer half extents; radius: edge rounding",
    {
        /// Centre.
        center: [f32; 3] = [0.0; 3],
        /// Outer half extents, each > 0.
        half: [f32; 3] = [1.0, 0.75, 0.5],
        /// Rounding radius, from 0 to the smallest half extent.
        radius: f32 = 0.2,
    } => |n, v| RoundedBox::new(v(n.center), v(n.half), n.radius)?;

    /// A torus around the z axis (rotate it with a transform).
    Torus, TorusNode, "torus", cli "torus", aliases [], note "axis z",
    {
        /// Centre.
        center: [f32; 3] = [0.0; 3],
        /// Distance from the centre to the tube's centre line, > 0.
        major: f32 = 0.75,
        /// Tube radius, > 0.
        minor: f32 = 0.25,
    } => |n, v| Torus::new(v(n.center), n.major, n.minor)?;

    /// The points within `radius` of the segment `a`–`b`.
    Capsule, CapsuleNode, "capsule", cli "capsule", aliases [], note "segment a-b",
    {
        /// One end of the segment.
        a: [f32; 3] = [0.0, 0.0, -0.5],
        /// The other end.
        b: [f32; 3] = [0.0, 0.0, 0.5],
        /// Radius, > 0.
        radius: f32 = 0.5,
    } => |n, v| Capsule::new(v(n.a), v(n.b), n.radius)?;

    /// A cylinder with flat caps at `a` and `b`.
    Cylinder, CylinderNode, "cylinder", cli "cylinder",
    aliases ["capped-cylinder", "capped_cylinder"], note "axis a-b",
    {
        /// Centre of one cap.
        a: [f32; 3] = [0.0, 0.0, -0.75],
        /// Centre of the other cap.
        b: [f32; 3] = [0.0, 0.0, 0.75],
        /// Radius, > 0.
        radius: f32 = 0.5,
    } => |n, v| CappedCylinder::new(v(n.a), v(n.b), n.radius)?;

    /// A cone frustum with flat caps: radius `ra` at `a`, `rb` at `b`.
    Cone, ConeNode, "cone", cli "cone", aliases ["capped-cone", "capped_cone"],
    note "radius ra at a, rb at b",
    {
        /// Centre of the first cap.
        a: [f32; 3] = [0.0, 0.0, -0.75],
        /// Centre of the second cap.
        b: [f32; 3] = [0.0, 0.0, 0.75],
        /// Radius at `a`, ≥ 0.
        ra: f32 = 0.75,
        /// Radius at `b`, ≥ 0.
        rb: f32 = 0.25,
    } => |n, v| CappedCone::new(v(n.a), v(n.b), n.ra, n.rb)?;

    /// The half-space `n·p ≤ offset` (unbounded: give sampling bounds or intersect it).
    Plane, PlaneNode, "plane", cli "plane", aliases [],
    note "n·p = offset; unbounded: needs --bounds",
    {
        /// Outward normal (normalized).
        normal: [f32; 3] = [0.0, 0.0, 1.0],
        /// Offset along the normal.
        offset: f32 = 0.0,
    } => |n, v| Plane::new(v(n.normal), n.offset)?;

    /// An axis-aligned ellipsoid (exact distance, Eberly's method).
    Ellipsoid, EllipsoidNode, "ellipsoid", cli "ellipsoid", aliases [],
    note "exact distance, Eberly's method",
    {
        /// Centre.
        center: [f32; 3] = [0.0; 3],
        /// Semi-axes, each > 0.
        radii: [f32; 3] = [1.0, 0.6, 0.4],
    } => |n, v| Ellipsoid::new(v(n.center), v(n.radii))?;
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_field::Field;

    #[test]
    fn every_kind_builds_from_its_defaults_and_knows_its_names() {
        for &k in PrimitiveKind::ALL {
            let p = k.default_node().build().unwrap();
            assert!(p.is_exact());
            assert_eq!(PrimitiveKind::from_name(k.key()), Some(k));
            assert_eq!(PrimitiveKind::from_name(k.cli_name()), Some(k));
            for a in k.aliases() {
                assert_eq!(PrimitiveKind::from_name(a), Some(k));
            }
            assert_eq!(k.default_node().kind(), k);
        }
        assert_eq!(PrimitiveKind::from_name("cube"), None);
    }

    #[test]
    fn nodes_take_their_own_parameters_only() {
        for &k in PrimitiveKind::ALL {
            assert_eq!(k.node_with(&[]).unwrap(), k.default_node());
        }
        let torus = PrimitiveKind::Torus;
        let n = torus.node_with(&[("minor", Param::Number(0.1))]).unwrap();
        assert!(n.params().contains(&("minor", Param::Number(0.1))));
        let e = torus
            .node_with(&[("radius", Param::Number(2.0)), ("ra", Param::Number(1.0))])
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "torus does not take --radius, --ra; its options are --center, --major, --minor"
        );
        let e = PrimitiveKind::Box
            .node_with(&[("half", Param::Number(-1.0))])
            .unwrap_err();
        assert!(matches!(e, ParamError::Build(_)), "{e}");
        let e = torus
            .node_with(&[("major", Param::Vector([1.0; 3]))])
            .unwrap_err();
        assert!(matches!(e, ParamError::Invalid(_)), "{e}");
    }

    #[test]
    fn parameters_are_set_by_name_and_checked() {
        let mut n = PrimitiveKind::Cone.default_node();
        n.set("ra", Param::Number(0.5)).unwrap();
        n.set("a", Param::Number(1.0)).unwrap();
        assert!(n.params().contains(&("a", Param::Vector([1.0; 3]))));
        let e = n.set("radius", Param::Number(1.0)).unwrap_err();
        assert!(e.contains("a, b, ra, rb"), "{e}");
        let e = n.set("ra", Param::Vector([1.0; 3])).unwrap_err();
        assert!(e.contains("number"), "{e}");
        let mut s = PrimitiveKind::Sphere.default_node();
        s.set("radius", Param::Number(-1.0)).unwrap();
        assert!(s.build().is_err());
    }
}
