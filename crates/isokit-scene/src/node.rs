//! Typed scene nodes: one Rust type per node kind of the scene files, with constructors, and
//! serde as the view that reads and writes them (JSON and TOML alike).
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
//! silently takes its default; missing primitive parameters take the defaults of
//! [`crate::primitives`]. Options are enums ([`SignMode`], [`BandMethod`], [`Filter`],
//! [`Inside`], [`Normals`]), written in snake case.
//!
//! Sources come from files (`path`, relative to the scene file) or from memory (a mesh's
//! arrays, a cloud, a grid, a brick grid, any [`Field`]): [`Node::mesh_data`],
//! [`Node::points_data`], [`Node::grid`], [`Node::bricks`], [`Node::field`]. A node with
//! in-memory data cannot be written as a scene file ([`crate::SceneFile::to_json`] names the
//! node).

use crate::primitives::{
    BoxNode, CapsuleNode, ConeNode, CylinderNode, EllipsoidNode, PlaneNode, PrimitiveNode,
    RoundedBoxNode, SphereNode, TorusNode,
};
use isokit_field::{BrickGrid, Field, Grid, PointCloud, TriMesh};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// Data held in memory by a source node, with a hash of its content (computed once) so that
/// scenes can tell an unchanged source from a changed one.
#[derive(Clone)]
pub struct Memory<T: ?Sized> {
    /// The data.
    pub data: Arc<T>,
    /// A hash of the data's content.
    pub hash: u64,
}

impl<T: ?Sized> std::fmt::Debug for Memory<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Memory({:016x})", self.hash)
    }
}

impl<T: ?Sized> PartialEq for Memory<T> {
    fn eq(&self, other: &Self) -> bool {
        self.hash == other.hash
    }
}

fn hash_f32s(h: &mut impl Hasher, v: impl IntoIterator<Item = f32>) {
    for x in v {
        x.to_bits().hash(h);
    }
}

fn hasher() -> std::collections::hash_map::DefaultHasher {
    std::collections::hash_map::DefaultHasher::new()
}

impl Memory<TriMesh> {
    /// A mesh held in memory.
    pub fn mesh(mesh: TriMesh) -> Self {
        let mut h = hasher();
        "mesh".hash(&mut h);
        hash_f32s(&mut h, mesh.positions.iter().flat_map(|p| p.to_array()));
        mesh.triangles.hash(&mut h);
        Self {
            hash: h.finish(),
            data: Arc::new(mesh),
        }
    }
}

impl Memory<PointCloud> {
    /// A cloud held in memory.
    pub fn cloud(cloud: PointCloud) -> Self {
        let mut h = hasher();
        "cloud".hash(&mut h);
        hash_f32s(&mut h, cloud.points.iter().flat_map(|p| p.to_array()));
        if let Some(n) = &cloud.normals {
            hash_f32s(&mut h, n.iter().flat_map(|p| p.to_array()));
        }
        Self {
            hash: h.finish(),
            data: Arc::new(cloud),
        }
    }
}

/// A sampled volume held in memory: a dense grid or a sparse brick grid.
#[derive(Clone, Debug)]
pub enum VolumeData {
    /// A dense grid.
    Grid(Grid),
    /// A brick grid (its background outside the bricks).
    Bricks(BrickGrid),
}

impl Memory<VolumeData> {
    /// A volume held in memory.
    pub fn volume(v: VolumeData) -> Self {
        let mut h = hasher();
        match &v {
            VolumeData::Grid(g) => {
                "grid".hash(&mut h);
                g.dims().hash(&mut h);
                hash_f32s(&mut h, g.origin().to_array());
                g.spacing().to_bits().hash(&mut h);
                hash_f32s(&mut h, g.data().iter().copied());
            }
            VolumeData::Bricks(b) => {
                "bricks".hash(&mut h);
                b.dims().hash(&mut h);
                hash_f32s(&mut h, b.origin().to_array());
                b.spacing().to_bits().hash(&mut h);
                b.brick_count().hash(&mut h);
                b.background().to_bits().hash(&mut h);
                for (n, info) in b.bricks().iter().enumerate() {
                    info.coord.hash(&mut h);
                    hash_f32s(&mut h, b.brick_data(n).iter().copied());
                }
            }
        }
        Self {
            hash: h.finish(),
            data: Arc::new(v),
        }
    }
}

