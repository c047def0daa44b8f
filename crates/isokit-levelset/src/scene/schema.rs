//! The scene schema: one set of serde types read from JSON and from TOML.
//!
//! A node of the shape tree is a table with exactly one key, the node's kind (serde's
//! externally tagged enum):
//!
//! ```json
//! {"difference": [
//!     {"sphere": {"radius": 1.0}},
//!     {"box": {"half": [0.6, 0.6, 0.6], "center": [0.5, 0.5, 0.5]}}
//! ]}
//! ```
//!
//! Lengths are in world units. Unknown keys are errors, so a misspelt parameter never
//! silently takes its default.

use serde::{Deserialize, Serialize};

fn zero3() -> [f32; 3] {
    [0.0; 3]
}

fn auto() -> String {
    "auto".to_owned()
}

/// A node of the shape tree: a source (primitive, mesh, cloud, volume, included scene) or
/// an operation on other nodes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Node {
    /// A ball: `{"sphere": {"radius": r, "center": [x, y, z]}}`.
    Sphere {
        /// Radius, > 0.
        radius: f32,
        /// Centre (default the origin).
        #[serde(default = "zero3")]
        center: [f32; 3],
    },
    /// An axis-aligned box: `{"box": {"half": [a, b, c], "center": [..]}}`.
    Box {
        /// Half extents, each > 0.
        half: [f32; 3],
        /// Centre (default the origin).
        #[serde(default = "zero3")]
        center: [f32; 3],
    },
    /// A box with rounded edges: the box of half extents `half` grown by `radius`.
    RoundedBox {
        /// Half extents of the inner box, each > 0.
        half: [f32; 3],
        /// Rounding radius, > 0.
        radius: f32,
        /// Centre (default the origin).
        #[serde(default = "zero3")]
        center: [f32; 3],
    },
    /// A torus around the z axis (rotate it with `transform`).
    Torus {
        /// Distance from the centre to the tube's centre line, > 0.
        major: f32,
        /// Tube radius, > 0 (larger than `major` gives the spindle torus).
        minor: f32,
        /// Centre (default the origin).
        #[serde(default = "zero3")]
        center: [f32; 3],
    },
    /// The points within `radius` of the segment `a`–`b`.
    Capsule {
        /// One end of the segment.
        a: [f32; 3],
        /// The other end.
        b: [f32; 3],
        /// Radius, > 0.
        radius: f32,
    },
    /// A cylinder with flat caps at `a` and `b`.
    Cylinder {
        /// Centre of one cap.
        a: [f32; 3],
        /// Centre of the other cap.
        b: [f32; 3],
        /// Radius, > 0.
        radius: f32,
    },
    /// A cone frustum with flat caps: radius `ra` at `a`, `rb` at `b`.
    Cone {
        /// Centre of the first cap.
        a: [f32; 3],
        /// Centre of the second cap.
        b: [f32; 3],
        /// Radius at `a`, ≥ 0.
        ra: f32,
        /// Radius at `b`, ≥ 0.
        rb: f32,
    },
    /// The half-space `n·p ≤ offset` (unbounded: give `sampling.bounds` or intersect it).
    Plane {
        /// Outward normal (normalized here).
        normal: [f32; 3],
        /// Offset along the normal.
        #[serde(default)]
        offset: f32,
    },
    /// An axis-aligned ellipsoid (exact distance).
    Ellipsoid {
        /// Semi-axes, each > 0.
        radii: [f32; 3],
        /// Centre (default the origin).
        #[serde(default = "zero3")]
        center: [f32; 3],
    },
    /// A triangle mesh (OBJ, glTF/GLB, PLY, STL, OFF) as an exact signed distance
    /// (kd-tree).
    Mesh {
        /// Path, relative to the scene file.
        path: String,
        /// Sign method: `auto`, `pseudonormal`, `winding` or `unsigned`.
        #[serde(default = "auto")]
        sign: String,
    },
    /// A point cloud (PLY, XYZ) as a partition-of-unity distance field.
    Points {
        /// Path, relative to the scene file.
        path: String,
        /// Neighbours per evaluation (default: the library's).
        #[serde(default)]
        k: Option<usize>,
        /// `auto` (the cloud's normals when it has them, else estimated), `given` or
        /// `estimate`.
        #[serde(default = "auto")]
        normals: String,
    },
    /// A sampled volume (NRRD, NHDR, NPY, NIfTI) read as a field.
    Volume {
        /// Path, relative to the scene file.
        path: String,
        /// Reconstruction filter: `trilinear` (default), `cubic_bspline`, `catmull_rom`.
        #[serde(default)]
        filter: Option<String>,
        /// The isovalue that is the surface (default 0).
        #[serde(default)]
        iso: f32,
        /// Which side of `iso` is inside: `below` (distance fields, default) or `above`
        /// (densities such as CT).
        #[serde(default)]
        inside: Option<String>,
    },
    /// Another scene file's shape, reused as a node.
    Include {
        /// Path, relative to this scene file.
        path: String,
    },
    /// `min` of the children.
    Union(Vec<Node>),
    /// `max` of the children.
    Intersection(Vec<Node>),
    /// The first child minus the others: `max(f0, −f1, −f2, …)`.
    Difference(Vec<Node>),
    /// `−f`: inside and outside swapped.
    Complement(Box<Node>),
    /// Smooth union with blend radius `radius`.
    SmoothUnion(Smooth),
    /// Smooth intersection with blend radius `radius`.
    SmoothIntersection(Smooth),
    /// Smooth difference (first minus the others) with blend radius `radius`.
    SmoothDifference(Smooth),
    /// Dilation (`by > 0`) or erosion (`by < 0`): `f − by`.
    Offset {
        /// Distance to move the surface outwards.
        by: f32,
        /// The shape.
        of: Box<Node>,
    },
    /// A hollow shell of the given thickness around the surface: `|f| − thickness/2`.
    Shell {
        /// Wall thickness, > 0.
        thickness: f32,
        /// The shape.
        of: Box<Node>,
    },
    /// Linear interpolation `(1 − t)·f_from + t·f_to` (002 Sec. 6.4.3).
    Morph {
        /// Blend parameter, 0 gives `from`, 1 gives `to`.
        t: f32,
        /// The shape at `t = 0`.
        from: Box<Node>,
        /// The shape at `t = 1`.
        to: Box<Node>,
    },
    /// A similarity transform: scale, then rotate, then translate.
    Transform(TransformSpec),
}

