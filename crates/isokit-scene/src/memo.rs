//! Lattice memos: the clamped values an expensive source (a mesh's kd-tree distance, a point
//! cloud's solve) took at the nodes of a sampling lattice, kept across compilations of an
//! edited scene, so that the bricks an edit elsewhere samples again do not query the source
//! again: a sphere's radius changed beside a mesh re-evaluates the sphere and the blend, and
//! reads the mesh's values back.
//!
//! A memo is keyed by the source's content hash and the frame it sits in (its transforms'
//! bits), and holds a table per lattice (the world origin's and spacing's bits, and the
//! dims: two lattices share a table only when the sampler computes the same points on
//! both). It is read and filled only while a sampling runs
//! ([`Scene::sample_again`](crate::Scene::sample_again) arms it; one lattice per source at a
//! time is armed; concurrent samplings of one compiled scene on different lattices are not
//! supported while memoizing: a point of one can read or fill the other's armed table where
//! it lies within the tolerance of its nodes), only at points within 1/1000 of a cell of a node (the sampler's points, brick
//! centres included, which it computes with the same formula as the nodes; the value stored
//! is the one computed there). Sources whose values depend on the sampling itself (a mesh
//! with a prism band, built for the lattice and the cap) are not memoized. A table is filled for the first cap the source
//! is evaluated with; by the contract of `Field::value_clamped` (the value itself below the
//! cap, `±cap` beyond), an entry `v` stored for cap `c` answers a query with another cap
//! `c'` as `clamp(v, −c', c')` unless it is saturated (`|v| = c`) and `c' > c` (an edit that
//! adds an operand to a blend raises the cap its operands get). So a sampling that reads
//! entries is bit for bit the one that computes them.
//! Tables fill in chunks of 8³ nodes, allocated where the first value below the cap is
//! stored (saturated values are stored only into chunks that exist), so a table costs 4
//! bytes per node of the chunks within the cap of the source's surface, plus an index of 24
//! bytes per chunk of the whole lattice (3/64 byte per node).

use crate::source::Counter;
use glam::{DQuat, Vec3};
use isokit_field::{Aabb, DistanceBox, Field};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

/// An f32 bit pattern no evaluation is stored as (a NaN with a payload): "not computed".
const EMPTY: u32 = 0x7fa5_5a5a;
/// Nodes per chunk along each axis.
const CHUNK: usize = 8;
/// Tables one compiled source can use (a viewer samples a coarse lattice, then the full one).
const SLOTS: usize = 4;
/// Tables kept per source across compilations (the most recently used).
const KEPT: usize = 2;
/// A point this close to a node (in cells) reads and fills the node's entry.
const TOLERANCE: f32 = 1e-3;
/// Lattices with more nodes than this get no table (the chunk index alone would be 48 MiB).
const MAX_NODES: u64 = 1 << 30;

/// Which source a memo belongs to: its content hash and its frame's bits.
pub(crate) type MemoKey = (u64, [u64; 4]);

/// The memo tables of every memoized source, shared by the compilations of one
/// [`SourceCache`](crate::SourceCache).
#[derive(Default)]
pub(crate) struct MemoStore {
    tables: HashMap<MemoKey, Vec<Arc<Table>>>,
}

impl MemoStore {
    /// Forgets the tables of sources not in `used` (the scene compiled last).
    pub(crate) fn retain(&mut self, used: &[MemoKey]) {
        self.tables.retain(|k, _| used.contains(k));
    }

    /// The table of `key` for `lattice`, made when it does not exist; the most recent
    /// first, at most [`KEPT`] per source.
    fn table(&mut self, key: MemoKey, lattice: Lattice) -> Option<Arc<Table>> {
        let list = self.tables.entry(key).or_default();
        let t = match list.iter().position(|t| t.lattice == lattice) {
            Some(i) => list.remove(i),
            None => Arc::new(Table::new(lattice)?),
        };
        list.insert(0, t.clone());
        list.truncate(KEPT);
        Some(t)
    }
}

/// A lattice in a source's frame, and the bits of the world lattice it comes from.
#[derive(Clone, Copy, Debug)]
struct Lattice {
    origin: Vec3,
    spacing: f32,
    dims: [usize; 3],
    /// The world origin's and spacing's bits: the table's identity.
    world: [u32; 4],
}

impl PartialEq for Lattice {
    fn eq(&self, other: &Self) -> bool {
        self.world == other.world && self.dims == other.dims
    }
}