/// How a mesh's signed distance is signed (see `isokit_kdtree::mesh::SignMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SignMode {
    /// Pseudonormals on watertight, oriented meshes, the generalized winding number otherwise.
    #[default]
    Auto,
    /// Angle-weighted pseudonormals.
    Pseudonormal,
    /// The generalized winding number (robust on open and self-intersecting meshes).
    Winding,
    /// No sign: the unsigned distance.
    Unsigned,
}

/// How a mesh source becomes a band when a scene is sampled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BandMethod {
    /// A band-limited kd-tree query per sample (exact anywhere).
    #[default]
    Kdtree,
    /// Prism scan conversion of the mesh on the sampling lattice (Sigg 2006, Sec. 4.2), on a
    /// hardware GPU when one exists, else the CPU.
    Prism,
    /// Prism scan conversion on the CPU.
    PrismCpu,
    /// Prism scan conversion on the GPU (any adapter, software ones included).
    PrismGpu,
}

/// Reconstruction filter of a volume source.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Filter {
    /// Trilinear interpolation.
    #[default]
    Trilinear,
    /// Tricubic B-spline approximation.
    CubicBspline,
    /// Tricubic Catmull-Rom interpolation.
    CatmullRom,
}

/// Which side of the isovalue is inside.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Inside {
    /// Below the isovalue (distance fields).
    #[default]
    Below,
    /// Above the isovalue (densities such as CT).
    Above,
}

/// Where a cloud's normals come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Normals {
    /// The file's normals when it has them, else estimated.
    #[default]
    Auto,
    /// The file's normals (an error without them).
    Given,
    /// Estimated (PCA and minimum-spanning-tree orientation).
    Estimate,
}

/// A triangle mesh (OBJ, glTF/GLB, PLY, STL, OFF, or in memory) as an exact signed distance.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MeshNode {
    /// Path, relative to the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<String>,
    /// Sign method.
    #[serde(default)]
    pub sign: SignMode,
    /// How the mesh becomes a band: a kd-tree query per sample, or prism scan conversion.
    #[serde(default, skip_serializing_if = "is_default")]
    pub method: BandMethod,
    /// The mesh in memory (instead of `path`).
    #[serde(skip)]
    #[schemars(skip)]
    pub data: Option<Memory<TriMesh>>,
}

/// A point cloud (PLY, XYZ, or in memory) as a partition-of-unity distance field.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PointsNode {
    /// Path, relative to the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<String>,
    /// Neighbours per evaluation (default: the library's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k: Option<usize>,
    /// Where the normals come from.
    #[serde(default)]
    pub normals: Normals,
    /// The cloud in memory (instead of `path`).
    #[serde(skip)]
    #[schemars(skip)]
    pub data: Option<Memory<PointCloud>>,
}

/// A sampled volume (NRRD, NHDR, NPY, NIfTI, or in memory) read as a field.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VolumeNode {
    /// Path, relative to the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<String>,
    /// Reconstruction filter.
    #[serde(default, skip_serializing_if = "is_default")]
    pub filter: Filter,
    /// The isovalue that is the surface.
    #[serde(default)]
    pub iso: f32,
    /// Which side of `iso` is inside.
    #[serde(default, skip_serializing_if = "is_default")]
    pub inside: Inside,
    /// The volume in memory (instead of `path`).
    #[serde(skip)]
    #[schemars(skip)]
    pub data: Option<Memory<VolumeData>>,
}

fn default_max_level() -> u8 {
    7
}

/// A child's field stored in a hashed octree (an adaptively sampled distance field,
/// Sigg 2006, Ch. 3) and evaluated by trilinear interpolation of the octree: a cheaper
/// stand-in for an expensive child (a mesh, a cloud).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OctreeNode {
    /// Finest level (1 to 12; level `L` has `2^L` cells along the longest side).
    #[serde(default = "default_max_level")]
    pub max_level: u8,
    /// Coarsest level that is always subdivided (default 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_level: Option<u8>,
    /// Largest interpolation error a cell may keep, world units (default: 1% of a finest
    /// cell).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<f32>,
    /// The field to store.
    pub of: Box<Node>,
}