/// Parameters of the smooth operations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Smooth {
    /// Blend radius, ≥ 0 (0 is the sharp operation).
    pub radius: f32,
    /// The operands (at least one; for the difference, the first minus the others).
    pub of: Vec<Node>,
}

/// Parameters of `transform`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformSpec {
    /// Translation (applied last).
    #[serde(default)]
    pub translate: Option<[f32; 3]>,
    /// Rotation about an axis through the origin.
    #[serde(default)]
    pub rotate: Option<Rotation>,
    /// Uniform scale factor, > 0 (applied first). Non-uniform scaling would not keep
    /// distances and is not offered.
    #[serde(default)]
    pub scale: Option<f32>,
    /// The shape.
    pub of: Box<Node>,
}

/// A rotation by `degrees` about `axis` (right-handed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rotation {
    /// Axis, nonzero.
    pub axis: [f32; 3],
    /// Angle in degrees.
    pub degrees: f32,
}

/// The camera of the renderer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Eye position.
    pub eye: [f32; 3],
    /// The point looked at (default the origin).
    #[serde(default = "zero3")]
    pub target: [f32; 3],
    /// Up direction (default +y).
    #[serde(default = "up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees (default 45).
    #[serde(default = "fov")]
    pub fov: f32,
}

fn up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

fn fov() -> f32 {
    45.0
}

fn one() -> f32 {
    1.0
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

/// A light: directional when `direction` is given, a point light at `position` otherwise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Direction the light travels (for a directional light).
    #[serde(default)]
    pub direction: Option<[f32; 3]>,
    /// Position (for a point light).
    #[serde(default)]
    pub position: Option<[f32; 3]>,
    /// Linear RGB colour (default white).
    #[serde(default = "white")]
    pub color: [f32; 3],
    /// Intensity factor (default 1).
    #[serde(default = "one")]
    pub intensity: f32,
}

/// Surface shading of the renderer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShadingSpec {
    /// `phong` (default), `curvature` (colour by principal curvatures), `normal`.
    #[serde(default)]
    pub mode: Option<String>,
    /// Base colour, linear RGB (default light grey).
    #[serde(default)]
    pub color: Option<[f32; 3]>,
    /// Ambient term (default 0.1).
    #[serde(default)]
    pub ambient: Option<f32>,
    /// Specular exponent (default 32).
    #[serde(default)]
    pub shininess: Option<f32>,
}

/// How the scene is sampled to a grid.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingSpec {
    /// Samples along the longest side of the domain (default 128).
    #[serde(default)]
    pub resolution: Option<usize>,
    /// Narrow band half-width in world units (default 4 voxels).
    #[serde(default)]
    pub band: Option<f32>,
    /// Brick size, a power of two from 2 to 64 (default 4).
    #[serde(default)]
    pub brick: Option<usize>,
    /// The domain, `[[xmin, ymin, zmin], [xmax, ymax, zmax]]` (default: the shape's
    /// bounds, padded by the band and two voxels). Required for unbounded shapes.
    #[serde(default)]
    pub bounds: Option<[[f32; 3]; 2]>,
}

