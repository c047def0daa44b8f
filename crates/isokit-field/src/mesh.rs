//! Triangle meshes as plain data: [`TriMesh`] (positions and index triples) and its
//! validation report ([`TriMesh::validate`], [`MeshReport`]). Reading and writing mesh files
//! is `isokit-io`'s job; this module has no formats.

use std::collections::HashMap;
use std::fmt;

use glam::{DVec3, Vec3};

use crate::Aabb;

/// An indexed triangle mesh: positions and triangles as index triples into them.
///
/// Readers guarantee every index is in range; a mesh built by hand may break that, and
/// [`TriMesh::validate`] counts such triangles instead of panicking. Writers refuse them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions in world units.
    pub positions: Vec<Vec3>,
    /// Triangles, counter-clockwise seen from outside for an oriented surface.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// A mesh from its parts (not checked; see [`TriMesh::validate`]).
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        Self {
            positions,
            triangles,
        }
    }

    /// The box around all finite positions ([`Aabb::EMPTY`] for none).
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.positions)
    }

    /// True when the mesh has no triangles.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Appends another mesh, offsetting its indices.
    pub fn append(&mut self, other: &TriMesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| t.map(|i| i.wrapping_add(base))),
        );
    }

    /// The first problem with the indices, if any: a triangle naming a vertex beyond the
    /// vertex count, or more vertices than 32-bit indices hold (writers refuse such meshes).
    pub fn index_problem(&self) -> Option<String> {
        let n = self.positions.len();
        if n > u32::MAX as usize {
            return Some(format!("{n} vertices do not fit 32-bit indices"));
        }
        self.triangles
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&i| i as usize >= n))
            .map(|(t, tri)| {
                format!("triangle {t} {tri:?} refers to a vertex beyond the {n} vertices")
            })
    }
}

/// Relative tolerance below which a triangle counts as zero-area: `|(b−a)×(c−a)| ≤ tol ·
/// (longest edge)²`, i.e. the sine of its smallest angle is about `tol` or less. Computed in
/// f64; `1e-7` is about the rounding of f32 positions.
pub const DEGENERATE_REL_TOL: f64 = 1e-7;

/// What [`TriMesh::validate`] found. Counts of problems, then topology.
///
/// Topology (edges, boundary, manifoldness, orientation, components, Euler characteristic)
/// is computed on vertex *indices*: a mesh whose seams hold duplicate vertices (as STL read
/// without welding would) shows those seams as boundary. Triangles with a repeated or
/// out-of-range index are left out of the topology entirely: their edges, their face and
/// the vertices that only they use count neither in χ = V − E + F nor in the components
/// (those vertices are still *referenced*, so not counted as unreferenced either). The
/// topology is that of the surface made of the proper triangles. Zero-area triangles with
/// three distinct indices are proper triangles here. A mesh without any proper triangle is
/// neither watertight nor consistently oriented.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshReport {
    /// Number of vertices.
    pub vertices: usize,
    /// Number of triangles.
    pub triangles: usize,
    /// Box around the finite vertices.
    pub bounds: Aabb,
    /// Triangles with a repeated index or zero area within [`DEGENERATE_REL_TOL`].
    pub degenerate_triangles: usize,
    /// Triangles over the same vertex set as an earlier triangle (either orientation).
    pub duplicate_triangles: usize,
    /// Triangles with an index beyond the vertex count (never produced by a reader).
    pub invalid_triangles: usize,
    /// Vertices at the same position as an earlier vertex (`-0.0 == 0.0`).
    pub duplicate_vertices: usize,
    /// Vertices that no triangle uses.
    pub unreferenced_vertices: usize,
    /// Vertices with a NaN or infinite coordinate.
    pub non_finite_vertices: usize,
    /// Distinct undirected edges.
    pub edges: usize,
    /// Edges used by exactly one triangle.
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Vertices whose proper triangles form more than one fan (sets of triangles joined
    /// through edges at the vertex): two surfaces touching in one point, a pinch that
    /// [`watertight`](Self::watertight) does not see. 0 for a 2-manifold mesh.
    pub non_manifold_vertices: usize,
    /// At least one proper triangle, no boundary and no non-manifold edges.
    pub watertight: bool,
    /// At least one proper triangle; every edge shared by two triangles is used once in each
    /// direction, and no directed edge is used twice.
    pub consistently_oriented: bool,
    /// Connected components (of proper triangles sharing vertices).
    pub components: usize,
    /// V − E + F over the vertices, distinct edges and triangles of the proper triangles
    /// (2 for a closed sphere-like surface, 2 − 2g for a closed orientable surface of
    /// genus g).
    pub euler_characteristic: i64,
}

