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
//! Besides the 3D primitives and sources there are 2D profiles ([`crate::profiles`]:
//! `circle`, `rectangle`, `polygon`, …) that combine with the same CSG nodes and become
//! solids by `extrude` and `revolve`; transforms with non-uniform `scale`, `mirror`, `orient`
//! and `affine`; repetition (`repeat`, `array`, `circular_array`); deformations (`twist`,
//! `bend`, `taper`, `elongate`); chamfer and stairs blends; `round` and `onion` (the
//! `offset` and `shell` of fogleman's `sdf` and libfive under their names there). Every node
//! states whether it is exact or a bound (see the README's table); none returns more than
//! the distance to its surface.
//!
//! Any node may carry `"color": [r, g, b]` (linear RGB in `[0, 1]`) beside its kind:
//! `{"sphere": {"radius": 1}, "color": [0.8, 0.1, 0.1]}`. Colours do not change the field;
//! the renderer colours each hit by the innermost coloured node whose surface passes there
//! ([`Node::Colored`]).
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
use crate::profiles::{
    CircleNode, EllipseNode, HexagonNode, PolygonNode, ProfileNode, RectangleNode,
    RoundedRectangleNode, SlotNode,
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

/// Where a cloud's field gets its sign far from the surface (see `isokit_points`, "The sign
/// far from the surface").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CloudSign {
    /// The fast winding number of the oriented cloud (Barill et al. 2018) where the nearest
    /// samples disagree on the side, the closest sample's side elsewhere.
    #[default]
    Winding,
    /// The side of the closest sample's tangent plane (Sigg 2006, Sec. 4.3.5): wrong beside
    /// sharp edges and concave pockets, many spacings away.
    Nearest,
    /// The winding number wherever the far field counts.
    WindingEverywhere,
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
    /// Neighbours per evaluation (default: chosen with the damping from the cloud's noise
    /// estimate, `isokit_points::noise`: 16, or 64 with damping 1 on a noisy cloud).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k: Option<usize>,
    /// Where the normals come from.
    #[serde(default)]
    pub normals: Normals,
    /// Where the field gets its sign far from the surface (default `winding`).
    #[serde(default, skip_serializing_if = "is_default")]
    pub sign: CloudSign,
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

/// A node of the shape tree: a source (primitive, profile, mesh, cloud, volume, included
/// scene, octree, in-memory field) or an operation on other nodes.
///
/// Scene files hold a node as a table with one key, its kind, and optionally `color`
/// (read into [`Node::Colored`]): serde's externally tagged form with that one extra key
/// (see the `Deserialize` impl).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(remote = "Self", rename_all = "snake_case", deny_unknown_fields)]
#[schemars(rename = "Node")]
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
    /// Scale (uniform, or one factor per axis), then rotate, then translate.
    Transform(TransformSpec),
    /// A disk in the xy-plane (a 2D profile).
    Circle(CircleNode),
    /// An axis-aligned rectangle (a 2D profile).
    Rectangle(RectangleNode),
    /// A rectangle with rounded corners (a 2D profile).
    RoundedRectangle(RoundedRectangleNode),
    /// A polygon from its vertices (a 2D profile).
    Polygon(PolygonNode),
    /// An axis-aligned ellipse (a 2D profile).
    Ellipse(EllipseNode),
    /// A slot, the points within a radius of a segment (a 2D profile).
    Slot(SlotNode),
    /// A regular hexagon (a 2D profile).
    Hexagon(HexagonNode),
    /// A profile extruded along z from `−height/2` to `height/2`.
    Extrude(ExtrudeNode),
    /// A profile revolved about the z axis, its x the distance from the axis less `offset`.
    Revolve(RevolveNode),
    /// A reflection in the plane `normal · p = offset`.
    Mirror(MirrorNode),
    /// A rotation taking the shape's z axis to `axis`.
    Orient(OrientNode),
    /// A general invertible affine map `world = M · [local; 1]`.
    Affine(AffineNode),
    /// Infinite repetition with a period per axis.
    Repeat(RepeatNode),
    /// A finite array of copies, `count` per axis `spacing` apart.
    Array(ArrayNode),
    /// `count` copies rotated by `360°/count` about an axis through the origin.
    CircularArray(CircularArrayNode),
    /// A twist about an axis: the cross-section at height `z` turned by `rate · z` degrees.
    Twist(TwistNode),
    /// A bend of the x axis into an arc, `rate` degrees per unit length.
    Bend(BendNode),
    /// A taper along an axis: cross-sections scaled by `1 + rate · z`.
    Taper(TaperNode),
    /// The shape cut at the coordinate planes and its parts moved apart by `by`.
    Elongate(ElongateNode),
    /// Rounding by `radius`: the same as `offset` by it (fogleman's `sdf` and IQ's `round`).
    Round(RoundNode),
    /// A shell of `thickness` around the surface: the same as `shell` (IQ's `onion`).
    Onion(OnionNode),
    /// Union with a 45° chamfer of size `radius` where the operands meet (hg_sdf).
    ChamferUnion(Smooth),
    /// Intersection with a chamfer of size `radius` (hg_sdf).
    ChamferIntersection(Smooth),
    /// Difference (first minus the others) with a chamfer of size `radius` (hg_sdf).
    ChamferDifference(Smooth),
    /// Union with `steps` stairs over the size `radius` where the operands meet (hg_sdf).
    StairsUnion(Stairs),
    /// Intersection with stairs (hg_sdf).
    StairsIntersection(Stairs),
    /// Difference (first minus the others) with stairs (hg_sdf).
    StairsDifference(Stairs),
    /// A node with a colour: written in scene files as the key `"color"` beside the node's
    /// kind, never as a kind of its own.
    #[serde(skip)]
    #[schemars(skip)]
    Colored(ColoredNode),
    /// Any field held in memory (cannot be written to a scene file).
    #[serde(skip)]
    #[schemars(skip)]
    Field(FieldNode),
}

