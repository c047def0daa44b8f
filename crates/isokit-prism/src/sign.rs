//! From packed keys to signed values, and the sign of the samples the band does not reach.
//!
//! Inside the band the sign comes with the key (pseudonormal of the closest feature), or,
//! for meshes signed by the winding number, from the winding number at the sample. Outside
//! the band every sample holds `±band`:
//!
//! - **Flood fill** (pseudonormal meshes, band wider than half a spacing): two neighbouring
//!   samples have the same sign unless the surface crosses the segment between them, and a
//!   surface point on that segment lies within half a spacing of one of them. So an
//!   unreached sample takes the sign of a neighbour that is unreached too, or reached with
//!   `|d| > spacing / 2`. A breadth-first fill inside each slab spreads the signs from such
//!   neighbours; a component of the slab with no such neighbour (a slab the band misses)
//!   asks the winding number once, at one of its samples.
//! - **Winding number per sample** (meshes signed by the winding number, or bands of at most
//!   half a spacing): exactly what the kd-tree path does, and as slow.

use crate::scan::unpack;
use glam::DVec3;
use isokit_kdtree::mesh::MeshSdf;

/// What decoding needs to know.
pub(crate) struct Decode<'a> {
    pub sdf: &'a MeshSdf,
    /// Signs from the winding number at every sample (else from the keys).
    pub winding: bool,
    /// Unsigned output (no sign anywhere).
    pub unsigned: bool,
    /// Band half-width, world units (f32 as stored).
    pub band: f32,
    pub spacing: f32,
    pub origin: DVec3,
    pub nx: usize,
    pub ny: usize,
    /// Fill the samples outside the band with `±band` (else leave NaN).
    pub fill: bool,
}

/// Counts from decoding one slab.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SlabCounts {
    pub band_samples: u64,
    pub windings: u64,
}

