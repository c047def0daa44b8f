//! Scene files: CSG trees written in JSON or TOML, evaluated lazily.
//!
//! A scene is a table whose key `shape` holds the tree (see [`schema::Node`] for the
//! vocabulary), with optional `camera`, `lights`, `shading` and `sampling` tables for the
//! renderer and the sampler. Paths inside a scene are relative to the scene file. Errors
//! name the file, the node path (`shape.difference[1].mesh`) and the problem.
//!
//! ```
//! use isokit_levelset::scene::{Scene, SceneFormat, SampleOptions};
//! use isokit_field::Field;
//! use glam::Vec3;
//!
//! let text = r#"{"shape": {"difference": [
//!     {"sphere": {"radius": 1.0}},
//!     {"box": {"half": [0.5, 0.5, 0.5], "center": [1.0, 0.0, 0.0]}}
//! ]}}"#;
//! let scene = Scene::from_text(text, SceneFormat::Json, "example.json", ".".as_ref()).unwrap();
//! // The box bites into the sphere: (0.6, 0, 0) is now outside, 0.1 from the box's face.
//! assert!((scene.value(Vec3::new(0.6, 0.0, 0.0)) - 0.1).abs() < 1e-6);
//!
//! // Sample the band lazily: bricks far from the surface are never evaluated.
//! let (grid, stats) = scene.sample(&SampleOptions { resolution: 128, ..Default::default() })
//!     .unwrap();
//! assert!(stats.dense_fraction < 0.5);
//! assert!(grid.brick_count() > 0);
//! ```
//!
//! ## What is computed
//! [`Scene::sample`] never fills the dense grid: the sampler evaluates one point per brick
//! and keeps the bricks whose value, less the Lipschitz bound times the brick's
//! half-diagonal, comes within the band; the tree is evaluated with values clamped to a cap
//! just above that, so bounding boxes prune subtrees and sources (a union skips a child
//! whose box is farther than the best value so far, a difference skips a subtrahend whose
//! box the point lies well outside of, and meshes answer band-limited kd-tree queries).
//! [`SampleStats`] reports the share of the dense grid's samples that were computed and
//! how often each source was queried.

pub mod eval;
pub mod schema;

use eval::{Compiled, Op, SmoothKind, Source, SourceField};
use glam::{DQuat, DVec3, Vec3};
use isokit_field::{
    Aabb, BrickGrid, Field, Grid,
    filter::{Filter, SampledField},
    primitives::{
        CappedCone, CappedCylinder, Capsule, Cuboid, Ellipsoid, Plane, Primitive, RoundedBox,
        Sphere, Torus,
    },
};
use isokit_kdtree::mesh::{MeshOptions, MeshSdf, SignMethod, SignMode};
use isokit_points::{NormalOptions, NormalSource, PointSdf, PointSdfOptions};
use rayon::prelude::*;
use schema::{Node, SceneFile, Smooth, TransformSpec};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A scene that cannot be read or built: which file, which node, what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {}{message}", if node.is_empty() { String::new() } else { format!("{node}: ") })]
pub struct SceneError {
    /// The scene file (or the name given to [`Scene::from_text`]).
    pub file: String,
    /// Path of the node in the file, e.g. `shape.union[1].sphere.radius`; empty for
    /// problems with the file as a whole.
    pub node: String,
    /// The problem.
    pub message: String,
}

impl SceneError {
    fn new(file: &str, node: &str, message: impl Into<String>) -> Self {
        Self {
            file: file.to_owned(),
            node: node.to_owned(),
            message: message.into(),
        }
    }
}

/// Scene file syntax.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    /// JSON (`.json`).
    Json,
    /// TOML (`.toml`).
    Toml,
}

impl SceneFormat {
    /// From a path's extension.
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "json" => Some(Self::Json),
            "toml" => Some(Self::Toml),
            _ => None,
        }
    }
}