/// A coloured node ([`Node::Colored`]): the colour of the surface it owns.
#[derive(Clone, Debug, PartialEq)]
pub struct ColoredNode {
    /// Linear RGB, each in `[0, 1]`.
    pub color: [f32; 3],
    /// The node.
    pub of: Box<Node>,
}

/// Parameters of `extrude`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExtrudeNode {
    /// Height, > 0: the solid spans `z` from `−height/2` to `height/2`.
    pub height: f32,
    /// Radius rounding the edges where the wall meets the caps, `0 ≤ round ≤ height/2`
    /// (default 0, sharp).
    #[serde(default, skip_serializing_if = "is_default")]
    pub round: f32,
    /// The 2D profile.
    pub of: Box<Node>,
}

/// Parameters of `revolve`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RevolveNode {
    /// Added to the profile's x: the profile's `x = 0` ends at radius `offset` (default 0).
    #[serde(default, skip_serializing_if = "is_default")]
    pub offset: f32,
    /// The 2D profile: its x is the distance from the z axis (less `offset`), its y is z.
    /// A profile that closes on the axis must reach across it (to `x < −offset`): one with
    /// an edge lying on the axis is refused (the axis would be a seam of zeros).
    pub of: Box<Node>,
}

fn z_axis() -> [f32; 3] {
    [0.0, 0.0, 1.0]
}

fn is_z_axis(a: &[f32; 3]) -> bool {
    *a == z_axis()
}

/// Parameters of `mirror`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MirrorNode {
    /// The plane's normal, nonzero.
    pub normal: [f32; 3],
    /// The plane's offset along the normalized normal (default 0: through the origin).
    #[serde(default, skip_serializing_if = "is_default")]
    pub offset: f32,
    /// The shape.
    pub of: Box<Node>,
}

/// Parameters of `orient`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OrientNode {
    /// Where the shape's z axis points afterwards, nonzero.
    pub axis: [f32; 3],
    /// The shape.
    pub of: Box<Node>,
}