impl Decode<'_> {
    fn position(&self, idx: usize, k0: usize) -> DVec3 {
        let (i, j, k) = (
            idx % self.nx,
            (idx / self.nx) % self.ny,
            k0 + idx / (self.nx * self.ny),
        );
        self.origin + self.spacing as f64 * DVec3::new(i as f64, j as f64, k as f64)
    }

    fn winding_negative(&self, p: DVec3) -> bool {
        self.sdf.winding_number(p) > 0.5
    }

    /// Turns the keys of slab `values` (slices from `k0`, keys stored as f32 bits) into
    /// values in place.
    pub fn slab(&self, k0: usize, values: &mut [f32]) -> SlabCounts {
        let mut counts = SlabCounts::default();
        let h = self.spacing;
        for (idx, v) in values.iter_mut().enumerate() {
            *v = match unpack(v.to_bits()) {
                Some((dg, neg)) if dg * h < self.band => {
                    counts.band_samples += 1;
                    let d = dg * h;
                    let negative = if self.unsigned {
                        false
                    } else if self.winding {
                        counts.windings += 1;
                        self.winding_negative(self.position(idx, k0))
                    } else {
                        neg
                    };
                    if negative { -d } else { d }
                }
                _ => f32::NAN,
            };
        }
        if !self.fill {
            return counts;
        }
        if self.unsigned {
            for v in values.iter_mut().filter(|v| v.is_nan()) {
                *v = self.band;
            }
        } else if self.winding || self.band <= 0.5 * h {
            for (idx, v) in values.iter_mut().enumerate() {
                if v.is_nan() {
                    counts.windings += 1;
                    let neg = self.winding_negative(self.position(idx, k0));
                    *v = if neg { -self.band } else { self.band };
                }
            }
        } else {
            counts.windings += self.flood(k0, values);
        }
        counts
    }

    /// Fills the NaN samples of a slab with `±band`; returns the winding numbers asked.
    ///
    /// Three passes, cheapest first: (1) along each row, a run of unreached samples next to a
    /// reached sample with `|d| > spacing / 2` takes its sign; (2) rows the band misses
    /// entirely are filled whole, breadth-first over rows (a row takes the sign of a
    /// neighbouring row's sample at the same `i` that is filled or farther than half a
    /// spacing); (3) what is left (runs bounded only by samples within half a spacing of the
    /// surface) is filled breadth-first over samples. A component with no usable neighbour
    /// asks the winding number once.
    fn flood(&self, k0: usize, values: &mut [f32]) -> u64 {
        let (nx, ny) = (self.nx, self.ny);
        let nz = values.len() / (nx * ny);
        let half = 0.5 * self.spacing;
        let band = self.band;
        let eligible = |v: f32| v.abs() > half && v.abs() < band;
        let signed = |v: f32| if v < 0.0 { -band } else { band };
        let rows = ny * nz;
        // Pass 1: runs within rows. `empty[r]`: row r is unreached throughout.
        let mut empty = vec![false; rows];
        let mut leftovers = false;
        for (r, row) in values.chunks_mut(nx).enumerate() {
            let mut i = 0;
            while i < nx {
                if !row[i].is_nan() {
                    i += 1;
                    continue;
                }
                let start = i;
                while i < nx && row[i].is_nan() {
                    i += 1;
                }
                let left = (start > 0).then(|| row[start - 1]).filter(|v| eligible(*v));
                let right = (i < nx).then(|| row[i]).filter(|v| eligible(*v));
                match left.or(right) {
                    Some(v) => row[start..i].fill(signed(v)),
                    None if start == 0 && i == nx => empty[r] = true,
                    None => leftovers = true,
                }
            }
        }
        // Pass 2: whole rows, breadth-first over rows.
        let mut windings = 0;
        let row_neighbours = |r: usize| {
            let (j, k) = (r % ny, r / ny);
            let mut out = [usize::MAX; 4];
            if j > 0 {
                out[0] = r - 1;
            }
            if j + 1 < ny {
                out[1] = r + 1;
            }
            if k > 0 {
                out[2] = r - ny;
            }
            if k + 1 < nz {
                out[3] = r + ny;
            }
            out
        };
        let mut queue: Vec<usize> = Vec::new();
        for r in 0..rows {
            if !empty[r] {
                continue;
            }
            let found = row_neighbours(r)
                .into_iter()
                .filter(|&q| q != usize::MAX && !empty[q])
                .find_map(|q| {
                    values[q * nx..(q + 1) * nx]
                        .iter()
                        .copied()
                        .find(|v| !v.is_nan() && (v.abs() >= band || eligible(*v)))
                });
            if let Some(v) = found {
                values[r * nx..(r + 1) * nx].fill(signed(v));
                empty[r] = false;
                queue.push(r);
            }
        }
        let spread_rows = |queue: &mut Vec<usize>, values: &mut [f32], empty: &mut [bool]| {
            let mut head = 0;
            while head < queue.len() {
                let r = queue[head];
                head += 1;
                let v = values[r * nx];
                for q in row_neighbours(r) {
                    if q != usize::MAX && empty[q] {
                        values[q * nx..(q + 1) * nx].fill(v);
                        empty[q] = false;
                        queue.push(q);
                    }
                }
            }
            queue.clear();
        };
        spread_rows(&mut queue, values, &mut empty);
        for r in 0..rows {
            if empty[r] {
                windings += 1;
                let neg = self.winding_negative(self.position(r * nx, k0));
                values[r * nx..(r + 1) * nx].fill(if neg { -band } else { band });
                empty[r] = false;
                queue.push(r);
                spread_rows(&mut queue, values, &mut empty);
            }
        }
        if leftovers {
            windings += self.flood_samples(k0, values);
        }
        windings
    }

    /// Breadth-first fill of the remaining NaN samples of a slab; returns the winding
    /// numbers asked.
    fn flood_samples(&self, k0: usize, values: &mut [f32]) -> u64 {
        let (nx, ny) = (self.nx, self.ny);
        let n = values.len();
        let nz = n / (nx * ny);
        let half = 0.5 * self.spacing;
        let band = self.band;
        let neighbours = |idx: usize| {
            let (i, j, k) = (idx % nx, (idx / nx) % ny, idx / (nx * ny));
            let mut out = [usize::MAX; 6];
            if i > 0 {
                out[0] = idx - 1;
            }
            if i + 1 < nx {
                out[1] = idx + 1;
            }
            if j > 0 {
                out[2] = idx - nx;
            }
            if j + 1 < ny {
                out[3] = idx + nx;
            }
            if k > 0 {
                out[4] = idx - nx * ny;
            }
            if k + 1 < nz {
                out[5] = idx + nx * ny;
            }
            out
        };
        let mut queue: Vec<usize> = Vec::new();
        // Seeds: unreached samples next to a filled one or a reached one farther than half a
        // spacing.
        for idx in 0..n {
            if !values[idx].is_nan() {
                continue;
            }
            let seed = neighbours(idx)
                .into_iter()
                .filter(|&w| w != usize::MAX)
                .map(|w| values[w])
                .find(|v| !v.is_nan() && v.abs() > half);
            if let Some(v) = seed {
                values[idx] = if v < 0.0 { -band } else { band };
                queue.push(idx);
            }
        }
        let spread = |queue: &mut Vec<usize>, values: &mut [f32]| {
            let mut head = 0;
            while head < queue.len() {
                let u = queue[head];
                head += 1;
                let val = values[u];
                for w in neighbours(u) {
                    if w != usize::MAX && values[w].is_nan() {
                        values[w] = val;
                        queue.push(w);
                    }
                }
            }
            queue.clear();
        };
        spread(&mut queue, values);
        let mut windings = 0;
        for idx in 0..n {
            if values[idx].is_nan() {
                windings += 1;
                let neg = self.winding_negative(self.position(idx, k0));
                values[idx] = if neg { -band } else { band };
                queue.push(idx);
                spread(&mut queue, values);
            }
        }
        windings
    }
}