/// One lattice's values.
pub(crate) struct Table {
    lattice: Lattice,
    inv_spacing: f32,
    chunk_dims: [usize; 3],
    chunks: Box<[OnceLock<Box<[AtomicU32]>>]>,
    /// The cap of the entries (bits), [`EMPTY`] until the first evaluation.
    cap: AtomicU32,
    /// Samplings running that may read the entries (fills happen whenever one is armed).
    readers: AtomicUsize,
    /// Samplings running.
    armed: AtomicUsize,
}

impl Table {
    fn new(lattice: Lattice) -> Option<Self> {
        let nodes = lattice.dims.iter().map(|&d| d as u64).product::<u64>();
        if nodes == 0 || nodes > MAX_NODES || !lattice.spacing.is_finite() || lattice.spacing <= 0.0
        {
            return None;
        }
        let chunk_dims = lattice.dims.map(|d| d.div_ceil(CHUNK));
        let n = chunk_dims.iter().product::<usize>();
        Some(Self {
            lattice,
            inv_spacing: 1.0 / lattice.spacing,
            chunk_dims,
            chunks: (0..n).map(|_| OnceLock::new()).collect(),
            cap: AtomicU32::new(EMPTY),
            readers: AtomicUsize::new(0),
            armed: AtomicUsize::new(0),
        })
    }

    /// The chunk and the entry in it of the node `p` lies at, if it lies at one.
    #[inline]
    fn node(&self, p: Vec3) -> Option<(usize, usize)> {
        let u = (p - self.lattice.origin) * self.inv_spacing;
        // Below −1/2 (or NaN) no node is near; above, `u + 1/2` truncated is the nearest
        // node (a conversion, where `round` is a call), and ties lie beyond the tolerance.
        if !u.cmpge(Vec3::splat(-0.5)).all() {
            return None;
        }
        let n = (u + 0.5).as_uvec3();
        if (u - n.as_vec3()).abs().max_element() > TOLERANCE {
            return None;
        }
        let [nx, ny, nz] = self.lattice.dims;
        let (i, j, k) = (n.x as usize, n.y as usize, n.z as usize);
        if i >= nx || j >= ny || k >= nz {
            return None;
        }
        let [cx, cy, _] = self.chunk_dims;
        let chunk = (i / CHUNK) + cx * ((j / CHUNK) + cy * (k / CHUNK));
        let entry = (i % CHUNK) + CHUNK * ((j % CHUNK) + CHUNK * (k % CHUNK));
        Some((chunk, entry))
    }

    /// The cap the entries were computed with (claiming the table for `cap` when it has
    /// none yet).
    #[inline]
    fn cap_for(&self, cap: f32) -> f32 {
        let c = self.cap.load(Ordering::Relaxed);
        if c != EMPTY {
            return f32::from_bits(c);
        }
        match self
            .cap
            .compare_exchange(EMPTY, cap.to_bits(), Ordering::Relaxed, Ordering::Relaxed)
        {
            Ok(_) => cap,
            Err(now) => f32::from_bits(now),
        }
    }
}

/// The tables one compiled source reads and fills, and how many values it read back.
pub(crate) struct Slots {
    tables: [OnceLock<Arc<Table>>; SLOTS],
    pub(crate) hits: Arc<Counter>,
}

/// A source whose clamped values at lattice nodes are memoized (see the module docs).
pub(crate) struct Memoized<F> {
    pub(crate) field: F,
    pub(crate) slots: Arc<Slots>,
}

impl<F: Field> Memoized<F> {
    pub(crate) fn new(field: F) -> (Self, Arc<Slots>) {
        let slots = Arc::new(Slots {
            tables: std::array::from_fn(|_| OnceLock::new()),
            hits: Arc::new(Counter::new()),
        });
        (
            Self {
                field,
                slots: slots.clone(),
            },
            slots,
        )
    }
}