/// Parses scene text into the schema's types.
pub fn parse(text: &str, format: SceneFormat, file: &str) -> Result<SceneFile, SceneError> {
    let value: serde_json::Value = match format {
        SceneFormat::Json => serde_json::from_str(text)
            .map_err(|e| SceneError::new(file, "", format!("invalid JSON: {e}")))?,
        SceneFormat::Toml => {
            let table: toml::Value = toml::from_str(text).map_err(|e| {
                // The message and where, without the quoted source line (which may be long).
                let at = e.span().map_or(String::new(), |r| {
                    let before = &text[..r.start.min(text.len())];
                    let line = before.matches('\n').count() + 1;
                    let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
                    format!(" at line {line} column {col}")
                });
                SceneError::new(
                    file,
                    "",
                    format!("invalid TOML{at}: {}", e.message().trim()),
                )
            })?;
            if let Some(node) = non_finite(&table, String::new()) {
                return Err(SceneError::new(
                    file,
                    &node,
                    "nan and inf are not allowed (numbers must be finite)",
                ));
            }
            serde_json::to_value(table)
                .map_err(|e| SceneError::new(file, "", format!("invalid TOML: {e}")))?
        }
    };
    if !value.is_object() {
        return Err(SceneError::new(
            file,
            "",
            "a scene is a table with the key `shape`",
        ));
    }
    serde_path_to_error::deserialize(value).map_err(|e| {
        let node = e.path().to_string();
        let node = if node == "." { String::new() } else { node };
        SceneError::new(file, &node, e.into_inner().to_string())
    })
}

/// The path (in `serde_path_to_error`'s notation) of the first non-finite float in `v`.
fn non_finite(v: &toml::Value, path: String) -> Option<String> {
    let join = |k: &str| {
        if path.is_empty() {
            k.to_owned()
        } else {
            format!("{path}.{k}")
        }
    };
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some(path),
        toml::Value::Table(t) => t.iter().find_map(|(k, v)| non_finite(v, join(k))),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| non_finite(v, format!("{path}[{i}]"))),
        _ => None,
    }
}

/// A compiled scene: the shape tree with its sources loaded, ready to evaluate. It is a
/// [`Field`] (evaluated in full, nothing clamped).
pub struct Scene {
    file: SceneFile,
    name: String,
    root: Compiled,
    sources: Vec<Source>,
    lipschitz: f32,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("name", &self.name)
            .field("sources", &self.sources.len())
            .field("bounds", &self.root.bounds)
            .finish()
    }
}