impl MeshReport {
    /// The genus when the mesh is one closed, oriented component: `(2 − χ) / 2`.
    pub fn genus(&self) -> Option<i64> {
        (self.watertight && self.consistently_oriented && self.components == 1)
            .then_some((2 - self.euler_characteristic) / 2)
    }

    /// True when nothing was counted as a problem and the surface is closed and oriented.
    pub fn is_clean(&self) -> bool {
        self.degenerate_triangles == 0
            && self.duplicate_triangles == 0
            && self.invalid_triangles == 0
            && self.non_finite_vertices == 0
            && self.watertight
            && self.consistently_oriented
    }
}

fn yes(b: bool) -> &'static str {
    if b { "yes" } else { "no" }
}

impl fmt::Display for MeshReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "vertices:   {} ({} duplicate, {} unreferenced, {} non-finite)",
            self.vertices,
            self.duplicate_vertices,
            self.unreferenced_vertices,
            self.non_finite_vertices
        )?;
        writeln!(
            f,
            "triangles:  {} ({} degenerate, {} duplicate, {} with invalid indices)",
            self.triangles,
            self.degenerate_triangles,
            self.duplicate_triangles,
            self.invalid_triangles
        )?;
        if self.bounds.is_empty() {
            writeln!(f, "bounds:     empty")?;
        } else {
            let (a, b) = (self.bounds.min, self.bounds.max);
            writeln!(
                f,
                "bounds:     [{}, {}, {}] .. [{}, {}, {}]",
                a.x, a.y, a.z, b.x, b.y, b.z
            )?;
        }
        writeln!(
            f,
            "edges:      {} ({} boundary, {} non-manifold)",
            self.edges, self.boundary_edges, self.non_manifold_edges
        )?;
        writeln!(f, "non-manifold vertices: {}", self.non_manifold_vertices)?;
        writeln!(f, "watertight: {}", yes(self.watertight))?;
        writeln!(
            f,
            "consistently oriented: {}",
            yes(self.consistently_oriented)
        )?;
        writeln!(f, "components: {}", self.components)?;
        write!(f, "Euler characteristic: {}", self.euler_characteristic)?;
        if let Some(g) = self.genus() {
            write!(f, " (genus {g})")?;
        }
        Ok(())
    }
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[x as usize];
        parent[x as usize] = parent[p as usize];
        x = p;
    }
    x
}

/// The key under which positions weld: their exact bits, with −0 taken as +0 (used to count
/// duplicate vertices and to merge coincident ones).
pub fn pos_key(p: glam::Vec3) -> [u32; 3] {
    // +0.0 for -0.0 so that both weld together.
    [p.x + 0.0, p.y + 0.0, p.z + 0.0].map(f32::to_bits)
}

impl TriMesh {
    /// Counts defects and computes the topology of the mesh. Never panics, whatever the
    /// indices hold. Runs in O(V + F) expected time with hash maps.
    pub fn validate(&self) -> MeshReport {
        let nv = self.positions.len();
        let mut referenced = vec![false; nv];
        // Used by a proper triangle (three distinct, valid indices).
        let mut in_face = vec![false; nv];
        let mut degenerate = 0;
        let mut invalid = 0;
        let mut duplicates = 0;
        let mut seen_sets: HashMap<[u32; 3], ()> = HashMap::with_capacity(self.triangles.len());
        // Undirected edge (lo, hi) → (uses lo→hi, uses hi→lo).
        let mut edges: HashMap<(u32, u32), (u32, u32)> =
            HashMap::with_capacity(self.triangles.len() * 3 / 2);
        let mut parent: Vec<u32> = (0..nv as u32).collect();
        let mut faces = 0i64;

        for t in &self.triangles {
            if t.iter().any(|&i| i as usize >= nv) {
                invalid += 1;
                continue;
            }
            for &i in t {
                referenced[i as usize] = true;
            }
            let mut s = *t;
            s.sort_unstable();
            if seen_sets.insert(s, ()).is_some() {
                duplicates += 1;
            }
            let repeated = t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
            if repeated {
                degenerate += 1;
                continue;
            }
            let [a, b, c] = t.map(|i| self.positions[i as usize].as_dvec3());
            if zero_area(a, b, c) {
                degenerate += 1;
            }
            faces += 1;
            for &i in t {
                in_face[i as usize] = true;
            }
            for k in 0..3 {
                let (u, v) = (t[k], t[(k + 1) % 3]);
                let e = edges.entry((u.min(v), u.max(v))).or_insert((0, 0));
                if u < v {
                    e.0 += 1;
                } else {
                    e.1 += 1;
                }
                let (ru, rv) = (find(&mut parent, u), find(&mut parent, v));
                if ru != rv {
                    parent[ru.max(rv) as usize] = ru.min(rv);
                }
            }
        }

        let mut boundary = 0;
        let mut non_manifold = 0;
        let mut oriented = true;
        for &(fw, bw) in edges.values() {
            match fw + bw {
                1 => boundary += 1,
                2 => oriented &= fw == 1 && bw == 1,
                _ => {
                    non_manifold += 1;
                    oriented &= fw <= 1 && bw <= 1;
                }
            }
        }

        let mut components = 0;
        let mut used_vertices = 0i64;
        for v in 0..nv as u32 {
            if in_face[v as usize] {
                used_vertices += 1;
                if find(&mut parent, v) == v {
                    components += 1;
                }
            }
        }

        let mut seen_pos: HashMap<[u32; 3], ()> = HashMap::with_capacity(nv);
        let mut duplicate_vertices = 0;
        let mut non_finite = 0;
        for p in &self.positions {
            if !p.is_finite() {
                non_finite += 1;
            }
            if seen_pos.insert(pos_key(*p), ()).is_some() {
                duplicate_vertices += 1;
            }
        }

        MeshReport {
            vertices: nv,
            triangles: self.triangles.len(),
            bounds: self.bounds(),
            degenerate_triangles: degenerate,
            duplicate_triangles: duplicates,
            invalid_triangles: invalid,
            duplicate_vertices,
            unreferenced_vertices: referenced.iter().filter(|r| !**r).count(),
            non_finite_vertices: non_finite,
            edges: edges.len(),
            boundary_edges: boundary,
            non_manifold_edges: non_manifold,
            non_manifold_vertices: self.pinched_vertices(),
            watertight: faces > 0 && boundary == 0 && non_manifold == 0,
            consistently_oriented: faces > 0 && oriented,
            components,
            euler_characteristic: used_vertices - edges.len() as i64 + faces,
        }
    }
}