impl<F: Field> Field for Memoized<F> {
    fn value(&self, p: Vec3) -> f32 {
        self.field.value(p)
    }
    fn bounds(&self) -> Aabb {
        self.field.bounds()
    }
    fn lipschitz(&self) -> f32 {
        self.field.lipschitz()
    }
    fn is_exact(&self) -> bool {
        self.field.is_exact()
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.field.fd_step(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.field.gradient(p)
    }
    fn hessian(&self, p: Vec3) -> glam::Mat3 {
        self.field.hessian(p)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        self.field.distance_box()
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.field.lower_bound(p)
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        for slot in &self.slots.tables {
            let Some(t) = slot.get() else { break };
            if t.armed.load(Ordering::Relaxed) == 0 {
                continue;
            }
            let Some((c, e)) = t.node(p) else { continue };
            let own = t.cap_for(cap);
            let chunk = t.chunks[c].get();
            if let Some(chunk) = chunk.filter(|_| t.readers.load(Ordering::Relaxed) > 0) {
                let bits = chunk[e].load(Ordering::Relaxed);
                let v = f32::from_bits(bits);
                // Saturated entries say only |value| ≥ own (see the module docs).
                if bits != EMPTY && (cap <= own || v.abs() < own) {
                    self.slots.hits.add();
                    return if cap == own { v } else { v.clamp(-cap, cap) };
                }
            }
            let v = self.field.value_clamped(p, cap);
            if cap == own && v.to_bits() != EMPTY {
                // A chunk is made only for a value below the cap (near the surface).
                let chunk = match chunk {
                    Some(chunk) => Some(chunk),
                    None if v.abs() < own => Some(t.chunks[c].get_or_init(|| {
                        (0..CHUNK * CHUNK * CHUNK)
                            .map(|_| AtomicU32::new(EMPTY))
                            .collect()
                    })),
                    None => None,
                };
                if let Some(chunk) = chunk {
                    chunk[e].store(v.to_bits(), Ordering::Relaxed);
                }
            }
            return v;
        }
        self.field.value_clamped(p, cap)
    }
}

/// A memoized source of a compiled scene: its tables, key and frame.
pub(crate) struct MemoUse {
    pub(crate) slots: Arc<Slots>,
    pub(crate) key: MemoKey,
    /// World = translation + scale · local (no rotation: a rotated lattice has no nodes in
    /// common with an axis-aligned one).
    pub(crate) translation: glam::DVec3,
    pub(crate) scale: f64,
}

/// The key of a source with content hash `hash` in the frame (`rotation`, `translation`,
/// `scale`); `None` when the frame rotates (no memo).
pub(crate) fn key_of(
    hash: u64,
    rotation: DQuat,
    translation: glam::DVec3,
    scale: f64,
) -> Option<MemoKey> {
    // Any rotation other than the identity (up to rounding) moves the lattice's axes.
    if rotation.angle_between(DQuat::IDENTITY) > 1e-12 {
        return None;
    }
    let [tx, ty, tz] = translation.to_array().map(f64::to_bits);
    Some((hash, [tx, ty, tz, scale.to_bits()]))
}

/// Armed tables; disarmed when dropped.
pub(crate) struct Armed(Vec<(Arc<Table>, bool)>);

impl Drop for Armed {
    fn drop(&mut self) {
        for (t, read) in &self.0 {
            t.armed.fetch_sub(1, Ordering::Relaxed);
            if *read {
                t.readers.fetch_sub(1, Ordering::Relaxed);
            }
        }
    }
}

/// Arms the memos of `uses` for a sampling on the lattice (`origin`, `spacing`, `dims`, in
/// world units); `read`: whether the sampling may read values back (a full re-evaluation
/// only fills them).
pub(crate) fn arm(
    store: &Mutex<MemoStore>,
    uses: &[MemoUse],
    origin: Vec3,
    spacing: f32,
    dims: [usize; 3],
    read: bool,
) -> Armed {
    let mut armed = Vec::new();
    let mut store = store.lock().unwrap_or_else(|p| p.into_inner());
    for u in uses {
        let lattice = Lattice {
            origin: ((origin.as_dvec3() - u.translation) / u.scale).as_vec3(),
            spacing: (f64::from(spacing) / u.scale) as f32,
            dims,
            world: [
                origin.x.to_bits(),
                origin.y.to_bits(),
                origin.z.to_bits(),
                spacing.to_bits(),
            ],
        };
        // One lattice per source at a time: a point of a sampling on another lattice can lie
        // within the tolerance of this one's nodes.
        let busy = u.slots.tables.iter().any(|s| {
            s.get()
                .is_some_and(|h| h.lattice != lattice && h.armed.load(Ordering::Relaxed) > 0)
        });
        if busy {
            continue;
        }
        let Some(t) = store.table(u.key, lattice) else {
            continue;
        };
        // Into this compilation's slots, unless they hold it already or are full.
        let held = u
            .slots
            .tables
            .iter()
            .any(|s| s.get().is_some_and(|h| Arc::ptr_eq(h, &t)));
        if !held && !u.slots.tables.iter().any(|s| s.set(t.clone()).is_ok()) {
            continue;
        }
        t.armed.fetch_add(1, Ordering::Relaxed);
        if read {
            t.readers.fetch_add(1, Ordering::Relaxed);
        }
        armed.push((t, read));
    }
    Armed(armed)
}