impl Scene {
    /// Reads and compiles a scene file (`.json` or `.toml`); meshes, clouds, volumes and
    /// included scenes are loaded relative to its folder.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let name = path.display().to_string();
        let format = SceneFormat::from_path(path).ok_or_else(|| {
            SceneError::new(&name, "", "unknown scene format (expected .json or .toml)")
        })?;
        let text = std::fs::read_to_string(path)
            .map_err(|e| SceneError::new(&name, "", format!("cannot read: {e}")))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut stack = vec![canonical(path)];
        Self::build(parse(&text, format, &name)?, &name, dir, &mut stack)
    }

    /// Compiles scene text; `name` names it in errors and `dir` resolves relative paths.
    pub fn from_text(
        text: &str,
        format: SceneFormat,
        name: &str,
        dir: &Path,
    ) -> Result<Self, SceneError> {
        Self::build(parse(text, format, name)?, name, dir, &mut Vec::new())
    }

    /// Compiles a scene built in code (see [`schema::Node`]'s constructors).
    pub fn from_file(file: SceneFile, dir: &Path) -> Result<Self, SceneError> {
        Self::build(file, "<scene>", dir, &mut Vec::new())
    }

    fn build(
        file: SceneFile,
        name: &str,
        dir: &Path,
        stack: &mut Vec<PathBuf>,
    ) -> Result<Self, SceneError> {
        let mut b = Builder {
            file: name,
            dir,
            stack,
            sources: Vec::new(),
            depth: 0,
            nodes: 0,
        };
        let root = b.compile(&file.shape, "shape")?;
        let sources = b.sources;
        let lipschitz = root.lipschitz.max(1.0);
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
            root,
            sources,
            lipschitz,
        })
    }

    /// The scene as read (shape tree, camera, lights, shading, sampling).
    pub fn settings(&self) -> &SceneFile {
        &self.file
    }

    /// The sources (leaves) with their query counters.
    pub fn sources(&self) -> &[Source] {
        &self.sources
    }

    /// Sets every source's query counter to zero.
    pub fn reset_counts(&self) {
        self.sources.iter().for_each(Source::reset);
    }

    /// The value at `p`, exact where `|f(p)| < cap`; elsewhere `±cap` with the right sign.
    /// Bounding boxes prune what cannot matter (see [`eval`]).
    pub fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        self.root.eval(p, cap, &self.sources)
    }

    /// The sampling domain: `sampling.bounds` when given, else the shape's bounds.
    pub fn domain(&self) -> Aabb {
        match self.file.sampling.bounds {
            Some([a, b]) => Aabb::from_corners(Vec3::from(a), Vec3::from(b)),
            None => self.root.bounds,
        }
    }

    /// Samples the band lazily into a [`BrickGrid`] (see the module docs) and reports what
    /// it cost.
    pub fn sample(&self, opts: &SampleOptions) -> Result<(BrickGrid, SampleStats), SceneError> {
        let t0 = Instant::now();
        self.reset_counts();
        let plan = self.plan(opts)?;
        let reach = 0.5 * ((plan.brick + 2 * opts.apron) as f32) * plan.spacing * 3f32.sqrt();
        // Just above what the sampler's brick test needs (see `BrickGrid::sample_field`).
        let cap = (plan.band + self.lipschitz * reach) * 1.001 + plan.spacing;
        let field = Clamped { scene: self, cap };
        let grid = BrickGrid::sample_field(
            &field,
            plan.dims,
            plan.origin,
            plan.spacing,
            plan.brick,
            opts.apron,
            plan.band,
            plan.band,
        )
        .map_err(|e| SceneError::new(&self.name, "sampling", e.to_string()))?;
        let dense = plan.dims.iter().map(|&d| d as f64).product::<f64>();
        let stats = self.stats(
            &plan,
            grid.evaluated_fraction(),
            dense,
            grid.brick_count(),
            grid.brick_dims().iter().product(),
            t0,
        );
        Ok((grid, stats))
    }

    /// Samples every node of the same lattice [`Scene::sample`] uses, in full (no
    /// clamping, no pruning): the baseline lazy sampling is measured against.
    pub fn sample_dense(&self, opts: &SampleOptions) -> Result<(Grid, SampleStats), SceneError> {
        let t0 = Instant::now();
        self.reset_counts();
        let plan = self.plan(opts)?;
        let mut grid = Grid::new(plan.dims, plan.origin, plan.spacing)
            .map_err(|e| SceneError::new(&self.name, "sampling", e.to_string()))?;
        let [nx, ny, _] = plan.dims;
        let (o, h) = (plan.origin, plan.spacing);
        grid.data_mut()
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, slice)| {
                for (n, v) in slice.iter_mut().enumerate() {
                    let ijk = Vec3::new((n % nx) as f32, (n / nx) as f32, k as f32);
                    *v = self.value(o + h * ijk);
                }
            });
        let dense = grid.len() as f64;
        let bricks = plan.dims.map(|d| d.div_ceil(plan.brick)).iter().product();
        let stats = self.stats(&plan, 1.0, dense, bricks, bricks, t0);
        Ok((grid, stats))
    }

    fn stats(
        &self,
        plan: &Plan,
        fraction: f64,
        dense: f64,
        kept: usize,
        total: usize,
        t0: Instant,
    ) -> SampleStats {
        SampleStats {
            dims: plan.dims,
            origin: plan.origin.to_array(),
            spacing: plan.spacing,
            band: plan.band,
            brick: plan.brick,
            dense_fraction: fraction,
            dense_samples: dense as u64,
            bricks_kept: kept,
            bricks_total: total,
            seconds: t0.elapsed().as_secs_f64(),
            sources: self
                .sources
                .iter()
                .map(|s| SourceStats {
                    node: s.node.clone(),
                    kind: s.kind,
                    queries: s.queries(),
                    query_fraction: s.queries() as f64 / dense.max(1.0),
                })
                .collect(),
        }
    }

    fn plan(&self, opts: &SampleOptions) -> Result<Plan, SceneError> {
        let err = |node: &str, m: String| SceneError::new(&self.name, node, m);
        let domain = opts.bounds.unwrap_or_else(|| self.domain());
        if domain.is_empty() {
            return Err(err(
                "shape",
                "the shape is empty (its bounding box holds nothing)".into(),
            ));
        }
        if !domain.is_finite() {
            return Err(err(
                "shape",
                "the shape is unbounded: give sampling.bounds = [[xmin, ymin, zmin], [xmax, ymax, zmax]]"
                    .into(),
            ));
        }
        let res = opts.resolution;
        if !(2..=isokit_field::MAX_AXIS).contains(&res) {
            return Err(err(
                "sampling.resolution",
                format!("{res} must be at least 2 samples along the longest side"),
            ));
        }
        if !(opts.brick.is_power_of_two() && (2..=64).contains(&opts.brick)) {
            return Err(err(
                "sampling.brick",
                format!("{} must be a power of two from 2 to 64", opts.brick),
            ));
        }
        let h0 = domain.size().max_element() / (res - 1).max(1) as f32;
        let explicit = opts.bounds.is_some() || self.file.sampling.bounds.is_some();
        let band = match opts.band {
            Some(b) if b.is_finite() && b > 0.0 => b,
            Some(b) => {
                return Err(err(
                    "sampling.band",
                    format!("{b} must be finite and positive"),
                ));
            }
            None if h0 > 0.0 && h0.is_finite() => 4.0 * h0,
            None => {
                return Err(err(
                    "sampling",
                    "the domain has no extent (a single point): give sampling.bounds or a band"
                        .into(),
                ));
            }
        };
        let pad = if explicit { 0.0 } else { band + 2.0 * h0 };
        if domain.expanded(pad).size().max_element() <= 0.0 {
            return Err(err(
                "sampling.bounds",
                "the domain has no extent: the corners must differ".into(),
            ));
        }
        let (dims, origin, spacing) = Grid::covering_geometry(domain, res, pad)
            .map_err(|e| err("sampling", e.to_string()))?;
        Ok(Plan {
            dims,
            origin,
            spacing,
            band,
            brick: opts.brick,
        })
    }
}