/// Any [`Field`] held in memory (a shape built in code): kind `field` in paths and stats.
#[derive(Clone)]
pub struct FieldNode {
    /// A name for messages.
    pub name: String,
    /// The field.
    pub field: Arc<dyn Field>,
    /// Identifies the field's content for change detection (the caller's choice; by default
    /// the field's address, so two different fields never compare equal).
    pub hash: u64,
}

impl std::fmt::Debug for FieldNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "FieldNode({:?})", self.name)
    }
}

impl PartialEq for FieldNode {
    fn eq(&self, other: &Self) -> bool {
        self.hash == other.hash && Arc::ptr_eq(&self.field, &other.field)
    }
}

fn is_default<T: Default + PartialEq>(v: &T) -> bool {
    *v == T::default()
}

/// A node of the shape tree: a source (primitive, mesh, cloud, volume, included scene,
/// octree, in-memory field) or an operation on other nodes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Node {
    /// A ball: `{"sphere": {"radius": r, "center": [x, y, z]}}`.
    Sphere(SphereNode),
    /// An axis-aligned box: `{"box": {"half": [a, b, c], "center": [..]}}`.
    Box(BoxNode),
    /// A box with rounded edges.
    RoundedBox(RoundedBoxNode),
    /// A torus around the z axis.
    Torus(TorusNode),
    /// A capsule (segment plus radius).
    Capsule(CapsuleNode),
    /// A capped cylinder.
    Cylinder(CylinderNode),
    /// A capped cone frustum.
    Cone(ConeNode),
    /// A half-space (unbounded).
    Plane(PlaneNode),
    /// An axis-aligned ellipsoid.
    Ellipsoid(EllipsoidNode),
    /// A triangle mesh as an exact signed distance.
    Mesh(MeshNode),
    /// A point cloud as a partition-of-unity distance field.
    Points(PointsNode),
    /// A sampled volume.
    Volume(VolumeNode),
    /// A child stored in a hashed octree.
    Octree(OctreeNode),
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
    /// Linear interpolation `(1 − t)·f_from + t·f_to` (Sigg 2006, Sec. 6.4.3).
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
    /// Any field held in memory (cannot be written to a scene file).
    #[serde(skip)]
    #[schemars(skip)]
    Field(FieldNode),
}

/// Parameters of the smooth operations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Smooth {
    /// Blend radius, ≥ 0 (0 is the sharp operation).
    pub radius: f32,
    /// The operands (at least one; for the difference, the first minus the others).
    pub of: Vec<Node>,
}

/// Parameters of `transform`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TransformSpec {
    /// Translation (applied last).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub translate: Option<[f32; 3]>,
    /// Rotation about an axis through the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotate: Option<Rotation>,
    /// Uniform scale factor, > 0 (applied first).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f32>,
    /// The shape.
    pub of: Box<Node>,
}

/// A rotation by `degrees` about `axis` (right-handed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Rotation {
    /// Axis, nonzero.
    pub axis: [f32; 3],
    /// Angle in degrees.
    pub degrees: f32,
}

impl From<PrimitiveNode> for Node {
    fn from(p: PrimitiveNode) -> Self {
        match p {
            PrimitiveNode::Sphere(n) => Node::Sphere(n),
            PrimitiveNode::Box(n) => Node::Box(n),
            PrimitiveNode::RoundedBox(n) => Node::RoundedBox(n),
            PrimitiveNode::Torus(n) => Node::Torus(n),
            PrimitiveNode::Capsule(n) => Node::Capsule(n),
            PrimitiveNode::Cylinder(n) => Node::Cylinder(n),
            PrimitiveNode::Cone(n) => Node::Cone(n),
            PrimitiveNode::Plane(n) => Node::Plane(n),
            PrimitiveNode::Ellipsoid(n) => Node::Ellipsoid(n),
        }
    }
}

