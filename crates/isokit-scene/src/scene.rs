//! A compiled scene: the shape tree turned into the level-set crate's field combinators with
//! its sources loaded, the list of files it depends on, a content hash per subtree, and lazy
//! sampling to a band.

use crate::file::{SceneFile, SceneFormat, parse};
use crate::node::{
    BandMethod, CloudSign, Filter as FilterNode, Inside, MeshNode, Node, Normals, OctreeNode,
    PointsNode, Scale, SignMode, Smooth, TransformSpec, VolumeData, VolumeNode,
};
use crate::source::{
    BrickField, Counted, Counter, MeshField, PrismBackend, VolumeField, volume_lipschitz,
};
use crate::{SceneError, SourceCache};
use glam::{DQuat, DVec3, Vec3};
use isokit_field::filter::{Filter, SampledField};
use isokit_field::transform::Affine;
use isokit_field::transform::Transformed;
use isokit_field::{Aabb, DistanceBox, Field, TriMesh};
use isokit_kdtree::mesh::{MeshOptions, MeshSdf};
use isokit_levelset::csg::{Blend, Complement, DifferenceN, IntersectionN, Offset, Shell};
use isokit_levelset::csg::{SmoothKind, SmoothN, UnionN};
use isokit_levelset::morph::LinearMorph;
use isokit_points::noise::estimate_noise;
use isokit_points::{NormalOptions, NormalSource, PointSdf, PointSdfOptions, SignRule};
use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The deepest tree a scene may build (across includes): evaluation recurses once per
/// level.
pub const MAX_DEPTH: usize = 256;
/// The most nodes a scene may build (across includes; an include used twice counts twice).
pub const MAX_NODES: usize = 100_000;

/// A source of the scene (a leaf that is queried), with its query counter.
#[derive(Clone)]
pub struct SourceInfo {
    /// The node's path in the scene, e.g. `shape.difference[1].mesh`.
    pub node: String,
    /// The node's kind (`sphere`, `mesh`, …).
    pub kind: &'static str,
    /// The number of triangles, for meshes.
    pub triangles: Option<usize>,
    pub(crate) count: Arc<Counter>,
    /// Values read back from the source's lattice memo, for memoized sources.
    pub(crate) memo_hits: Option<Arc<Counter>>,
}

impl std::fmt::Debug for SourceInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SourceInfo")
            .field("node", &self.node)
            .field("kind", &self.kind)
            .field("queries", &self.queries())
            .finish()
    }
}

impl SourceInfo {
    /// How many times the source was evaluated since the last reset.
    pub fn queries(&self) -> u64 {
        self.count.get()
    }

    /// How many values were read back from the source's lattice memo since the last reset
    /// (see [`crate::SourceCache::memoizing`]); 0 for sources without one.
    pub fn memo_hits(&self) -> u64 {
        self.memo_hits.as_ref().map_or(0, |c| c.get())
    }
}

/// A node's content hash and its bounds, as [`Scene::hashes`] lists them.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeHash {
    /// The node's path, e.g. `shape.union[2].sphere`.
    pub node: String,
    /// A hash of the subtree: its kinds and parameters, and for file sources the file's
    /// path, size and modification time (so saving a referenced file changes it).
    pub hash: u64,
    /// The subtree's bounding box.
    pub bounds: Aabb,
    /// Depth in the tree (the root is 0); with the pre-order of [`Scene::hashes`] it gives
    /// each node's children.
    pub depth: usize,
    /// The subtree's distance box ([`Field::distance_box`]): where its value can be below
    /// the distance to that box less a slack. In the coordinates of the node's frame.
    pub distance_box: Option<isokit_field::DistanceBox>,
    /// For unions, intersections, differences and their blends (whose operands share the
    /// node's frame and enter only through clamped values): how much the node raises the
    /// cap its operands are evaluated with, and a hash of its own parameters.
    pub pass: Option<Pass>,
}

/// How a combinator evaluates its operands ([`NodeHash::pass`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pass {
    /// The operands' cap less the node's (0 for the sharp operations).
    pub growth: f32,
    /// A hash of the node's kind and parameters, operands excluded.
    pub own: u64,
    /// Whether an operand added or removed leaves the node's value unchanged wherever that
    /// operand's value lies above the cap: true for unions and differences (a missing
    /// operand of a minimum, or a missing subtrahend, acts as one at +∞), false for
    /// intersections (a missing operand of a maximum acts as one at −∞, and an added far
    /// operand raises the value everywhere).
    pub far_when_absent: bool,
}

/// The frame of a node below transforms: world = translation + scale · rotation(local).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Frame {
    pub(crate) rotation: DQuat,
    pub(crate) translation: DVec3,
    pub(crate) scale: f64,
}

impl Frame {
    const WORLD: Frame = Frame {
        rotation: DQuat::IDENTITY,
        translation: DVec3::ZERO,
        scale: 1.0,
    };

    /// This frame followed (inside) by a transform of rotation `r`, translation `t`,
    /// scale `s`.
    fn then(self, r: DQuat, t: DVec3, s: f64) -> Frame {
        Frame {
            rotation: self.rotation * r,
            translation: self.translation + self.scale * (self.rotation * t),
            scale: self.scale * s,
        }
    }

    /// A world point in this frame.
    pub(crate) fn to_local(self, p: DVec3) -> DVec3 {
        self.rotation.inverse() * (p - self.translation) / self.scale
    }
}

/// A mesh source with the prism method, and the frame it sits in.
pub(crate) struct PrismMesh {
    pub(crate) field: Arc<MeshField>,
    pub(crate) frame: Frame,
    pub(crate) node: String,
}

/// A compiled scene: the shape tree with its sources loaded, ready to evaluate. It is a
/// [`Field`] (evaluated in full, nothing clamped; [`Field::value_clamped`] prunes).
pub struct Scene {
    file: SceneFile,
    name: String,
    root: Arc<dyn Field>,
    sources: Vec<SourceInfo>,
    pub(crate) prism_meshes: Vec<PrismMesh>,
    /// Memoized sources, and the cache's tables they use ([`crate::memo`]).
    pub(crate) memos: Vec<crate::memo::MemoUse>,
    pub(crate) memo_store: Arc<std::sync::Mutex<crate::memo::MemoStore>>,
    lipschitz: f32,
    dependencies: Vec<PathBuf>,
    hashes: Vec<NodeHash>,
    /// Each node's compiled field, in the order of `hashes` (the sampling after an edit
    /// evaluates the subtrees that changed).
    subtrees: Vec<Option<Arc<dyn Field>>>,
    colors: Vec<ColorEntry>,
    parts: Vec<ColoredPart>,
}

