//! The vocabulary of 2D profiles in scene files: circle, rectangle, rounded rectangle,
//! polygon, ellipse, slot and hexagon, each an exact 2D signed distance in the xy-plane
//! (`isokit_field::profile`). Profiles combine with the same CSG, blend, offset and shell
//! nodes as solids, and become solids by `extrude` and `revolve`; used directly they are
//! the infinite prisms over them (unbounded in z).
//!
//! Missing parameters take their defaults, as for the 3D primitives (`{"circle": {}}` is
//! the unit circle); a polygon needs its `points`.

use glam::Vec2;
use isokit_field::FieldError;
use isokit_field::profile::{Circle, Ellipse, Polygon, Profile, Rectangle, RoundedRectangle, Slot};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

fn v(a: [f32; 2]) -> Vec2 {
    Vec2::from_array(a)
}

/// A disk: `{"circle": {"radius": r, "center": [x, y]}}`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct CircleNode {
    /// Radius, > 0 (default 1).
    pub radius: f32,
    /// Centre (default the origin).
    pub center: [f32; 2],
}

impl Default for CircleNode {
    fn default() -> Self {
        Self {
            radius: 1.0,
            center: [0.0; 2],
        }
    }
}

/// An axis-aligned rectangle: `{"rectangle": {"half": [a, b], "center": [x, y]}}`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct RectangleNode {
    /// Half extents, each > 0 (default `[1, 0.5]`).
    pub half: [f32; 2],
    /// Centre (default the origin).
    pub center: [f32; 2],
}

impl Default for RectangleNode {
    fn default() -> Self {
        Self {
            half: [1.0, 0.5],
            center: [0.0; 2],
        }
    }
}

/// A rectangle with rounded corners: `{"rounded_rectangle": {"half": [a, b], "radius": r}}`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct RoundedRectangleNode {
    /// Outer half extents, each > 0 (default `[1, 0.5]`).
    pub half: [f32; 2],
    /// Corner radius, `0 ≤ radius ≤ min(half)` (default 0.1).
    pub radius: f32,
    /// Centre (default the origin).
    pub center: [f32; 2],
}

impl Default for RoundedRectangleNode {
    fn default() -> Self {
        Self {
            half: [1.0, 0.5],
            radius: 0.1,
            center: [0.0; 2],
        }
    }
}

/// A polygon from its vertices: `{"polygon": {"points": [[x, y], …]}}` (either orientation,
/// closed implicitly; any simple polygon, exact, signed by the even-odd rule).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PolygonNode {
    /// The vertices, at least 3.
    pub points: Vec<[f32; 2]>,
}

/// An axis-aligned ellipse: `{"ellipse": {"radii": [a, b], "center": [x, y]}}` (exact).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct EllipseNode {
    /// Semi-axes, each > 0 (default `[1, 0.5]`).
    pub radii: [f32; 2],
    /// Centre (default the origin).
    pub center: [f32; 2],
}

impl Default for EllipseNode {
    fn default() -> Self {
        Self {
            radii: [1.0, 0.5],
            center: [0.0; 2],
        }
    }
}

/// A slot (stadium): the points within `radius` of the segment `a`–`b`:
/// `{"slot": {"a": [x, y], "b": [x, y], "radius": r}}`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct SlotNode {
    /// One end of the segment (default `[-0.5, 0]`).
    pub a: [f32; 2],
    /// The other end (default `[0.5, 0]`).
    pub b: [f32; 2],
    /// Radius, > 0 (default 0.25).
    pub radius: f32,
}

impl Default for SlotNode {
    fn default() -> Self {
        Self {
            a: [-0.5, 0.0],
            b: [0.5, 0.0],
            radius: 0.25,
        }
    }
}

/// A regular hexagon: `{"hexagon": {"radius": r, "center": [x, y]}}`, `radius` the distance
/// from the centre to the corners, two corners on the x axis (flat sides parallel to it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct HexagonNode {
    /// Circumradius, > 0 (default 1).
    pub radius: f32,
    /// Centre (default the origin).
    pub center: [f32; 2],
}

impl Default for HexagonNode {
    fn default() -> Self {
        Self {
            radius: 1.0,
            center: [0.0; 2],
        }
    }
}

/// A profile node of any kind, with its parameters (what [`crate::Node::profile`] returns).
#[derive(Clone, Debug, PartialEq)]
pub enum ProfileNode {
    /// A circle.
    Circle(CircleNode),
    /// A rectangle.
    Rectangle(RectangleNode),
    /// A rounded rectangle.
    RoundedRectangle(RoundedRectangleNode),
    /// A polygon.
    Polygon(PolygonNode),
    /// An ellipse.
    Ellipse(EllipseNode),
    /// A slot.
    Slot(SlotNode),
    /// A regular hexagon.
    Hexagon(HexagonNode),
}

impl ProfileNode {
    /// The exact profile (an error for invalid parameters, e.g. a negative radius).
    pub fn build(&self) -> Result<Profile, FieldError> {
        Ok(match self {
            ProfileNode::Circle(n) => Circle::new(v(n.center), n.radius)?.into(),
            ProfileNode::Rectangle(n) => Rectangle::new(v(n.center), v(n.half))?.into(),
            ProfileNode::RoundedRectangle(n) => {
                RoundedRectangle::new(v(n.center), v(n.half), n.radius)?.into()
            }
            ProfileNode::Polygon(n) => {
                let pts: Vec<Vec2> = n.points.iter().map(|&p| v(p)).collect();
                Polygon::new(&pts)?.into()
            }
            ProfileNode::Ellipse(n) => Ellipse::new(v(n.center), v(n.radii))?.into(),
            ProfileNode::Slot(n) => Slot::new(v(n.a), v(n.b), n.radius)?.into(),
            ProfileNode::Hexagon(n) => Polygon::regular(v(n.center), n.radius, 6, 0.0)?.into(),
        })
    }

    /// The parameters as numbers, for content hashes (names and values in order).
    pub fn numbers(&self) -> Vec<f32> {
        match self {
            ProfileNode::Circle(n) => vec![n.radius, n.center[0], n.center[1]],
            ProfileNode::Rectangle(n) => [n.half, n.center].concat(),
            ProfileNode::RoundedRectangle(n) => {
                vec![n.half[0], n.half[1], n.radius, n.center[0], n.center[1]]
            }
            ProfileNode::Polygon(n) => n.points.concat(),
            ProfileNode::Ellipse(n) => [n.radii, n.center].concat(),
            ProfileNode::Slot(n) => vec![n.a[0], n.a[1], n.b[0], n.b[1], n.radius],
            ProfileNode::Hexagon(n) => vec![n.radius, n.center[0], n.center[1]],
        }
    }
}