impl Node {
    /// The node's kind as written in a scene file, e.g. `"smooth_union"` (`"field"` for an
    /// in-memory field).
    pub fn kind(&self) -> &'static str {
        match self {
            Node::Sphere(_) => "sphere",
            Node::Box(_) => "box",
            Node::RoundedBox(_) => "rounded_box",
            Node::Torus(_) => "torus",
            Node::Capsule(_) => "capsule",
            Node::Cylinder(_) => "cylinder",
            Node::Cone(_) => "cone",
            Node::Plane(_) => "plane",
            Node::Ellipsoid(_) => "ellipsoid",
            Node::Mesh(_) => "mesh",
            Node::Points(_) => "points",
            Node::Volume(_) => "volume",
            Node::Octree(_) => "octree",
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
            Node::Field(_) => "field",
        }
    }

    /// Every node kind a scene file can hold, in documentation order.
    pub const KINDS: &'static [&'static str] = &[
        "sphere",
        "box",
        "rounded_box",
        "torus",
        "capsule",
        "cylinder",
        "cone",
        "plane",
        "ellipsoid",
        "mesh",
        "points",
        "volume",
        "octree",
        "include",
        "union",
        "intersection",
        "difference",
        "complement",
        "smooth_union",
        "smooth_intersection",
        "smooth_difference",
        "offset",
        "shell",
        "morph",
        "transform",
    ];

    /// The primitive this node is, if it is one.
    pub fn primitive(&self) -> Option<PrimitiveNode> {
        Some(match self {
            Node::Sphere(n) => PrimitiveNode::Sphere(*n),
            Node::Box(n) => PrimitiveNode::Box(*n),
            Node::RoundedBox(n) => PrimitiveNode::RoundedBox(*n),
            Node::Torus(n) => PrimitiveNode::Torus(*n),
            Node::Capsule(n) => PrimitiveNode::Capsule(*n),
            Node::Cylinder(n) => PrimitiveNode::Cylinder(*n),
            Node::Cone(n) => PrimitiveNode::Cone(*n),
            Node::Plane(n) => PrimitiveNode::Plane(*n),
            Node::Ellipsoid(n) => PrimitiveNode::Ellipsoid(*n),
            _ => return None,
        })
    }

    /// The direct children of an operation (empty for sources).
    pub fn children(&self) -> Vec<&Node> {
        match self {
            Node::Union(v) | Node::Intersection(v) | Node::Difference(v) => v.iter().collect(),
            Node::SmoothUnion(s) | Node::SmoothIntersection(s) | Node::SmoothDifference(s) => {
                s.of.iter().collect()
            }
            Node::Complement(n) => vec![n],
            Node::Offset { of, .. } | Node::Shell { of, .. } => vec![of],
            Node::Morph { from, to, .. } => vec![from, to],
            Node::Transform(t) => vec![&t.of],
            Node::Octree(o) => vec![&o.of],
            _ => Vec::new(),
        }
    }

    /// The first node below (or at) this one holding data in memory, with its path from
    /// `parent` (as in errors: `shape.union[1].mesh`).
    pub fn first_in_memory(&self, parent: &str) -> Option<String> {
        let path = format!("{parent}.{}", self.kind());
        let here = match self {
            Node::Mesh(m) => m.data.is_some(),
            Node::Points(p) => p.data.is_some(),
            Node::Volume(v) => v.data.is_some(),
            Node::Field(_) => true,
            _ => false,
        };
        if here {
            return Some(path);
        }
        let list = matches!(
            self,
            Node::Union(_) | Node::Intersection(_) | Node::Difference(_)
        );
        let smooth = matches!(
            self,
            Node::SmoothUnion(_) | Node::SmoothIntersection(_) | Node::SmoothDifference(_)
        );
        self.children().iter().enumerate().find_map(|(i, c)| {
            let p = if list {
                format!("{path}[{i}]")
            } else if smooth {
                format!("{path}.of[{i}]")
            } else {
                match self {
                    Node::Morph { .. } => format!("{path}.{}", ["from", "to"][i]),
                    Node::Complement(_) => path.clone(),
                    _ => format!("{path}.of"),
                }
            };
            c.first_in_memory(&p)
        })
    }
}