impl TriMesh {
    /// Vertices whose proper triangles (three distinct, valid indices) fall into more than one
    /// fan: triangles around a vertex are joined when they share an edge at it.
    fn pinched_vertices(&self) -> usize {
        let nv = self.positions.len();
        let proper = |t: &[u32; 3]| {
            t.iter().all(|&i| (i as usize) < nv) && t[0] != t[1] && t[1] != t[2] && t[0] != t[2]
        };
        // Triangles around each vertex, as offsets into one array (compressed rows).
        let mut start = vec![0usize; nv + 1];
        for t in self.triangles.iter().filter(|t| proper(t)) {
            for &i in t {
                start[i as usize + 1] += 1;
            }
        }
        for v in 0..nv {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut around = vec![0usize; start[nv]];
        for (k, t) in self.triangles.iter().enumerate().filter(|(_, t)| proper(t)) {
            for &i in t {
                around[fill[i as usize]] = k;
                fill[i as usize] += 1;
            }
        }
        let mut pinched = 0;
        let mut parent: Vec<u32> = Vec::new();
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for v in 0..nv {
            let tris = &around[start[v]..start[v + 1]];
            if tris.len() < 2 {
                continue;
            }
            // Union of the triangles (local indices) that share another vertex `w`, i.e. the
            // edge `v w`: the (w, triangle) pairs sorted by `w` (O(d log d) for a fan of d,
            // however many triangles a hostile file puts around one vertex).
            parent.clear();
            parent.extend(0..tris.len() as u32);
            pairs.clear();
            for (a, &k) in tris.iter().enumerate() {
                for &w in &self.triangles[k] {
                    if w as usize != v {
                        pairs.push((w, a as u32));
                    }
                }
            }
            pairs.sort_unstable();
            for p in pairs.windows(2) {
                if p[0].0 == p[1].0 {
                    let (ra, rb) = (find(&mut parent, p[0].1), find(&mut parent, p[1].1));
                    if ra != rb {
                        parent[ra.max(rb) as usize] = ra.min(rb);
                    }
                }
            }
            let fans = (0..tris.len() as u32)
                .filter(|&a| find(&mut parent, a) == a)
                .count();
            pinched += (fans > 1) as usize;
        }
        pinched
    }
}

/// Whether the triangle `a b c` has zero area within [`DEGENERATE_REL_TOL`] of its longest
/// edge squared: what [`TriMesh::validate`] counts as degenerate.
pub fn zero_area(a: DVec3, b: DVec3, c: DVec3) -> bool {
    let cross = (b - a).cross(c - a).length();
    let longest = (b - a)
        .length_squared()
        .max((c - b).length_squared())
        .max((a - c).length_squared());
    // NaN compares false: a triangle with a non-finite vertex is not "degenerate" here but is
    // reported through non_finite_vertices.
    cross <= DEGENERATE_REL_TOL * longest
}