/// Parameters of `affine`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AffineNode {
    /// The map's three rows `[a, b, c, t]`: `world_i = a·x + b·y + c·z + t` (invertible,
    /// stretching no direction more than 1e6 times another).
    pub matrix: [[f32; 4]; 3],
    /// The shape.
    pub of: Box<Node>,
}

/// Parameters of `repeat`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RepeatNode {
    /// The period along each axis, ≥ 0 (0: not repeated along that axis).
    pub period: [f32; 3],
    /// The shape (bounded along the repeated axes).
    pub of: Box<Node>,
}

/// Parameters of `array`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ArrayNode {
    /// Copies along each axis, each ≥ 1.
    pub count: [u32; 3],
    /// Distance between copies along each axis (copy `i` moved by `i · spacing`).
    pub spacing: [f32; 3],
    /// The shape.
    pub of: Box<Node>,
}

/// Parameters of `circular_array`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CircularArrayNode {
    /// Copies, 1 to 65536 (copy `j` turned by `j · 360°/count`).
    pub count: u32,
    /// The axis through the origin (default `[0, 0, 1]`).
    #[serde(default = "z_axis", skip_serializing_if = "is_z_axis")]
    pub axis: [f32; 3],
    /// The shape.
    pub of: Box<Node>,
}

/// Parameters of `twist`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TwistNode {
    /// Degrees of turn per unit length along the axis (right-handed).
    pub rate: f32,
    /// The axis through the origin (default `[0, 0, 1]`).
    #[serde(default = "z_axis", skip_serializing_if = "is_z_axis")]
    pub axis: [f32; 3],
    /// The shape (bounded).
    pub of: Box<Node>,
}

/// Parameters of `bend`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BendNode {
    /// Degrees of turn per unit length along x: the x axis becomes an arc of radius
    /// `180 / (π · rate)` curving towards +y (−y for a negative rate).
    pub rate: f32,
    /// The shape (bounded, bent by less than 180° in all, on the near side of the centre).
    pub of: Box<Node>,
}

/// Parameters of `taper`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TaperNode {
    /// Change of scale per unit length: the cross-section at height `z` is scaled by
    /// `1 + rate · z` about the axis.
    pub rate: f32,
    /// The axis through the origin (default `[0, 0, 1]`).
    #[serde(default = "z_axis", skip_serializing_if = "is_z_axis")]
    pub axis: [f32; 3],
    /// The shape (bounded, `1 + rate · z > 0` over its height).
    pub of: Box<Node>,
}

/// Parameters of `elongate`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ElongateNode {
    /// How much longer the shape grows along each axis, ≥ 0.
    pub by: [f32; 3],
    /// The shape.
    pub of: Box<Node>,
}

/// Parameters of `round`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RoundNode {
    /// The rounding radius (the surface moves out by it): `f − radius`.
    pub radius: f32,
    /// The shape.
    pub of: Box<Node>,
}

/// Parameters of `onion`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OnionNode {
    /// Wall thickness, > 0: `|f| − thickness/2`.
    pub thickness: f32,
    /// The shape.
    pub of: Box<Node>,
}

/// Parameters of the stairs blends.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Stairs {
    /// Size of the stepped fillet, ≥ 0.
    pub radius: f32,
    /// Number of steps, ≥ 1 (default 4).
    #[serde(default = "four")]
    pub steps: u32,
    /// The operands (at least one; for the difference, the first minus the others).
    pub of: Vec<Node>,
}

fn four() -> u32 {
    4
}

/// `"scale"` of a transform: one factor, or one per axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Scale {
    /// The same factor along every axis (exact).
    Uniform(f32),
    /// A factor per axis `[sx, sy, sz]` (a distance bound: `min(s) · f(p / s)`).
    Axes([f32; 3]),
}