/// Constructors for building trees in code (the same trees a scene file describes).
///
/// ```
/// use isokit_scene::Node;
/// let part = Node::difference(vec![
///     Node::sphere(1.0, [0.0; 3]),
///     Node::cuboid([0.5; 3], [1.0, 0.0, 0.0]),
/// ]);
/// assert_eq!(part.kind(), "difference");
/// ```
impl Node {
    /// `{"sphere": {"radius": r, "center": c}}`.
    pub fn sphere(radius: f32, center: [f32; 3]) -> Self {
        Node::Sphere(SphereNode { center, radius })
    }

    /// `{"box": {"half": h, "center": c}}`.
    pub fn cuboid(half: [f32; 3], center: [f32; 3]) -> Self {
        Node::Box(BoxNode { center, half })
    }

    /// `{"rounded_box": {"half": h, "radius": r, "center": c}}`.
    pub fn rounded_box(half: [f32; 3], radius: f32, center: [f32; 3]) -> Self {
        Node::RoundedBox(RoundedBoxNode {
            center,
            half,
            radius,
        })
    }

    /// `{"torus": {"major": R, "minor": r, "center": c}}`.
    pub fn torus(major: f32, minor: f32, center: [f32; 3]) -> Self {
        Node::Torus(TorusNode {
            center,
            major,
            minor,
        })
    }

    /// `{"capsule": {"a": a, "b": b, "radius": r}}`.
    pub fn capsule(a: [f32; 3], b: [f32; 3], radius: f32) -> Self {
        Node::Capsule(CapsuleNode { a, b, radius })
    }

    /// `{"cylinder": {"a": a, "b": b, "radius": r}}`.
    pub fn cylinder(a: [f32; 3], b: [f32; 3], radius: f32) -> Self {
        Node::Cylinder(CylinderNode { a, b, radius })
    }

    /// `{"cone": {"a": a, "b": b, "ra": ra, "rb": rb}}`.
    pub fn cone(a: [f32; 3], b: [f32; 3], ra: f32, rb: f32) -> Self {
        Node::Cone(ConeNode { a, b, ra, rb })
    }

    /// `{"plane": {"normal": n, "offset": d}}`.
    pub fn plane(normal: [f32; 3], offset: f32) -> Self {
        Node::Plane(PlaneNode { normal, offset })
    }

    /// `{"ellipsoid": {"radii": r, "center": c}}`.
    pub fn ellipsoid(radii: [f32; 3], center: [f32; 3]) -> Self {
        Node::Ellipsoid(EllipsoidNode { center, radii })
    }

    /// `{"mesh": {"path": p, "sign": "auto"}}`.
    pub fn mesh(path: impl Into<String>) -> Self {
        Node::Mesh(MeshNode {
            path: Some(path.into()),
            ..Default::default()
        })
    }

    /// A mesh held in memory, signed by `sign`.
    pub fn mesh_data(mesh: TriMesh, sign: SignMode) -> Self {
        Node::Mesh(MeshNode {
            path: None,
            sign,
            method: BandMethod::Kdtree,
            data: Some(Memory::mesh(mesh)),
        })
    }

    /// `{"points": {"path": p}}`.
    pub fn points(path: impl Into<String>) -> Self {
        Node::Points(PointsNode {
            path: Some(path.into()),
            ..Default::default()
        })
    }

    /// A cloud held in memory (its normals used when it has them, else estimated).
    pub fn points_data(cloud: PointCloud) -> Self {
        Node::Points(PointsNode {
            data: Some(Memory::cloud(cloud)),
            ..Default::default()
        })
    }

    /// `{"volume": {"path": p}}`.
    pub fn volume(path: impl Into<String>) -> Self {
        Node::Volume(VolumeNode {
            path: Some(path.into()),
            ..Default::default()
        })
    }

    /// A dense grid held in memory, surface at `iso`, inside below it.
    pub fn grid(grid: Grid, iso: f32) -> Self {
        Node::Volume(VolumeNode {
            iso,
            data: Some(Memory::volume(VolumeData::Grid(grid))),
            ..Default::default()
        })
    }