impl Field for Scene {
    fn value(&self, p: Vec3) -> f32 {
        self.root.eval(p, f32::INFINITY, &self.sources)
    }

    fn bounds(&self) -> Aabb {
        self.root.bounds
    }

    /// Computed per node: min, max, the smooth blends, offsets, shells and similarity
    /// transforms keep the largest of their operands' bounds; a morph has
    /// `|1 − t|·L_from + |t|·L_to`; a volume's is measured from its samples.
    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }
}

/// The scene clamped to `±cap`: what the lazy sampler evaluates.
struct Clamped<'a> {
    scene: &'a Scene,
    cap: f32,
}

impl Field for Clamped<'_> {
    fn value(&self, p: Vec3) -> f32 {
        self.scene.value_clamped(p, self.cap)
    }
    fn bounds(&self) -> Aabb {
        self.scene.bounds()
    }
    fn lipschitz(&self) -> f32 {
        self.scene.lipschitz
    }
}

/// The lattice one sampling uses.
struct Plan {
    dims: [usize; 3],
    origin: Vec3,
    spacing: f32,
    band: f32,
    brick: usize,
}

/// Knobs of [`Scene::sample`]; [`SampleOptions::from_scene`] reads them from the scene's
/// `sampling` table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleOptions {
    /// Samples along the longest side of the domain.
    pub resolution: usize,
    /// Band half-width in world units (default 4 voxels).
    pub band: Option<f32>,
    /// Brick size (a power of two, 2 to 64).
    pub brick: usize,
    /// Apron samples stored around each brick (0 for meshing, 1 or more for filtering).
    pub apron: usize,
    /// The domain (default the scene's).
    pub bounds: Option<Aabb>,
}

impl Default for SampleOptions {
    fn default() -> Self {
        Self {
            resolution: 128,
            band: None,
            brick: 4,
            apron: 0,
            bounds: None,
        }
    }
}

impl SampleOptions {
    /// The scene's `sampling` table over the defaults.
    pub fn from_scene(scene: &Scene) -> Self {
        let s = &scene.file.sampling;
        let d = Self::default();
        Self {
            resolution: s.resolution.unwrap_or(d.resolution),
            band: s.band,
            brick: s.brick.unwrap_or(d.brick),
            ..d
        }
    }
}