impl Scale {
    /// The three factors.
    pub fn factors(self) -> [f32; 3] {
        match self {
            Scale::Uniform(s) => [s; 3],
            Scale::Axes(a) => a,
        }
    }
}

impl<'de> Deserialize<'de> for Node {
    /// A table with the node's kind as its one key, plus `color` optionally.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(NodeVisitor)
    }
}

impl Serialize for Node {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::Error;
        match self {
            Node::Colored(c) => {
                let mut m = match serde_json::to_value(&*c.of).map_err(S::Error::custom)? {
                    serde_json::Value::Object(m) => m,
                    _ => return Err(S::Error::custom("a coloured node must be a table")),
                };
                m.insert("color".to_owned(), serde_json::json!(c.color));
                m.serialize(s)
            }
            _ => Node::serialize(self, s),
        }
    }
}

/// Adds the optional `"color"` key to every node form of a generated scene-file schema
/// (the colour is read beside the kind, not as a kind: see [`Node::Colored`]) and its
/// definition, `$defs.Color`.
pub(crate) fn add_color_to_schema(schema: &mut serde_json::Value) {
    let Some(defs) = schema.get_mut("$defs").and_then(|d| d.as_object_mut()) else {
        return;
    };
    defs.insert(
        "Color".to_owned(),
        serde_json::json!({
            "description": "A node's colour, linear RGB, each component in [0, 1]: the \
                renderer colours the surface the node owns.",
            "type": "array",
            "items": {"type": "number", "minimum": 0.0, "maximum": 1.0},
            "minItems": 3,
            "maxItems": 3,
        }),
    );
    if let Some(forms) = defs
        .get_mut("Node")
        .and_then(|n| n.get_mut("oneOf"))
        .and_then(|o| o.as_array_mut())
    {
        for form in forms {
            if let Some(props) = form.get_mut("properties").and_then(|p| p.as_object_mut()) {
                props.insert(
                    "color".to_owned(),
                    serde_json::json!({"$ref": "#/$defs/Color"}),
                );
            }
        }
    }
}

/// Reads a node: each key of the table is `color` or the kind (exactly one), whose value
/// is read by the derived enum logic through [`KindEntry`].
struct NodeVisitor;

impl<'de> serde::de::Visitor<'de> for NodeVisitor {
    type Value = Node;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a node: a table whose one key is the node's kind (and optionally `color`)")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Node, A::Error> {
        use serde::de::Error;
        let mut node: Option<(String, Node)> = None;
        let mut color: Option<[f32; 3]> = None;
        while let Some(key) = map.next_key::<String>()? {
            if key == "color" {
                if color.is_some() {
                    return Err(A::Error::duplicate_field("color"));
                }
                color = Some(map.next_value()?);
                continue;
            }
            if let Some((first, _)) = &node {
                return Err(A::Error::custom(format!(
                    "a node has exactly one kind, but `{key}` follows `{first}` (wrap several \
                     shapes in a `union`)"
                )));
            }
            let n = Node::deserialize(KindEntry {
                key: key.clone(),
                map: &mut map,
            })?;
            node = Some((key, n));
        }
        let Some((_, node)) = node else {
            return Err(A::Error::custom(
                "a node needs its kind as a key (e.g. `{\"sphere\": {}}`)",
            ));
        };
        Ok(match color {
            Some(color) => node.with_color(color),
            None => node,
        })
    }
}

/// The kind key of a node table and the map it came from, presented to the derived enum
/// deserializer as an externally tagged enum.
struct KindEntry<'a, A> {
    key: String,
    map: &'a mut A,
}

impl<'de, A: serde::de::MapAccess<'de>> serde::Deserializer<'de> for KindEntry<'_, A> {
    type Error = A::Error;

    fn deserialize_any<V: serde::de::Visitor<'de>>(self, _v: V) -> Result<V::Value, A::Error> {
        Err(serde::de::Error::custom("a node is read as an enum"))
    }

    fn deserialize_enum<V: serde::de::Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, A::Error> {
        visitor.visit_enum(self)
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map struct identifier
        ignored_any
    }
}