/// A coloured node of a scene (`"color"` in the file), as [`Scene::parts`] lists them.
#[derive(Clone, Debug, PartialEq)]
pub struct ColoredPart {
    /// The node's path, e.g. `shape.union[1].extrude`.
    pub node: String,
    /// Its colour, linear RGB.
    pub color: [f32; 3],
    /// The index of the nearest coloured node above it, if any.
    pub parent: Option<usize>,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("name", &self.name)
            .field("sources", &self.sources.len())
            .field("bounds", &self.root.bounds())
            .finish()
    }
}

impl Scene {
    /// Reads and compiles a scene file (`.json` or `.toml`); meshes, clouds, volumes and
    /// included scenes are loaded relative to its folder.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        Self::load_with(path, &mut SourceCache::default())
    }

    /// [`Scene::load`] reusing the built sources in `cache` whose files did not change
    /// (kd-trees, point-cloud solves, volumes), and adding the new ones to it.
    pub fn load_with(path: &Path, cache: &mut SourceCache) -> Result<Self, SceneError> {
        let name = isokit_io::shown_path(path);
        let (file, _) = read_scene_file(path, &name, "")?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut stack = vec![canonical(path)];
        let mut deps = vec![path.to_path_buf()];
        Self::build(file, &name, dir, &mut stack, &mut deps, cache)
    }

    /// Compiles scene text; `name` names it in errors and `dir` resolves relative paths.
    pub fn from_text(
        text: &str,
        format: SceneFormat,
        name: &str,
        dir: &Path,
    ) -> Result<Self, SceneError> {
        let file = parse(text, format, name)?;
        Self::build(
            file,
            name,
            dir,
            &mut Vec::new(),
            &mut Vec::new(),
            &mut SourceCache::default(),
        )
    }

    /// Compiles a scene built in code (see [`Node`]'s constructors); relative paths are
    /// resolved in `dir`.
    pub fn from_file(file: SceneFile, dir: &Path) -> Result<Self, SceneError> {
        Self::from_file_with(file, dir, &mut SourceCache::default())
    }

    /// [`Scene::from_file`] reusing and filling `cache`.
    pub fn from_file_with(
        file: SceneFile,
        dir: &Path,
        cache: &mut SourceCache,
    ) -> Result<Self, SceneError> {
        Self::build(
            file,
            "<scene>",
            dir,
            &mut Vec::new(),
            &mut Vec::new(),
            cache,
        )
    }

    /// Compiles a shape built in code with default settings (paths relative to the current
    /// folder).
    pub fn from_node(shape: Node) -> Result<Self, SceneError> {
        Self::from_file(SceneFile::new(shape), Path::new("."))
    }

    fn build(
        file: SceneFile,
        name: &str,
        dir: &Path,
        stack: &mut Vec<PathBuf>,
        deps: &mut Vec<PathBuf>,
        cache: &mut SourceCache,
    ) -> Result<Self, SceneError> {
        let mut b = Builder {
            file: name.to_owned(),
            dir: dir.to_path_buf(),
            stack,
            deps,
            cache,
            sources: Vec::new(),
            prism_meshes: Vec::new(),
            memos: Vec::new(),
            hashes: Vec::new(),
            subtrees: Vec::new(),
            frame: Frame::WORLD,
            warped: None,
            colors: Vec::new(),
            color_stack: Vec::new(),
            depth: 0,
            nodes: 0,
            pass: None,
        };
        let root = b.compile(&file.shape, "shape")?;
        let memo_store = b.cache.memos.clone();
        if b.cache.memoize {
            let used: Vec<_> = b.memos.iter().map(|m| m.key).collect();
            memo_store
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .retain(&used);
        }
        let (sources, prism_meshes, hashes) = (b.sources, b.prism_meshes, b.hashes);
        let subtrees = b.subtrees;
        let memos = b.memos;
        let colors = b.colors;
        let parts = colors
            .iter()
            .map(|c| ColoredPart {
                node: c.node.clone(),
                color: c.color,
                parent: c.parent,
            })
            .collect();
        let dependencies = b.deps.clone();
        let lipschitz = root.field.lipschitz().max(1.0);
        if !lipschitz.is_finite() {
            return Err(SceneError::new(
                name,
                "shape",
                "the field's slope is not finite (a volume with enormous values or a tiny spacing?)",
            ));
        }
        Ok(Self {
            file,
            name: name.to_owned(),
            root: root.field,
            sources,
            prism_meshes,
            memos,
            memo_store,
            lipschitz,
            dependencies,
            hashes,
            subtrees,
            colors,
            parts,
        })
    }

    /// The coloured nodes, in pre-order (the object ids of [`Scene::part_at`] index them).
    pub fn parts(&self) -> &[ColoredPart] {
        &self.parts
    }

    /// The coloured node that owns the surface point `p`: among the top-level coloured
    /// nodes, the one whose value at `p` is smallest in magnitude and within `tolerance`
    /// (the surface passes there), then the same among its coloured descendants, down to the
    /// innermost; `None` where no coloured node's surface passes within `tolerance` (the
    /// default colour). Values are evaluated clamped to `2 · tolerance`, so far subtrees are
    /// pruned by their boxes.
    pub fn part_at(&self, p: Vec3, tolerance: f32) -> Option<usize> {
        let mut current: Option<usize> = None;
        loop {
            let mut best: Option<(f32, usize)> = None;
            for (i, e) in self.colors.iter().enumerate() {
                if e.parent != current {
                    continue;
                }
                let v = isokit_field::value_clamped(&*e.field, p, 2.0 * tolerance).abs();
                if v <= tolerance && best.is_none_or(|b| v < b.0) {
                    best = Some((v, i));
                }
            }
            match best {
                Some((_, i)) => current = Some(i),
                None => return current,
            }
        }
    }

    /// The colour of each point (see [`Scene::part_at`]): the owning part's colour, or
    /// `default` where none owns it.
    pub fn colors_at(&self, points: &[Vec3], tolerance: f32, default: [f32; 3]) -> Vec<[f32; 3]> {
        use rayon::prelude::*;
        points
            .par_iter()
            .map(|&p| {
                self.part_at(p, tolerance)
                    .map_or(default, |i| self.parts[i].color)
            })
            .collect()
    }

    /// The scene as read (shape tree, camera, lights, shading, sampling).
    pub fn settings(&self) -> &SceneFile {
        &self.file
    }

    /// The name used in messages (the file's path, or `<scene>`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The sources (leaves) with their query counters.
    pub fn sources(&self) -> &[SourceInfo] {
        &self.sources
    }

    /// Sets every source's query counter to zero.
    pub fn reset_counts(&self) {
        self.sources.iter().for_each(|s| {
            s.count.reset();
            if let Some(h) = &s.memo_hits {
                h.reset();
            }
        });
    }

    /// Every file the scene read: the scene file itself, included scenes, meshes, clouds,
    /// volumes (a live viewer watches them).
    pub fn dependencies(&self) -> &[PathBuf] {
        &self.dependencies
    }

    /// Every node's content hash and bounds, root first (see [`NodeHash`]): two scenes
    /// whose nodes at the same path have the same hash compute the same field there.
    pub fn hashes(&self) -> &[NodeHash] {
        &self.hashes
    }

    /// Each node's compiled field, in the order of [`Scene::hashes`].
    pub(crate) fn subtree_fields(&self) -> &[Option<Arc<dyn Field>>] {
        &self.subtrees
    }

    /// The root's content hash.
    pub fn hash(&self) -> u64 {
        self.hashes.first().map_or(0, |h| h.hash)
    }

    /// The compiled tree as a field.
    pub fn field(&self) -> &dyn Field {
        &*self.root
    }

    /// The value at `p`, exact where `|f(p)| < cap`; elsewhere `±cap` with the right sign.
    /// Bounding boxes prune what cannot matter.
    pub fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        isokit_field::value_clamped(&*self.root, p, cap)
    }

    /// The sampling domain: `sampling.bounds` when given, else the shape's bounds.
    pub fn domain(&self) -> Aabb {
        match self.file.sampling.bounds {
            Some([a, b]) => Aabb::from_corners(Vec3::from(a), Vec3::from(b)),
            None => self.root.bounds(),
        }
    }

    /// The number of triangles of the scene's meshes.
    pub fn triangles(&self) -> usize {
        self.sources.iter().filter_map(|s| s.triangles).sum()
    }
}