/// What one source cost in one sampling.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceStats {
    /// Node path.
    pub node: String,
    /// Node kind.
    pub kind: &'static str,
    /// Evaluations of the source.
    pub queries: u64,
    /// `queries` over the dense grid's sample count (a dense evaluation queries every
    /// source once per sample).
    pub query_fraction: f64,
}

/// What one sampling computed.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleStats {
    /// Lattice dimensions.
    pub dims: [usize; 3],
    /// Position of sample (0, 0, 0).
    pub origin: [f32; 3],
    /// Sample spacing.
    pub spacing: f32,
    /// Band half-width.
    pub band: f32,
    /// Brick size.
    pub brick: usize,
    /// Share of the dense grid's samples that were evaluated.
    pub dense_fraction: f64,
    /// Samples of the dense grid.
    pub dense_samples: u64,
    /// Bricks kept.
    pub bricks_kept: usize,
    /// Bricks of the lattice.
    pub bricks_total: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Per source.
    pub sources: Vec<SourceStats>,
}

impl SampleStats {
    /// As a JSON object (the `--stats` output of `isokit scene`).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "dense_fraction": self.dense_fraction,
            "seconds": self.seconds,
            "dims": self.dims,
            "origin": self.origin,
            "spacing": self.spacing,
            "band": self.band,
            "brick": self.brick,
            "dense_samples": self.dense_samples,
            "bricks_kept": self.bricks_kept,
            "bricks_total": self.bricks_total,
            "sources": self.sources.iter().map(|s| serde_json::json!({
                "node": s.node,
                "kind": s.kind,
                "queries": s.queries,
                "query_fraction": s.query_fraction,
            })).collect::<Vec<_>>(),
        })
    }
}

/// The deepest tree a scene may build (across includes): evaluation recurses once per
/// level.
pub const MAX_DEPTH: usize = 256;
/// The most nodes a scene may build (across includes; an include used twice counts twice).
pub const MAX_NODES: usize = 100_000;

/// Compiles schema nodes into the evaluation tree, loading sources.
struct Builder<'a> {
    file: &'a str,
    dir: &'a Path,
    stack: &'a mut Vec<PathBuf>,
    sources: Vec<Source>,
    depth: usize,
    nodes: usize,
}

/// A Lipschitz bound of a volume source: the largest difference of neighbouring samples
/// over the spacing, times the filter's factor (sound for samples with that slope), plus 1
/// for the continuation by the distance to the box outside the grid.
fn volume_lipschitz(grid: &Grid, filter: Filter) -> f32 {
    let [nx, ny, nz] = grid.dims();
    let d = grid.data();
    let mut slope = 0.0f32;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let n = grid.index(i, j, k);
                let v = d[n];
                if i + 1 < nx {
                    slope = slope.max((d[n + 1] - v).abs());
                }
                if j + 1 < ny {
                    slope = slope.max((d[n + nx] - v).abs());
                }
                if k + 1 < nz {
                    slope = slope.max((d[n + nx * ny] - v).abs());
                }
            }
        }
    }
    filter.lipschitz_factor() * slope / grid.spacing() + 1.0
}

fn canonical(p: &Path) -> PathBuf {
    p.canonicalize().unwrap_or_else(|_| p.to_path_buf())
}