impl<'de, A: serde::de::MapAccess<'de>> serde::de::EnumAccess<'de> for KindEntry<'_, A> {
    type Error = A::Error;
    type Variant = Self;

    fn variant_seed<V: serde::de::DeserializeSeed<'de>>(
        self,
        seed: V,
    ) -> Result<(V::Value, Self), A::Error> {
        use serde::de::IntoDeserializer;
        let v = seed.deserialize(self.key.clone().into_deserializer())?;
        Ok((v, self))
    }
}

impl<'de, A: serde::de::MapAccess<'de>> serde::de::VariantAccess<'de> for KindEntry<'_, A> {
    type Error = A::Error;

    fn unit_variant(self) -> Result<(), A::Error> {
        self.map.next_value::<serde::de::IgnoredAny>().map(|_| ())
    }

    fn newtype_variant_seed<T: serde::de::DeserializeSeed<'de>>(
        self,
        seed: T,
    ) -> Result<T::Value, A::Error> {
        self.map.next_value_seed(seed)
    }

    fn tuple_variant<V: serde::de::Visitor<'de>>(
        self,
        len: usize,
        visitor: V,
    ) -> Result<V::Value, A::Error> {
        self.map.next_value_seed(Shaped::Tuple(len, visitor))
    }

    fn struct_variant<V: serde::de::Visitor<'de>>(
        self,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, A::Error> {
        self.map.next_value_seed(Shaped::Struct(fields, visitor))
    }
}

/// A visitor handed to the value's deserializer as a tuple or a struct.
enum Shaped<V> {
    Tuple(usize, V),
    Struct(&'static [&'static str], V),
}