impl Field for Scene {
    fn value(&self, p: Vec3) -> f32 {
        self.root.value(p)
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        self.root.values(points, out)
    }
    fn bounds(&self) -> Aabb {
        self.root.bounds()
    }
    /// Computed per node: min, max, the smooth blends, offsets, shells and similarity
    /// transforms keep the largest of their operands' bounds; a morph has
    /// `|1 − t|·L_from + |t|·L_to`; a volume's is measured from its samples.
    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }
    fn is_exact(&self) -> bool {
        self.root.is_exact()
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.root.fd_step(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.root.gradient(p)
    }
    fn hessian(&self, p: Vec3) -> glam::Mat3 {
        self.root.hessian(p)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        self.root.distance_box()
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.root.lower_bound(p)
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        self.root.value_clamped(p, cap)
    }
}

/// An error and its causes, joined by `: ` (an I/O error's operating-system reason is its
/// source).
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cause = c.source();
    }
    s
}

fn canonical(p: &Path) -> PathBuf {
    p.canonicalize().unwrap_or_else(|_| p.to_path_buf())
}

/// Reads and parses a scene file; `node` names the include node in errors (empty for the
/// top-level file).
fn read_scene_file(path: &Path, name: &str, node: &str) -> Result<(SceneFile, String), SceneError> {
    let format = SceneFormat::from_path(path).ok_or_else(|| {
        if node.is_empty() {
            SceneError::new(name, "", "unknown scene format (expected .json or .toml)")
        } else {
            SceneError::new(
                name,
                node,
                format!("{name}: unknown scene format (expected .json or .toml)"),
            )
        }
    })?;
    let text = std::fs::read_to_string(path).map_err(|e| {
        if node.is_empty() {
            SceneError::new(name, "", format!("cannot read: {e}"))
        } else {
            SceneError::new(name, node, format!("cannot read {name}: {e}"))
        }
    })?;
    Ok((parse(&text, format, name)?, text))
}

/// A file's stamp for content hashes: its canonical path, size and modification time.
pub(crate) fn file_stamp(path: &Path) -> u64 {
    let mut h = DefaultHasher::new();
    canonical(path).hash(&mut h);
    if let Ok(m) = std::fs::metadata(path) {
        m.len().hash(&mut h);
        if let Ok(t) = m.modified() {
            t.hash(&mut h);
        }
    }
    h.finish()
}

/// Whether a compiled node is a 2D profile (a field independent of z) or a solid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Dim {
    /// A profile: a 2D signed distance in the xy-plane.
    Two,
    /// A solid.
    Three,
}

/// A compiled node: its field, content hash and dimension.
pub(crate) struct Compiled {
    pub(crate) field: Arc<dyn Field>,
    pub(crate) hash: u64,
    pub(crate) dim: Dim,
}

impl Compiled {
    /// A solid's compiled node.
    pub(crate) fn solid(field: Box<dyn Field>, hash: u64) -> Self {
        Self {
            field: Arc::from(field),
            hash,
            dim: Dim::Three,
        }
    }
}

/// A coloured node of the scene: its path, colour, field (shared with the tree) and the
/// nearest coloured node above it.
#[derive(Clone)]
pub(crate) struct ColorEntry {
    pub(crate) node: String,
    pub(crate) color: [f32; 3],
    pub(crate) field: Arc<dyn Field>,
    pub(crate) parent: Option<usize>,
}

/// Compiles nodes into fields, loading sources.
pub(crate) struct Builder<'a> {
    /// The file being compiled (its name in errors) and its folder.
    file: String,
    dir: PathBuf,
    stack: &'a mut Vec<PathBuf>,
    deps: &'a mut Vec<PathBuf>,
    cache: &'a mut SourceCache,
    sources: Vec<SourceInfo>,
    prism_meshes: Vec<PrismMesh>,
    memos: Vec<crate::memo::MemoUse>,
    hashes: Vec<NodeHash>,
    subtrees: Vec<Option<Arc<dyn Field>>>,
    frame: Frame,
    /// The first node above that is not a similarity (a deformation, a repetition, an
    /// affine map): prism bands need the mesh's frame to be one.
    pub(crate) warped: Option<String>,
    pub(crate) colors: Vec<ColorEntry>,
    pub(crate) color_stack: Vec<usize>,
    depth: usize,
    nodes: usize,
    /// Set by a combinator as it finishes compiling, taken by [`Builder::compile`].
    pass: Option<Pass>,
}