/// A whole scene file: the shape tree and the renderer's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// The shape tree.
    pub shape: Node,
    /// Camera of the renderer.
    #[serde(default)]
    pub camera: Option<CameraSpec>,
    /// Lights of the renderer.
    #[serde(default)]
    pub lights: Vec<LightSpec>,
    /// Shading of the renderer.
    #[serde(default)]
    pub shading: Option<ShadingSpec>,
    /// Grid sampling.
    #[serde(default)]
    pub sampling: SamplingSpec,
}

impl Node {
    /// The node's kind as written in a scene file, e.g. `"smooth_union"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Node::Sphere { .. } => "sphere",
            Node::Box { .. } => "box",
            Node::RoundedBox { .. } => "rounded_box",
            Node::Torus { .. } => "torus",
            Node::Capsule { .. } => "capsule",
            Node::Cylinder { .. } => "cylinder",
            Node::Cone { .. } => "cone",
            Node::Plane { .. } => "plane",
            Node::Ellipsoid { .. } => "ellipsoid",
            Node::Mesh { .. } => "mesh",
            Node::Points { .. } => "points",
            Node::Volume { .. } => "volume",
            Node::Include { .. } => "include",
            Node::Union(_) => "union",
            Node::Intersection(_) => "intersection",
            Node::Difference(_) => "difference",
            Node::Complement(_) => "complement",
            Node::SmoothUnion(_) => "smooth_union",
            Node::SmoothIntersection(_) => "smooth_intersection",
            Node::SmoothDifference(_) => "smooth_difference",
            Node::Offset { .. } => "offset",
            Node::Shell { .. } => "shell",
            Node::Morph { .. } => "morph",
            Node::Transform(_) => "transform",
        }
    }
}

/// Constructors for building trees in code (the same trees a scene file describes).
///
/// ```
/// use isokit_levelset::scene::schema::Node;
/// let part = Node::difference(vec![
///     Node::sphere(1.0, [0.0; 3]),
///     Node::cuboid([0.5; 3], [1.0, 0.0, 0.0]),
/// ]);
/// assert_eq!(part.kind(), "difference");
/// ```
impl Node {
    /// `{"sphere": {"radius": r, "center": c}}`.
    pub fn sphere(radius: f32, center: [f32; 3]) -> Self {
        Node::Sphere { radius, center }
    }

    /// `{"box": {"half": h, "center": c}}`.
    pub fn cuboid(half: [f32; 3], center: [f32; 3]) -> Self {
        Node::Box { half, center }
    }

    /// `{"torus": {"major": R, "minor": r, "center": c}}`.
    pub fn torus(major: f32, minor: f32, center: [f32; 3]) -> Self {
        Node::Torus {
            major,
            minor,
            center,
        }
    }

    /// `{"cylinder": {"a": a, "b": b, "radius": r}}`.
    pub fn cylinder(a: [f32; 3], b: [f32; 3], radius: f32) -> Self {
        Node::Cylinder { a, b, radius }
    }

    /// `{"mesh": {"path": p, "sign": "auto"}}`.
    pub fn mesh(path: impl Into<String>) -> Self {
        Node::Mesh {
            path: path.into(),
            sign: auto(),
        }
    }

    /// `{"union": [...]}`.
    pub fn union(of: Vec<Node>) -> Self {
        Node::Union(of)
    }

    /// `{"intersection": [...]}`.
    pub fn intersection(of: Vec<Node>) -> Self {
        Node::Intersection(of)
    }

    /// `{"difference": [A, B, ...]}`: A minus the others.
    pub fn difference(of: Vec<Node>) -> Self {
        Node::Difference(of)
    }

    /// `{"smooth_union": {"radius": k, "of": [...]}}`.
    pub fn smooth_union(radius: f32, of: Vec<Node>) -> Self {
        Node::SmoothUnion(Smooth { radius, of })
    }

    /// `{"offset": {"by": r, "of": self}}`.
    pub fn offset(self, by: f32) -> Self {
        Node::Offset {
            by,
            of: Box::new(self),
        }
    }

    /// `{"transform": {"translate": t, "of": self}}`.
    pub fn translated(self, t: [f32; 3]) -> Self {
        Node::Transform(TransformSpec {
            translate: Some(t),
            rotate: None,
            scale: None,
            of: Box::new(self),
        })
    }

    /// `{"transform": {"rotate": {"axis": a, "degrees": d}, "of": self}}`.
    pub fn rotated(self, axis: [f32; 3], degrees: f32) -> Self {
        Node::Transform(TransformSpec {
            translate: None,
            rotate: Some(Rotation { axis, degrees }),
            scale: None,
            of: Box::new(self),
        })
    }
}

impl SceneFile {
    /// A scene of just `shape`, with default camera, lights, shading and sampling.
    pub fn new(shape: Node) -> Self {
        Self {
            shape,
            camera: None,
            lights: Vec::new(),
            shading: None,
            sampling: SamplingSpec::default(),
        }
    }
}