impl<'de, V: serde::de::Visitor<'de>> serde::de::DeserializeSeed<'de> for Shaped<V> {
    type Value = V::Value;

    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<V::Value, D::Error> {
        match self {
            Shaped::Tuple(len, v) => d.deserialize_tuple(len, v),
            Shaped::Struct(fields, v) => d.deserialize_struct("", fields, v),
        }
    }
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
    /// Scale factor, > 0 (applied first): one number (uniform, exact) or one per axis
    /// `[sx, sy, sz]` (a distance bound, `min(s) · f(p / s)`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<Scale>,
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
            Node::Circle(_) => "circle",
            Node::Rectangle(_) => "rectangle",
            Node::RoundedRectangle(_) => "rounded_rectangle",
            Node::Polygon(_) => "polygon",
            Node::Ellipse(_) => "ellipse",
            Node::Slot(_) => "slot",
            Node::Hexagon(_) => "hexagon",
            Node::Extrude(_) => "extrude",
            Node::Revolve(_) => "revolve",
            Node::Mirror(_) => "mirror",
            Node::Orient(_) => "orient",
            Node::Affine(_) => "affine",
            Node::Repeat(_) => "repeat",
            Node::Array(_) => "array",
            Node::CircularArray(_) => "circular_array",
            Node::Twist(_) => "twist",
            Node::Bend(_) => "bend",
            Node::Taper(_) => "taper",
            Node::Elongate(_) => "elongate",
            Node::Round(_) => "round",
            Node::Onion(_) => "onion",
            Node::ChamferUnion(_) => "chamfer_union",
            Node::ChamferIntersection(_) => "chamfer_intersection",
            Node::ChamferDifference(_) => "chamfer_difference",
            Node::StairsUnion(_) => "stairs_union",
            Node::StairsIntersection(_) => "stairs_intersection",
            Node::StairsDifference(_) => "stairs_difference",
            Node::Colored(c) => c.of.kind(),
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
        "circle",
        "rectangle",
        "rounded_rectangle",
        "polygon",
        "ellipse",
        "slot",
        "hexagon",
        "extrude",
        "revolve",
        "mirror",
        "orient",
        "affine",
        "repeat",
        "array",
        "circular_array",
        "twist",
        "bend",
        "taper",
        "elongate",
        "round",
        "onion",
        "chamfer_union",
        "chamfer_intersection",
        "chamfer_difference",
        "stairs_union",
        "stairs_intersection",
        "stairs_difference",
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

    /// The 2D profile this node is, if it is one.
    pub fn profile(&self) -> Option<ProfileNode> {
        Some(match self {
            Node::Circle(n) => ProfileNode::Circle(*n),
            Node::Rectangle(n) => ProfileNode::Rectangle(*n),
            Node::RoundedRectangle(n) => ProfileNode::RoundedRectangle(*n),
            Node::Polygon(n) => ProfileNode::Polygon(n.clone()),
            Node::Ellipse(n) => ProfileNode::Ellipse(*n),
            Node::Slot(n) => ProfileNode::Slot(*n),
            Node::Hexagon(n) => ProfileNode::Hexagon(*n),
            _ => return None,
        })
    }

    /// The node under its colour (itself when it has none) and the colour.
    pub fn uncolored(&self) -> (&Node, Option<[f32; 3]>) {
        match self {
            Node::Colored(c) => (&c.of, Some(c.color)),
            n => (n, None),
        }
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
            Node::Extrude(n) => vec![&n.of],
            Node::Revolve(n) => vec![&n.of],
            Node::Mirror(n) => vec![&n.of],
            Node::Orient(n) => vec![&n.of],
            Node::Affine(n) => vec![&n.of],
            Node::Repeat(n) => vec![&n.of],
            Node::Array(n) => vec![&n.of],
            Node::CircularArray(n) => vec![&n.of],
            Node::Twist(n) => vec![&n.of],
            Node::Bend(n) => vec![&n.of],
            Node::Taper(n) => vec![&n.of],
            Node::Elongate(n) => vec![&n.of],
            Node::Round(n) => vec![&n.of],
            Node::Onion(n) => vec![&n.of],
            Node::ChamferUnion(s) | Node::ChamferIntersection(s) | Node::ChamferDifference(s) => {
                s.of.iter().collect()
            }
            Node::StairsUnion(s) | Node::StairsIntersection(s) | Node::StairsDifference(s) => {
                s.of.iter().collect()
            }
            Node::Colored(c) => c.of.children(),
            _ => Vec::new(),
        }
    }

    /// The first node below (or at) this one holding data in memory, with its path from
    /// `parent` (as in errors: `shape.union[1].mesh`).
    pub fn first_in_memory(&self, parent: &str) -> Option<String> {
        if let Node::Colored(c) = self {
            return c.of.first_in_memory(parent);
        }
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
            Node::SmoothUnion(_)
                | Node::SmoothIntersection(_)
                | Node::SmoothDifference(_)
                | Node::ChamferUnion(_)
                | Node::ChamferIntersection(_)
                | Node::ChamferDifference(_)
                | Node::StairsUnion(_)
                | Node::StairsIntersection(_)
                | Node::StairsDifference(_)
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
            scale: Some(Scale::Uniform(s)),
            of: Box::new(self),
        })
    }

    /// `{"transform": {"scale": [sx, sy, sz], "of": self}}`: a factor per axis.
    pub fn scaled_axes(self, s: [f32; 3]) -> Self {
        Node::Transform(TransformSpec {
            translate: None,
            rotate: None,
            scale: Some(Scale::Axes(s)),
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
            scale: scale.map(Scale::Uniform),
            of: Box::new(self),
        })
    }
}

/// Constructors of the modeling vocabulary: 2D profiles, profile operations, transforms,
/// repetition, deformations, blends and colour (the same trees the scene-file forms hold).
///
/// ```
/// use isokit_scene::Node;
/// // A flange: a disk extruded, four bolt holes by a circular array, coloured.
/// let hole = Node::circle(0.1, [0.6, 0.0]).extrude(1.0);
/// let flange = Node::difference(vec![
///     Node::circle(1.0, [0.0, 0.0]).extrude(0.2),
///     hole.circular_array(4, [0.0, 0.0, 1.0]),
/// ])
/// .with_color([0.7, 0.7, 0.75]);
/// assert_eq!(flange.kind(), "difference");
/// ```
impl Node {
    /// `{"circle": {"radius": r, "center": [x, y]}}`.
    pub fn circle(radius: f32, center: [f32; 2]) -> Self {
        Node::Circle(CircleNode { radius, center })
    }