    /// A brick grid held in memory (e.g. a sampled band), surface at 0, inside below.
    pub fn bricks(bricks: BrickGrid) -> Self {
        Node::Volume(VolumeNode {
            data: Some(Memory::volume(VolumeData::Bricks(bricks))),
            ..Default::default()
        })
    }

    /// Any field held in memory, called `name` in messages.
    pub fn field(name: impl Into<String>, field: Arc<dyn Field>) -> Self {
        let hash = Arc::as_ptr(&field) as *const () as usize as u64;
        Node::Field(FieldNode {
            name: name.into(),
            field,
            hash,
        })
    }

    /// `{"include": {"path": p}}`.
    pub fn include(path: impl Into<String>) -> Self {
        Node::Include { path: path.into() }
    }

    /// `{"octree": {"max_level": l, "of": self}}`.
    pub fn octree(self, max_level: u8) -> Self {
        Node::Octree(OctreeNode {
            max_level,
            min_level: None,
            error: None,
            of: Box::new(self),
        })
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

    /// `{"complement": self}`.
    pub fn complement(self) -> Self {
        Node::Complement(Box::new(self))
    }

    /// `{"smooth_union": {"radius": k, "of": [...]}}`.
    pub fn smooth_union(radius: f32, of: Vec<Node>) -> Self {
        Node::SmoothUnion(Smooth { radius, of })
    }

    /// `{"smooth_intersection": {"radius": k, "of": [...]}}`.
    pub fn smooth_intersection(radius: f32, of: Vec<Node>) -> Self {
        Node::SmoothIntersection(Smooth { radius, of })
    }

    /// `{"smooth_difference": {"radius": k, "of": [...]}}`.
    pub fn smooth_difference(radius: f32, of: Vec<Node>) -> Self {
        Node::SmoothDifference(Smooth { radius, of })
    }

    /// `{"offset": {"by": r, "of": self}}`.
    pub fn offset(self, by: f32) -> Self {
        Node::Offset {
            by,
            of: Box::new(self),
        }
    }

    /// `{"shell": {"thickness": t, "of": self}}`.
    pub fn shell(self, thickness: f32) -> Self {
        Node::Shell {
            thickness,
            of: Box::new(self),
        }
    }

    /// `{"morph": {"t": t, "from": self, "to": to}}`.
    pub fn morph(self, to: Node, t: f32) -> Self {
        Node::Morph {
            t,
            from: Box::new(self),
            to: Box::new(to),
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

    /// `{"transform": {"scale": s, "of": self}}`.
    pub fn scaled(self, s: f32) -> Self {
        Node::Transform(TransformSpec {
            translate: None,
            rotate: None,
            scale: Some(s),
            of: Box::new(self),
        })
    }

    /// `{"transform": {"scale": s, "rotate": r, "translate": t, "of": self}}` with the parts
    /// given (applied in that order: scale, rotation, translation); `self` unchanged when
    /// none is.
    pub fn transformed(
        self,
        scale: Option<f32>,
        rotate: Option<Rotation>,
        translate: Option<[f32; 3]>,
    ) -> Self {
        if scale.is_none() && rotate.is_none() && translate.is_none() {
            return self;
        }
        Node::Transform(TransformSpec {
            translate,
            rotate,
            scale,
            of: Box::new(self),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transformed_wraps_only_when_a_part_is_given() {
        let s = Node::sphere(1.0, [0.0; 3]);
        assert_eq!(s.clone().transformed(None, None, None), s);
        let r = Rotation {
            axis: [0.0, 0.0, 1.0],
            degrees: 90.0,
        };
        let t = s
            .clone()
            .transformed(Some(2.0), Some(r.clone()), Some([1.0, 0.0, 0.0]));
        assert_eq!(
            t,
            Node::Transform(TransformSpec {
                translate: Some([1.0, 0.0, 0.0]),
                rotate: Some(r),
                scale: Some(2.0),
                of: Box::new(s),
            })
        );
    }
}