impl Builder<'_> {
    fn err(&self, node: &str, m: impl Into<String>) -> SceneError {
        SceneError::new(self.file, node, m)
    }

    fn source(&mut self, node: String, kind: &'static str, f: SourceField) -> Compiled {
        self.sources.push(Source::new(node, kind, f));
        Compiled::new(Op::Source(self.sources.len() - 1), &self.sources)
    }

    fn primitive(
        &mut self,
        path: &str,
        kind: &'static str,
        p: Result<impl Into<Primitive>, isokit_field::FieldError>,
    ) -> Result<Compiled, SceneError> {
        let p = p.map_err(|e| self.err(path, e.to_string()))?;
        Ok(self.source(path.to_owned(), kind, SourceField::Analytic(p.into())))
    }

    fn children(
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

    fn resolve(&self, path: &str, node: &str) -> Result<PathBuf, SceneError> {
        if path.is_empty() {
            return Err(self.err(node, "path is empty"));
        }
        let p = self.dir.join(path);
        if p.is_dir() {
            return Err(self.err(node, format!("{} is a directory, not a file", p.display())));
        }
        if !p.is_file() {
            return Err(self.err(node, format!("no such file: {}", p.display())));
        }
        Ok(p)
    }

    fn compile(&mut self, node: &Node, parent: &str) -> Result<Compiled, SceneError> {
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
        let out = self.compile_node(node, path);
        self.depth -= 1;
        out
    }

    fn compile_node(&mut self, node: &Node, path: String) -> Result<Compiled, SceneError> {
        let v = Vec3::from;
        let finite = |x: f32, name: &str| -> Result<f32, SceneError> {
            if x.is_finite() {
                Ok(x)
            } else {
                Err(self.err(&format!("{path}.{name}"), format!("{x} must be finite")))
            }
        };
        Ok(match node {
            Node::Sphere { radius, center } => {
                self.primitive(&path, "sphere", Sphere::new(v(*center), *radius))?
            }
            Node::Box { half, center } => {
                self.primitive(&path, "box", Cuboid::new(v(*center), v(*half)))?
            }
            Node::RoundedBox {
                half,
                radius,
                center,
            } => self.primitive(
                &path,
                "rounded_box",
                RoundedBox::new(v(*center), v(*half), *radius),
            )?,
            Node::Torus {
                major,
                minor,
                center,
            } => self.primitive(&path, "torus", Torus::new(v(*center), *major, *minor))?,
            Node::Capsule { a, b, radius } => {
                self.primitive(&path, "capsule", Capsule::new(v(*a), v(*b), *radius))?
            }
            Node::Cylinder { a, b, radius } => self.primitive(
                &path,
                "cylinder",
                CappedCylinder::new(v(*a), v(*b), *radius),
            )?,
            Node::Cone { a, b, ra, rb } => {
                self.primitive(&path, "cone", CappedCone::new(v(*a), v(*b), *ra, *rb))?
            }
            Node::Plane { normal, offset } => {
                self.primitive(&path, "plane", Plane::new(v(*normal), *offset))?
            }
            Node::Ellipsoid { radii, center } => {
                self.primitive(&path, "ellipsoid", Ellipsoid::new(v(*center), v(*radii)))?
            }
            Node::Mesh { path: file, sign } => {
                let sign = match sign.as_str() {
                    "auto" => SignMode::Auto,
                    "pseudonormal" => SignMode::Pseudonormal,
                    "winding" => SignMode::Winding,
                    "unsigned" => SignMode::Unsigned,
                    s => {
                        return Err(self.err(
                            &format!("{path}.sign"),
                            format!(
                                "unknown sign `{s}` (expected auto, pseudonormal, winding or unsigned)"
                            ),
                        ));
                    }
                };
                let f = self.resolve(file, &path)?;
                let mesh = isokit_io::read_mesh(&f).map_err(|e| self.err(&path, e.to_string()))?;
                let opts = MeshOptions {
                    sign,
                    ..Default::default()
                };
                let sdf = MeshSdf::new(&mesh, opts)
                    .map_err(|e| self.err(&path, format!("{}: {e}", f.display())))?;
                // Pseudonormal signs on an open or misoriented mesh can be negative far
                // outside its box; the winding number and unsigned distances cannot.
                let box_bound = sdf.sign_method() != SignMethod::Pseudonormal || {
                    let r = mesh.validate();
                    r.watertight && r.consistently_oriented
                };
                self.source(
                    path,
                    "mesh",
                    SourceField::Mesh {
                        sdf: Box::new(sdf),
                        box_bound,
                    },
                )
            }
            Node::Points {
                path: file,
                k,
                normals,
            } => {
                let f = self.resolve(file, &path)?;
                let cloud =
                    isokit_io::read_points(&f).map_err(|e| self.err(&path, e.to_string()))?;
                let normals = match (normals.as_str(), cloud.normals.is_some()) {
                    ("auto", true) | ("given", _) => NormalSource::Given,
                    ("auto", false) | ("estimate", _) => {
                        NormalSource::Estimate(NormalOptions::default())
                    }
                    (s, _) => {
                        return Err(self.err(
                            &format!("{path}.normals"),
                            format!("unknown normals `{s}` (expected auto, given or estimate)"),
                        ));
                    }
                };
                let mut opts = PointSdfOptions::default();
                if let Some(k) = k {
                    opts.k = *k;
                }
                let (sdf, _) = PointSdf::from_cloud(&cloud, normals, &opts)
                    .map_err(|e| self.err(&path, format!("{}: {e}", f.display())))?;
                self.source(path, "points", SourceField::Points(Box::new(sdf)))
            }
            Node::Volume {
                path: file,
                filter,
                iso,
                inside,
            } => {
                let filter = match filter.as_deref() {
                    None | Some("trilinear") => Filter::Trilinear,
                    Some("cubic_bspline") => Filter::CubicBSpline,
                    Some("catmull_rom") => Filter::CatmullRom,
                    Some(s) => {
                        return Err(self.err(
                            &format!("{path}.filter"),
                            format!(
                                "unknown filter `{s}` (expected trilinear, cubic_bspline or catmull_rom)"
                            ),
                        ));
                    }
                };
                let sign = match inside.as_deref() {
                    None | Some("below") => 1.0,
                    Some("above") => -1.0,
                    Some(s) => {
                        return Err(self.err(
                            &format!("{path}.inside"),
                            format!("unknown side `{s}` (expected below or above)"),
                        ));
                    }
                };
                let iso = finite(*iso, "iso")?;
                let f = self.resolve(file, &path)?;
                let grid = isokit_io::read_volume(&f)
                    .and_then(|v| v.into_grid())
                    .map_err(|e| self.err(&path, e.to_string()))?;
                let (lo, hi) = grid.min_max().ok_or_else(|| {
                    self.err(
                        &path,
                        format!("{}: the volume has no finite sample", f.display()),
                    )
                })?;
                if grid.data().iter().any(|x| !x.is_finite()) {
                    return Err(self.err(
                        &path,
                        format!("{}: the volume holds NaN or infinite samples", f.display()),
                    ));
                }
                // Trilinear and B-spline reconstructions are convex combinations of the
                // samples; tricubic Catmull-Rom can undershoot by up to 0.477 of the range
                // (the negative lobes of its 64 weights).
                let undershoot = if filter == Filter::CatmullRom {
                    0.5 * (hi - lo)
                } else {
                    0.0
                };
                let min = if sign > 0.0 { lo - iso } else { iso - hi } - undershoot;
                let lipschitz = volume_lipschitz(&grid, filter);
                let field = Box::new(SampledField::new(grid, filter));
                self.source(
                    path,
                    "volume",
                    SourceField::Volume {
                        field,
                        iso,
                        sign,
                        min,
                        lipschitz,
                    },
                )
            }
            Node::Include { path: file } => {
                let f = self.resolve(file, &path)?;
                let key = canonical(&f);
                if let Some(i) = self.stack.iter().position(|p| *p == key) {
                    let cycle: Vec<String> = self.stack[i..]
                        .iter()
                        .chain(std::iter::once(&key))
                        .map(|p| p.display().to_string())
                        .collect();
                    return Err(self.err(&path, format!("include cycle: {}", cycle.join(" -> "))));
                }
                let name = f.display().to_string();
                let format = SceneFormat::from_path(&f).ok_or_else(|| {
                    self.err(
                        &path,
                        format!("{name}: unknown scene format (expected .json or .toml)"),
                    )
                })?;
                let text = std::fs::read_to_string(&f)
                    .map_err(|e| self.err(&path, format!("cannot read {name}: {e}")))?;
                let inner = parse(&text, format, &name)?;
                let dir = f.parent().unwrap_or(Path::new("."));
                self.stack.push(key);
                let mut sub = Builder {
                    file: &name,
                    dir,
                    stack: &mut *self.stack,
                    sources: std::mem::take(&mut self.sources),
                    depth: self.depth,
                    nodes: self.nodes,
                };
                let compiled = sub.compile(&inner.shape, &format!("{path}({name}).shape"));
                self.sources = sub.sources;
                self.nodes = sub.nodes;
                self.stack.pop();
                compiled?
            }
            Node::Union(of) => {
                Compiled::new(Op::Union(self.children(of, &path, 1)?), &self.sources)
            }
            Node::Intersection(of) => Compiled::new(
                Op::Intersection(self.children(of, &path, 1)?),
                &self.sources,
            ),
            Node::Difference(of) => {
                Compiled::new(Op::Difference(self.children(of, &path, 2)?), &self.sources)
            }
            Node::Complement(of) => {
                let c = self.compile(of, &path)?;
                Compiled::new(Op::Complement(Box::new(c)), &self.sources)
            }
            Node::SmoothUnion(s) => self.smooth(s, &path, SmoothKind::Union)?,
            Node::SmoothIntersection(s) => self.smooth(s, &path, SmoothKind::Intersection)?,
            Node::SmoothDifference(s) => self.smooth(s, &path, SmoothKind::Difference)?,
            Node::Offset { by, of } => {
                let by = finite(*by, "by")?;
                let c = self.compile(of, &format!("{path}.of"))?;
                Compiled::new(
                    Op::Offset {
                        by,
                        of: Box::new(c),
                    },
                    &self.sources,
                )
            }
            Node::Shell { thickness, of } => {
                let t = finite(*thickness, "thickness")?;
                if t <= 0.0 {
                    return Err(self.err(&format!("{path}.thickness"), format!("{t} must be > 0")));
                }
                let c = self.compile(of, &format!("{path}.of"))?;
                Compiled::new(
                    Op::Shell {
                        half: 0.5 * t,
                        of: Box::new(c),
                    },
                    &self.sources,
                )
            }
            Node::Morph { t, from, to } => {
                let t = finite(*t, "t")?;
                let a = self.compile(from, &format!("{path}.from"))?;
                let b = self.compile(to, &format!("{path}.to"))?;
                Compiled::new(
                    Op::Morph {
                        t,
                        from: Box::new(a),
                        to: Box::new(b),
                    },
                    &self.sources,
                )
            }
            Node::Transform(t) => self.transform(t, &path)?,
        })
    }

    fn smooth(&mut self, s: &Smooth, path: &str, kind: SmoothKind) -> Result<Compiled, SceneError> {
        if !(s.radius.is_finite() && s.radius >= 0.0) {
            return Err(self.err(
                &format!("{path}.radius"),
                format!("{} must be finite and non-negative", s.radius),
            ));
        }
        let min = if kind == SmoothKind::Difference { 2 } else { 1 };
        let of = self.children(&s.of, &format!("{path}.of"), min)?;
        Ok(Compiled::new(
            Op::Smooth {
                kind,
                k: s.radius,
                of,
            },
            &self.sources,
        ))
    }

    fn transform(&mut self, t: &TransformSpec, path: &str) -> Result<Compiled, SceneError> {
        let translation = t
            .translate
            .map_or(DVec3::ZERO, |v| Vec3::from(v).as_dvec3());
        if !translation.is_finite() {
            return Err(self.err(&format!("{path}.translate"), "must be finite"));
        }
        let scale = f64::from(t.scale.unwrap_or(1.0));
        if !(scale.is_finite() && scale > 0.0) {
            return Err(self.err(
                &format!("{path}.scale"),
                format!("{scale} must be finite and > 0 (uniform scale only)"),
            ));
        }
        let rotation = match &t.rotate {
            None => DQuat::IDENTITY,
            Some(r) => {
                let axis = Vec3::from(r.axis).as_dvec3();
                if !(axis.is_finite() && axis.length() > 0.0 && r.degrees.is_finite()) {
                    return Err(self.err(
                        &format!("{path}.rotate"),
                        "axis must be finite and nonzero, degrees finite",
                    ));
                }
                DQuat::from_axis_angle(axis.normalize(), f64::from(r.degrees).to_radians())
            }
        };
        let c = self.compile(&t.of, &format!("{path}.of"))?;
        Ok(Compiled::new(
            Op::Transform {
                inv_rotation: rotation.inverse(),
                translation,
                scale,
                of: Box::new(c),
            },
            &self.sources,
        ))
    }
}