    /// `{"rectangle": {"half": [a, b], "center": [x, y]}}`.
    pub fn rectangle(half: [f32; 2], center: [f32; 2]) -> Self {
        Node::Rectangle(RectangleNode { half, center })
    }

    /// `{"rounded_rectangle": {"half": [a, b], "radius": r, "center": [x, y]}}`.
    pub fn rounded_rectangle(half: [f32; 2], radius: f32, center: [f32; 2]) -> Self {
        Node::RoundedRectangle(RoundedRectangleNode {
            half,
            radius,
            center,
        })
    }

    /// `{"polygon": {"points": [[x, y], …]}}`.
    pub fn polygon(points: Vec<[f32; 2]>) -> Self {
        Node::Polygon(PolygonNode { points })
    }

    /// `{"ellipse": {"radii": [a, b], "center": [x, y]}}`.
    pub fn ellipse(radii: [f32; 2], center: [f32; 2]) -> Self {
        Node::Ellipse(EllipseNode { radii, center })
    }

    /// `{"slot": {"a": [x, y], "b": [x, y], "radius": r}}`.
    pub fn slot(a: [f32; 2], b: [f32; 2], radius: f32) -> Self {
        Node::Slot(SlotNode { a, b, radius })
    }

    /// `{"hexagon": {"radius": r, "center": [x, y]}}` (`r` the corner distance).
    pub fn hexagon(radius: f32, center: [f32; 2]) -> Self {
        Node::Hexagon(HexagonNode { radius, center })
    }

    /// `{"extrude": {"height": h, "of": self}}`: this profile from `z = −h/2` to `h/2`.
    pub fn extrude(self, height: f32) -> Self {
        self.extrude_rounded(height, 0.0)
    }

    /// `{"extrude": {"height": h, "round": r, "of": self}}`: with the cap edges rounded.
    pub fn extrude_rounded(self, height: f32, round: f32) -> Self {
        Node::Extrude(ExtrudeNode {
            height,
            round,
            of: Box::new(self),
        })
    }

    /// `{"revolve": {"offset": d, "of": self}}`: this profile revolved about z.
    pub fn revolve(self, offset: f32) -> Self {
        Node::Revolve(RevolveNode {
            offset,
            of: Box::new(self),
        })
    }

    /// `{"mirror": {"normal": n, "offset": d, "of": self}}`: reflected in `n · p = d`.
    pub fn mirrored(self, normal: [f32; 3], offset: f32) -> Self {
        Node::Mirror(MirrorNode {
            normal,
            offset,
            of: Box::new(self),
        })
    }

    /// `{"orient": {"axis": a, "of": self}}`: turned so that its z axis points along `a`.
    pub fn oriented(self, axis: [f32; 3]) -> Self {
        Node::Orient(OrientNode {
            axis,
            of: Box::new(self),
        })
    }

    /// `{"affine": {"matrix": rows, "of": self}}`: `world_i = rows[i] · [x, y, z, 1]`.
    pub fn affine(self, matrix: [[f32; 4]; 3]) -> Self {
        Node::Affine(AffineNode {
            matrix,
            of: Box::new(self),
        })
    }

    /// `{"repeat": {"period": p, "of": self}}`: repeated forever (0 leaves an axis alone).
    pub fn repeated(self, period: [f32; 3]) -> Self {
        Node::Repeat(RepeatNode {
            period,
            of: Box::new(self),
        })
    }