pub(crate) fn hash_of(parts: impl FnOnce(&mut DefaultHasher)) -> u64 {
    let mut h = DefaultHasher::new();
    parts(&mut h);
    h.finish()
}

pub(crate) fn f32_bits(h: &mut DefaultHasher, v: &[f32]) {
    v.iter().for_each(|x| x.to_bits().hash(h));
}

impl Builder<'_> {
    pub(crate) fn err(&self, node: &str, m: impl Into<String>) -> SceneError {
        SceneError::new(&self.file, node, m)
    }

    pub(crate) fn counted<F: Field + 'static>(
        &mut self,
        node: String,
        kind: &'static str,
        triangles: Option<usize>,
        field: F,
    ) -> Box<dyn Field> {
        let count = Arc::new(Counter::new());
        self.sources.push(SourceInfo {
            node,
            kind,
            triangles,
            count: count.clone(),
            memo_hits: None,
        });
        Box::new(Counted { field, count })
    }

    /// `field` (the source just counted, with content hash `hash`) memoized on the
    /// lattices it is sampled on, when the cache asks for it and its frame allows.
    fn memoized(&mut self, field: Box<dyn Field>, hash: u64) -> Box<dyn Field> {
        if !self.cache.memoize || self.warped.is_some() {
            return field;
        }
        let f = self.frame;
        let Some(key) = crate::memo::key_of(hash, f.rotation, f.translation, f.scale) else {
            return field;
        };
        let (m, slots) = crate::memo::Memoized::new(field);
        if let Some(s) = self.sources.last_mut() {
            s.memo_hits = Some(slots.hits.clone());
        }
        self.memos.push(crate::memo::MemoUse {
            slots,
            key,
            translation: f.translation,
            scale: f.scale,
        });
        Box::new(m)
    }

    /// The file a node names, relative to the scene file, recorded as a dependency (also
    /// when it is missing: a live viewer waits for it to appear).
    fn resolve(&mut self, file: &str, node: &str) -> Result<PathBuf, SceneError> {
        if file.is_empty() {
            return Err(self.err(node, "path is empty"));
        }
        let p = self.dir.join(file);
        self.deps.push(p.clone());
        if p.is_dir() {
            return Err(self.err(
                node,
                format!("{} is a directory, not a file", isokit_io::shown_path(&p)),
            ));
        }
        if !p.is_file() {
            return Err(self.err(node, format!("no such file: {}", isokit_io::shown_path(&p))));
        }
        Ok(p)
    }

    pub(crate) fn children(
        &mut self,
        of: &[Node],
        path: &str,
        min: usize,
    ) -> Result<Vec<Compiled>, SceneError> {
        if of.len() < min {
            let what = if min == 1 { "shape" } else { "shapes" };
            return Err(self.err(
                path,
                format!("needs at least {min} {what}, got {}", of.len()),
            ));
        }
        of.iter()
            .enumerate()
            .map(|(i, n)| self.compile(n, &format!("{path}[{i}]")))
            .collect()
    }

    pub(crate) fn compile(&mut self, node: &Node, parent: &str) -> Result<Compiled, SceneError> {
        let (node, color) = node.uncolored();
        let path = format!("{parent}.{}", node.kind());
        self.nodes += 1;
        if self.nodes > MAX_NODES {
            return Err(self.err(
                &path,
                format!("the scene has more than {MAX_NODES} nodes (includes count each time they are used)"),
            ));
        }
        if self.depth >= MAX_DEPTH {
            return Err(self.err(
                &path,
                format!("the tree is nested more than {MAX_DEPTH} levels deep"),
            ));
        }
        self.depth += 1;
        // Reserve the node's slot so the list stays in pre-order (root first).
        let slot = self.hashes.len();
        self.hashes.push(NodeHash {
            node: path.clone(),
            hash: 0,
            bounds: Aabb::EMPTY,
            depth: self.depth - 1,
            distance_box: None,
            pass: None,
        });
        self.subtrees.push(None);
        // A coloured node: reserve its entry so that the entries stay in pre-order too.
        let entry = color.map(|c| {
            let parent = self.color_stack.last().copied();
            self.colors.push(ColorEntry {
                node: path.clone(),
                color: c,
                field: Arc::new(isokit_field::primitives::Plane::new(Vec3::Z, 0.0).expect("z")),
                parent,
            });
            let i = self.colors.len() - 1;
            self.color_stack.push(i);
            i
        });
        let out = if let Some(c) =
            color.filter(|c| !c.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)))
        {
            Err(self.err(
                &format!("{path}.color"),
                format!("{c:?}: each component must be in [0, 1] (linear RGB)"),
            ))
        } else {
            self.compile_node(node, path)
        };
        if entry.is_some() {
            self.color_stack.pop();
        }
        self.depth -= 1;
        match out {
            Ok(mut c) => {
                if let (Some(i), Some(rgb)) = (entry, color) {
                    // The coloured subtree is shared by the tree and the colour lookup.
                    self.colors[i].field = c.field.clone();
                    c.hash = hash_of(|h| {
                        "color".hash(h);
                        f32_bits(h, &rgb);
                        c.hash.hash(h);
                    });
                }
                let h = &mut self.hashes[slot];
                h.hash = c.hash;
                h.bounds = c.field.bounds();
                h.distance_box = c.field.distance_box();
                h.pass = self.pass.take();
                self.subtrees[slot] = Some(c.field.clone());
                Ok(c)
            }
            Err(e) => Err(e),
        }
    }

    /// The one dimension of a list of children, or an error naming the mix.
    pub(crate) fn same_dim(&self, kids: &[Compiled], path: &str) -> Result<Dim, SceneError> {
        let first = kids.first().map_or(Dim::Three, |k| k.dim);
        if kids.iter().any(|k| k.dim != first) {
            return Err(self.err(
                path,
                "mixes 2D profiles and 3D shapes: extrude or revolve the profiles first",
            ));
        }
        Ok(first)
    }

    fn compile_node(&mut self, node: &Node, path: String) -> Result<Compiled, SceneError> {
        if let Some(p) = node.primitive() {
            let prim = p.build().map_err(|e| self.err(&path, e.to_string()))?;
            let hash = hash_of(|h| {
                node.kind().hash(h);
                for (name, v) in p.params() {
                    name.hash(h);
                    match v {
                        crate::primitives::Param::Number(x) => f32_bits(h, &[x]),
                        crate::primitives::Param::Vector(x) => f32_bits(h, &x),
                    }
                }
            });
            let field = self.counted(path, node.kind(), None, prim);
            return Ok(Compiled::solid(field, hash));
        }
        if let Some(c) = self.compile_vocabulary(node, &path)? {
            return Ok(c);
        }
        let finite = |x: f32, name: &str| -> Result<f32, SceneError> {
            if x.is_finite() {
                Ok(x)
            } else {
                Err(SceneError::new(
                    &self.file,
                    &format!("{path}.{name}"),
                    format!("{x} must be finite"),
                ))
            }
        };
        let combine = |kind: &str, params: &[f32], kids: &[Compiled]| {
            hash_of(|h| {
                kind.hash(h);
                f32_bits(h, params);
                kids.iter().for_each(|k| k.hash.hash(h));
            })
        };
        let file = self.file.clone();
        let csg = |e: isokit_levelset::csg::CsgError| SceneError::new(&file, &path, e.to_string());
        Ok(match node {
            Node::Mesh(m) => self.mesh(m, path)?,
            Node::Points(p) => self.points(p, path)?,
            Node::Volume(v) => self.volume(v, path)?,
            Node::Octree(o) => self.octree(o, path)?,
            Node::Field(f) => {
                let hash = hash_of(|h| {
                    "field".hash(h);
                    f.hash.hash(h);
                });
                let field = self.counted(path, "field", None, f.field.clone());
                Compiled::solid(field, hash)
            }
            Node::Include { path: file } => self.include(file, path)?,
            Node::Union(of) => {
                let kids = self.children(of, &path, 1)?;
                let dim = self.same_dim(&kids, &path)?;
                let hash = combine("union", &[], &kids);
                self.pass = Some(Pass {
                    growth: 0.0,
                    own: hash_of(|h| "union".hash(h)),
                    far_when_absent: true,
                });
                let fields = kids.into_iter().map(|k| k.field).collect();
                Compiled {
                    field: Arc::new(UnionN::new(fields).map_err(csg)?),
                    hash,
                    dim,
                }
            }
            Node::Intersection(of) => {
                let kids = self.children(of, &path, 1)?;
                let dim = self.same_dim(&kids, &path)?;
                let hash = combine("intersection", &[], &kids);
                self.pass = Some(Pass {
                    growth: 0.0,
                    own: hash_of(|h| "intersection".hash(h)),
                    far_when_absent: false,
                });
                let fields = kids.into_iter().map(|k| k.field).collect();
                Compiled {
                    field: Arc::new(IntersectionN::new(fields).map_err(csg)?),
                    hash,
                    dim,
                }
            }
            Node::Difference(of) => {
                let kids = self.children(of, &path, 2)?;
                let dim = self.same_dim(&kids, &path)?;
                let hash = combine("difference", &[], &kids);
                self.pass = Some(Pass {
                    growth: 0.0,
                    own: hash_of(|h| "difference".hash(h)),
                    far_when_absent: true,
                });
                let mut fields: Vec<Arc<dyn Field>> = kids.into_iter().map(|k| k.field).collect();
                let base = fields.remove(0);
                Compiled {
                    field: Arc::new(DifferenceN::new(base, fields)),
                    hash,
                    dim,
                }
            }
            Node::Complement(of) => {
                let c = self.compile(of, &path)?;
                Compiled {
                    hash: combine("complement", &[], std::slice::from_ref(&c)),
                    dim: c.dim,
                    field: Arc::new(Complement::new(c.field)),
                }
            }
            Node::SmoothUnion(s) => self.smooth(s, &path, SmoothKind::Union)?,
            Node::SmoothIntersection(s) => self.smooth(s, &path, SmoothKind::Intersection)?,
            Node::SmoothDifference(s) => self.smooth(s, &path, SmoothKind::Difference)?,
            Node::Offset { by, of } => self.offset(*by, of, &path, "by")?,
            Node::Shell { thickness, of } => self.shell(*thickness, of, &path)?,
            Node::Morph { t, from, to } => {
                let t = finite(*t, "t")?;
                let a = self.compile(from, &format!("{path}.from"))?;
                let b = self.compile(to, &format!("{path}.to"))?;
                let hash = hash_of(|h| {
                    "morph".hash(h);
                    t.to_bits().hash(h);
                    a.hash.hash(h);
                    b.hash.hash(h);
                });
                if a.dim != b.dim {
                    return Err(self.err(
                        &path,
                        "mixes 2D profiles and 3D shapes: extrude or revolve the profiles first",
                    ));
                }
                let dim = a.dim;
                let field = LinearMorph::new(a.field, b.field, t)
                    .map_err(|e| self.err(&path, e.to_string()))?;
                Compiled {
                    field: Arc::new(field),
                    hash,
                    dim,
                }
            }
            Node::Transform(t) => self.transform(t, &path)?,
            _ => unreachable!("primitives are compiled above"),
        })
    }

    fn smooth(&mut self, s: &Smooth, path: &str, kind: SmoothKind) -> Result<Compiled, SceneError> {
        self.blended(kind, Blend::Round, s.radius, &s.of, path)
    }

    /// A blended n-ary operation (round, chamfer or stairs) of `of` with size `radius`.
    pub(crate) fn blended(
        &mut self,
        kind: SmoothKind,
        blend: Blend,
        radius: f32,
        of: &[Node],
        path: &str,
    ) -> Result<Compiled, SceneError> {
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(self.err(
                &format!("{path}.radius"),
                format!("{radius} must be finite and non-negative"),
            ));
        }
        if blend == Blend::Stairs(0) {
            return Err(self.err(&format!("{path}.steps"), "must be at least 1"));
        }
        let min = if kind == SmoothKind::Difference { 2 } else { 1 };
        let kids = self.children(of, &format!("{path}.of"), min)?;
        let dim = self.same_dim(&kids, path)?;
        let hash = hash_of(|h| {
            format!("{kind:?}").hash(h);
            if blend != Blend::Round {
                format!("{blend:?}").hash(h);
            }
            radius.to_bits().hash(h);
            kids.iter().for_each(|k| k.hash.hash(h));
        });
        let fields = kids.into_iter().map(|k| k.field).collect();
        let field = SmoothN::with_blend(kind, blend, radius, fields)
            .map_err(|e| self.err(path, e.to_string()))?;
        self.pass = Some(Pass {
            growth: field.child_cap(0.0),
            far_when_absent: kind != SmoothKind::Intersection,
            own: hash_of(|h| {
                format!("{kind:?} {blend:?}").hash(h);
                radius.to_bits().hash(h);
            }),
        });
        Ok(Compiled {
            field: Arc::new(field),
            hash,
            dim,
        })
    }

    /// `offset` (and `round`): `f − by`; `name` is the parameter's key.
    pub(crate) fn offset(
        &mut self,
        by: f32,
        of: &Node,
        path: &str,
        name: &str,
    ) -> Result<Compiled, SceneError> {
        if !by.is_finite() {
            return Err(self.err(&format!("{path}.{name}"), format!("{by} must be finite")));
        }
        let c = self.compile(of, &format!("{path}.of"))?;
        let hash = hash_of(|h| {
            "offset".hash(h);
            f32_bits(h, &[by]);
            c.hash.hash(h);
        });
        let field = Offset::new(c.field, by).map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled {
            field: Arc::new(field),
            hash,
            dim: c.dim,
        })
    }

    /// `shell` (and `onion`): `|f| − thickness/2`.
    pub(crate) fn shell(
        &mut self,
        thickness: f32,
        of: &Node,
        path: &str,
    ) -> Result<Compiled, SceneError> {
        if !(thickness.is_finite() && thickness > 0.0) {
            return Err(self.err(
                &format!("{path}.thickness"),
                format!("{thickness} must be finite and > 0"),
            ));
        }
        let c = self.compile(of, &format!("{path}.of"))?;
        let hash = hash_of(|h| {
            "shell".hash(h);
            f32_bits(h, &[thickness]);
            c.hash.hash(h);
        });
        let field = Shell::new(c.field, thickness).map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled {
            field: Arc::new(field),
            hash,
            dim: c.dim,
        })
    }

    /// Compiles `of` below a node that is not a similarity (prism bands refuse it).
    pub(crate) fn compile_warped(&mut self, of: &Node, path: &str) -> Result<Compiled, SceneError> {
        let saved = self.warped.clone();
        if saved.is_none() {
            self.warped = Some(path.to_owned());
        }
        let c = self.compile(of, &format!("{path}.of"));
        self.warped = saved;
        c
    }

    fn transform(&mut self, t: &TransformSpec, path: &str) -> Result<Compiled, SceneError> {
        let translation = t.translate.map_or(Vec3::ZERO, Vec3::from);
        if !translation.is_finite() {
            return Err(self.err(&format!("{path}.translate"), "must be finite"));
        }
        let mut factors = t.scale.map_or([1.0; 3], |s| s.factors());
        if !factors.iter().all(|s| s.is_finite() && *s > 0.0) {
            let shown = match t.scale {
                Some(Scale::Uniform(s)) => s.to_string(),
                _ => format!("{factors:?}"),
            };
            return Err(self.err(
                &format!("{path}.scale"),
                format!("{shown} must be finite and > 0 (uniform, or one factor per axis)"),
            ));
        }
        let (axis, degrees) = match &t.rotate {
            None => (None, 0.0),
            Some(r) => {
                let axis = Vec3::from(r.axis);
                if !(axis.is_finite() && axis.length() > 0.0 && r.degrees.is_finite()) {
                    return Err(self.err(
                        &format!("{path}.rotate"),
                        "axis must be finite and nonzero, degrees finite",
                    ));
                }
                (Some(axis), r.degrees)
            }
        };
        let q = axis.map_or(DQuat::IDENTITY, |a| {
            let a = a.as_dvec3();
            DQuat::from_axis_angle(
                (a / a.abs().max_element()).normalize(),
                f64::from(degrees).to_radians(),
            )
        });
        let uniform = factors[0] == factors[1] && factors[1] == factors[2];
        // The child's frame (for prism bands): world = t + s · q(local), as the builders
        // below compose it; a non-uniform scale is no similarity.
        let c = if uniform {
            let outer = self.frame;
            self.frame = outer.then(q, translation.as_dvec3(), f64::from(factors[0]));
            let c = self.compile(&t.of, &format!("{path}.of"));
            self.frame = outer;
            c?
        } else {
            self.compile_warped(&t.of, path)?
        };
        if c.dim == Dim::Two {
            if axis.is_some_and(|a| a.x != 0.0 || a.y != 0.0) && degrees != 0.0 {
                return Err(self.err(
                    &format!("{path}.rotate"),
                    "a 2D profile turns about the z axis only (rotate the extruded solid instead)",
                ));
            }
            // z is immaterial to a profile: its scale there changes nothing.
            factors[2] = if factors[0] == factors[1] {
                factors[0]
            } else {
                factors[0].min(factors[1])
            };
        }
        let hash = hash_of(|h| {
            "transform".hash(h);
            f32_bits(h, &translation.to_array());
            f32_bits(h, &[factors[0], degrees]);
            if !uniform {
                f32_bits(h, &factors);
            }
            if let Some(a) = axis {
                f32_bits(h, &a.to_array());
            }
            c.hash.hash(h);
        });
        let dim = c.dim;
        let field: Box<dyn Field> = if factors[0] == factors[1] && factors[1] == factors[2] {
            // Scale, then rotate, then translate (the builders compose in call order).
            let mut x = Transformed::new(c.field)
                .scale(factors[0])
                .map_err(|e| self.err(path, e.to_string()))?;
            if let Some(a) = axis {
                x = x
                    .rotate_axis_degrees(a, degrees)
                    .map_err(|e| self.err(path, e.to_string()))?;
            }
            Box::new(
                x.translate(translation)
                    .map_err(|e| self.err(path, e.to_string()))?,
            )
        } else {
            let m = glam::DMat3::from_quat(q)
                * glam::DMat3::from_diagonal(Vec3::from(factors).as_dvec3());
            Box::new(
                Affine::new(c.field, m, translation.as_dvec3())
                    .map_err(|e| self.err(path, e.to_string()))?,
            )
        };
        Ok(Compiled {
            field: Arc::from(field),
            hash,
            dim,
        })
    }

    fn mesh(&mut self, m: &MeshNode, path: String) -> Result<Compiled, SceneError> {
        let sign = match m.sign {
            SignMode::Auto => isokit_kdtree::mesh::SignMode::Auto,
            SignMode::Pseudonormal => isokit_kdtree::mesh::SignMode::Pseudonormal,
            SignMode::Winding => isokit_kdtree::mesh::SignMode::Winding,
            SignMode::Unsigned => isokit_kdtree::mesh::SignMode::Unsigned,
        };
        let (mesh, stamp, what): (Arc<TriMesh>, u64, String) = match (&m.data, &m.path) {
            (Some(d), _) => (d.data.clone(), d.hash, "the mesh in memory".to_owned()),
            (None, Some(file)) => {
                let f = self.resolve(file, &path)?;
                let stamp = file_stamp(&f);
                let mesh = match self.cache.meshes.get(&(canonical(&f), stamp)) {
                    Some(m) => m.clone(),
                    None => {
                        let mesh = Arc::new(
                            isokit_io::read_mesh(&f).map_err(|e| self.err(&path, chain(&e)))?,
                        );
                        self.cache
                            .meshes
                            .insert((canonical(&f), stamp), mesh.clone());
                        mesh
                    }
                };
                (mesh, stamp, isokit_io::shown_path(&f))
            }
            (None, None) => return Err(self.err(&path, "a mesh needs a `path`")),
        };
        let key = (stamp, m.sign);
        let sdf = match self.cache.mesh_sdfs.get(&key) {
            Some(s) => s.clone(),
            None => {
                let opts = MeshOptions {
                    sign,
                    ..Default::default()
                };
                let sdf = Arc::new(
                    MeshSdf::new(&mesh, opts)
                        .map_err(|e| self.err(&path, format!("{what}: {e}")))?,
                );
                self.cache.mesh_sdfs.insert(key, sdf.clone());
                sdf
            }
        };
        let prism = match m.method {
            BandMethod::Kdtree => None,
            BandMethod::Prism => Some(PrismBackend::Auto),
            BandMethod::PrismCpu => Some(PrismBackend::Cpu),
            BandMethod::PrismGpu => Some(PrismBackend::Gpu),
        };
        if let (Some(_), Some(w)) = (prism, &self.warped) {
            return Err(self.err(
                &path,
                format!(
                    "a prism band lives on the sampling lattice in the mesh's frame, which {w} \
                     (not a rotation, uniform scale or translation) does not have: use the \
                     default `\"method\": \"kdtree\"` there"
                ),
            ));
        }
        let field = Arc::new(MeshField::new(sdf, prism.map(|b| (mesh.clone(), b))));
        if prism.is_some() {
            self.prism_meshes.push(PrismMesh {
                field: field.clone(),
                frame: self.frame,
                node: path.clone(),
            });
        }
        let hash = hash_of(|h| {
            "mesh".hash(h);
            stamp.hash(h);
            m.sign.hash(h);
            m.method.hash(h);
        });
        let triangles = Some(mesh.triangles.len());
        let field = self.counted(path, "mesh", triangles, field);
        // A prism band is built for the lattice and cap of each sampling: its values are
        // not the source's alone, so they are not memoized.
        let field = if prism.is_some() {
            field
        } else {
            self.memoized(field, hash)
        };
        Ok(Compiled::solid(field, hash))
    }

    fn points(&mut self, p: &PointsNode, path: String) -> Result<Compiled, SceneError> {
        let (cloud, stamp, what) = match (&p.data, &p.path) {
            (Some(d), _) => (d.data.clone(), d.hash, "the cloud in memory".to_owned()),
            (None, Some(file)) => {
                let f = self.resolve(file, &path)?;
                let cloud = isokit_io::read_points(&f).map_err(|e| self.err(&path, chain(&e)))?;
                (Arc::new(cloud), file_stamp(&f), isokit_io::shown_path(&f))
            }
            (None, None) => return Err(self.err(&path, "a point cloud needs a `path`")),
        };
        let key = (stamp, p.k, p.normals, p.sign);
        let sdf = match self.cache.clouds.get(&key) {
            Some(s) => s.clone(),
            None => {
                let normals = match (p.normals, cloud.normals.is_some()) {
                    (Normals::Auto, true) | (Normals::Given, _) => NormalSource::Given,
                    (Normals::Auto, false) | (Normals::Estimate, _) => {
                        NormalSource::Estimate(NormalOptions::default())
                    }
                };
                let mut opts = PointSdfOptions {
                    sign: match p.sign {
                        CloudSign::Winding => SignRule::Winding,
                        CloudSign::Nearest => SignRule::Nearest,
                        CloudSign::WindingEverywhere => SignRule::WindingEverywhere,
                    },
                    ..PointSdfOptions::default()
                };
                match p.k {
                    Some(k) => opts.k = k,
                    // Chosen from the cloud's noise (`isokit_points::noise`).
                    None => {
                        let n = estimate_noise(&cloud.points)
                            .map_err(|e| self.err(&path, format!("{what}: {e}")))?;
                        (opts.k, opts.damping) = n.knobs();
                    }
                }
                let (sdf, _) = PointSdf::from_cloud(&cloud, normals, &opts)
                    .map_err(|e| self.err(&path, format!("{what}: {e}")))?;
                let sdf = Arc::new(sdf);
                self.cache.clouds.insert(key, sdf.clone());
                sdf
            }
        };
        let hash = hash_of(|h| {
            "points".hash(h);
            key.hash(h);
        });
        let field = self.counted(path, "points", None, sdf);
        let field = self.memoized(field, hash);
        Ok(Compiled::solid(field, hash))
    }

    fn volume(&mut self, v: &VolumeNode, path: String) -> Result<Compiled, SceneError> {
        let filter = match v.filter {
            FilterNode::Trilinear => Filter::Trilinear,
            FilterNode::CubicBspline => Filter::CubicBSpline,
            FilterNode::CatmullRom => Filter::CatmullRom,
        };
        let sign = match v.inside {
            Inside::Below => 1.0,
            Inside::Above => -1.0,
        };
        if !v.iso.is_finite() {
            return Err(self.err(&format!("{path}.iso"), format!("{} must be finite", v.iso)));
        }
        let iso = v.iso;
        let (data, stamp, what) = match (&v.data, &v.path) {
            (Some(d), _) => (d.data.clone(), d.hash, "the volume in memory".to_owned()),
            (None, Some(file)) => {
                let f = self.resolve(file, &path)?;
                let grid = isokit_io::read_volume(&f)
                    .and_then(|v| v.into_grid())
                    .map_err(|e| self.err(&path, chain(&e)))?;
                (
                    Arc::new(VolumeData::Grid(grid)),
                    file_stamp(&f),
                    isokit_io::shown_path(&f),
                )
            }
            (None, None) => return Err(self.err(&path, "a volume needs a `path`")),
        };
        let hash = hash_of(|h| {
            "volume".hash(h);
            stamp.hash(h);
            v.filter.hash(h);
            iso.to_bits().hash(h);
            v.inside.hash(h);
        });
        let field: Box<dyn Field> = match &*data {
            VolumeData::Grid(grid) => {
                let key = (stamp, v.filter, iso.to_bits(), v.inside);
                let vf = match self.cache.volumes.get(&key) {
                    Some(f) => f.clone(),
                    None => {
                        let vf = Arc::new(self.volume_field(
                            grid.clone(),
                            filter,
                            iso,
                            sign,
                            &path,
                            &what,
                        )?);
                        self.cache.volumes.insert(key, vf.clone());
                        vf
                    }
                };
                self.counted(path, "volume", None, vf)
            }
            VolumeData::Bricks(bricks) => {
                if iso != 0.0 || v.inside != Inside::Below || v.filter != FilterNode::Trilinear {
                    return Err(self.err(
                        &path,
                        "a brick grid in memory is read as a distance field: trilinear, iso 0, inside below",
                    ));
                }
                let lipschitz = 3f32.sqrt();
                self.counted(
                    path,
                    "volume",
                    None,
                    BrickField {
                        bricks: bricks.clone(),
                        lipschitz,
                    },
                )
            }
        };
        Ok(Compiled::solid(field, hash))
    }

    fn volume_field(
        &self,
        grid: isokit_field::Grid,
        filter: Filter,
        iso: f32,
        sign: f32,
        path: &str,
        what: &str,
    ) -> Result<VolumeField, SceneError> {
        let (lo, hi) = grid
            .min_max()
            .ok_or_else(|| self.err(path, format!("{what}: the volume has no finite sample")))?;
        if grid.data().iter().any(|x| !x.is_finite()) {
            return Err(self.err(
                path,
                format!("{what}: the volume holds NaN or infinite samples"),
            ));
        }
        // Trilinear and B-spline reconstructions are convex combinations of the samples;
        // tricubic Catmull-Rom can undershoot by up to 0.477 of the range (the negative
        // lobes of its 64 weights).
        let undershoot = if filter == Filter::CatmullRom {
            0.5 * (hi - lo)
        } else {
            0.0
        };
        let min = if sign > 0.0 { lo - iso } else { iso - hi } - undershoot;
        let lipschitz = volume_lipschitz(&grid, filter);
        Ok(VolumeField {
            field: SampledField::new(grid, filter),
            iso,
            sign,
            min,
            lipschitz,
        })
    }

    fn octree(&mut self, o: &OctreeNode, path: String) -> Result<Compiled, SceneError> {
        if !(1..=12).contains(&o.max_level) {
            return Err(self.err(
                &format!("{path}.max_level"),
                format!("{} must be 1 to 12", o.max_level),
            ));
        }
        let child = self.compile(&o.of, &format!("{path}.of"))?;
        let b = child.field.bounds();
        if !b.is_finite() || b.is_empty() {
            return Err(self.err(&path, "the octree's child must be bounded"));
        }
        let cell = b.size().max_element() / (1u32 << o.max_level) as f32;
        let error = o.error.unwrap_or(0.01 * cell);
        if !(error.is_finite() && error >= 0.0) {
            return Err(self.err(&format!("{path}.error"), format!("{error} must be ≥ 0")));
        }
        let mut opts = isokit_octree::BuildOptions::new(u32::from(o.max_level));
        opts.min_level = u32::from(o.min_level.unwrap_or(2).min(o.max_level));
        opts.error = error;
        opts.band = 2.0 * cell;
        let domain = b.expanded(4.0 * cell);
        let tree = isokit_octree::HashedOctree::build(&*child.field, domain, &opts)
            .map_err(|e| self.err(&path, e.to_string()))?;
        let hash = hash_of(|h| {
            "octree".hash(h);
            o.max_level.hash(h);
            o.min_level.hash(h);
            error.to_bits().hash(h);
            child.hash.hash(h);
        });
        let field = self.counted(path, "octree", None, tree);
        Ok(Compiled::solid(field, hash))
    }

    fn include(&mut self, file: &str, path: String) -> Result<Compiled, SceneError> {
        let f = self.resolve(file, &path)?;
        let key = canonical(&f);
        if let Some(i) = self.stack.iter().position(|p| *p == key) {
            let cycle: Vec<String> = self.stack[i..]
                .iter()
                .chain(std::iter::once(&key))
                .map(|p| isokit_io::shown_path(p))
                .collect();
            return Err(self.err(&path, format!("include cycle: {}", cycle.join(" -> "))));
        }
        let name = isokit_io::shown_path(&f);
        let (inner, _) = read_scene_file(&f, &name, &path).map_err(|e| {
            if e.file == name && e.node.is_empty() {
                self.err(&path, e.message)
            } else {
                e
            }
        })?;
        let dir = f.parent().unwrap_or(Path::new(".")).to_path_buf();
        self.stack.push(key);
        // The included file's nodes are compiled with its own folder and name.
        let saved_dir = std::mem::replace(&mut self.dir, dir);
        let saved_file = std::mem::replace(&mut self.file, name.clone());
        let compiled = self.compile(&inner.shape, &format!("{path}({name}).shape"));
        self.dir = saved_dir;
        self.file = saved_file;
        self.stack.pop();
        let c = compiled?;
        Ok(Compiled {
            hash: hash_of(|h| {
                "include".hash(h);
                c.hash.hash(h);
            }),
            field: c.field,
            dim: c.dim,
        })
    }
}