    /// `{"array": {"count": n, "spacing": s, "of": self}}`.
    pub fn array(self, count: [u32; 3], spacing: [f32; 3]) -> Self {
        Node::Array(ArrayNode {
            count,
            spacing,
            of: Box::new(self),
        })
    }

    /// `{"circular_array": {"count": n, "axis": a, "of": self}}`.
    pub fn circular_array(self, count: u32, axis: [f32; 3]) -> Self {
        Node::CircularArray(CircularArrayNode {
            count,
            axis,
            of: Box::new(self),
        })
    }

    /// `{"twist": {"rate": degrees per unit length, "axis": a, "of": self}}`.
    pub fn twisted(self, rate: f32, axis: [f32; 3]) -> Self {
        Node::Twist(TwistNode {
            rate,
            axis,
            of: Box::new(self),
        })
    }

    /// `{"bend": {"rate": degrees per unit length, "of": self}}`.
    pub fn bent(self, rate: f32) -> Self {
        Node::Bend(BendNode {
            rate,
            of: Box::new(self),
        })
    }

    /// `{"taper": {"rate": t, "axis": a, "of": self}}`: cross-sections scaled by `1 + t·z`.
    pub fn tapered(self, rate: f32, axis: [f32; 3]) -> Self {
        Node::Taper(TaperNode {
            rate,
            axis,
            of: Box::new(self),
        })
    }

    /// `{"elongate": {"by": [x, y, z], "of": self}}`.
    pub fn elongated(self, by: [f32; 3]) -> Self {
        Node::Elongate(ElongateNode {
            by,
            of: Box::new(self),
        })
    }

    /// `{"round": {"radius": r, "of": self}}` (the same field as `offset` by `r`).
    pub fn round(self, radius: f32) -> Self {
        Node::Round(RoundNode {
            radius,
            of: Box::new(self),
        })
    }

    /// `{"onion": {"thickness": t, "of": self}}` (the same field as `shell`).
    pub fn onion(self, thickness: f32) -> Self {
        Node::Onion(OnionNode {
            thickness,
            of: Box::new(self),
        })
    }

    /// `{"chamfer_union": {"radius": r, "of": [...]}}`.
    pub fn chamfer_union(radius: f32, of: Vec<Node>) -> Self {
        Node::ChamferUnion(Smooth { radius, of })
    }

    /// `{"chamfer_intersection": {"radius": r, "of": [...]}}`.
    pub fn chamfer_intersection(radius: f32, of: Vec<Node>) -> Self {
        Node::ChamferIntersection(Smooth { radius, of })
    }

    /// `{"chamfer_difference": {"radius": r, "of": [...]}}`.
    pub fn chamfer_difference(radius: f32, of: Vec<Node>) -> Self {
        Node::ChamferDifference(Smooth { radius, of })
    }

    /// `{"stairs_union": {"radius": r, "steps": n, "of": [...]}}`.
    pub fn stairs_union(radius: f32, steps: u32, of: Vec<Node>) -> Self {
        Node::StairsUnion(Stairs { radius, steps, of })
    }

    /// `{"stairs_intersection": {"radius": r, "steps": n, "of": [...]}}`.
    pub fn stairs_intersection(radius: f32, steps: u32, of: Vec<Node>) -> Self {
        Node::StairsIntersection(Stairs { radius, steps, of })
    }

    /// `{"stairs_difference": {"radius": r, "steps": n, "of": [...]}}`.
    pub fn stairs_difference(radius: f32, steps: u32, of: Vec<Node>) -> Self {
        Node::StairsDifference(Stairs { radius, steps, of })
    }

    /// The node with `"color": [r, g, b]` (replacing a colour it has).
    pub fn with_color(self, color: [f32; 3]) -> Self {
        let of = match self {
            Node::Colored(c) => c.of,
            n => Box::new(n),
        };
        Node::Colored(ColoredNode { color, of })
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
                scale: Some(Scale::Uniform(2.0)),
                of: Box::new(s),
            })
        );
    }
}
