//! Bond inference from distances on a uniform spatial hash grid.

use std::collections::HashMap;

use super::{Atom, Element};

/// Pairs closer than this (Å) are never bonded: they are clashes or duplicates.
pub const MIN_BOND_DISTANCE: f32 = 0.4;
/// Two hydrogens are bonded only when closer than this (Å), as in H₂ (0.74 Å); otherwise
/// the generous covalent cut-off would bond the hydrogens of every CH₂ and NH₂ group.
pub const MAX_HH_BOND_DISTANCE: f32 = 0.8;
/// An atom gets at most this many inferred bonds (a guard against pathological input such
/// as thousands of atoms packed 0.5 Å apart, which would otherwise produce a number of
/// bonds quadratic in the atom count). No real molecule comes near it.
pub const MAX_INFERRED_BONDS_PER_ATOM: usize = 16;
/// Each atom is compared with at most this many atoms of each neighbouring cell (its own
/// included). A cell of the grid (edge: the longest possible bond, about 3.5 Å) holds a
/// handful of atoms in any real structure; the cap only binds for pathological input
/// (thousands of atoms piled at one point), where it keeps inference linear instead of
/// quadratic, at the price of bonds among the pile not being inferred.
pub const MAX_CANDIDATES_PER_CELL: usize = 256;
/// Tolerances outside `-MAX_TOLERANCE..=MAX_TOLERANCE` (Å) are clamped to it.
pub const MAX_TOLERANCE: f32 = 1.0;

/// The 13 neighbour offsets after (0, 0, 0) in lexicographic order: with the cell itself,
/// each unordered pair of neighbouring cells is visited exactly once.
const HALF_NEIGHBOURS: [[i64; 3]; 13] = {
    let mut out = [[0i64; 3]; 13];
    let mut n = 0;
    let mut dx = -1;
    while dx <= 1 {
        let mut dy = -1;
        while dy <= 1 {
            let mut dz = -1;
            while dz <= 1 {
                if dx > 0 || (dx == 0 && (dy > 0 || (dy == 0 && dz > 0))) {
                    out[n] = [dx, dy, dz];
                    n += 1;
                }
                dz += 1;
            }
            dy += 1;
        }
        dx += 1;
    }
    out
};

/// Where the atoms of each cell lie in the key-sorted atom list.
enum Cells {
    /// A dense grid of `dims` cells (x slowest): cell `c` holds `start[c]..start[c + 1]`.
    Dense { dims: [i64; 3], start: Vec<u32> },
    /// Occupied cells only, for sparse or far-flung atoms.
    Hash(HashMap<[i64; 3], (usize, usize)>),
}

impl Cells {
    /// Sorts `order` by cell key (then atom index) and indexes it: a counting sort into a
    /// dense grid when the grid has at most a few cells per atom, else a comparison sort
    /// and a hash map of the occupied cells. Keys are non-negative.
    fn build(order: &mut [([i64; 3], u32)]) -> Cells {
        let mut hi = [0i64; 3];
        for (k, _) in order.iter() {
            for a in 0..3 {
                hi[a] = hi[a].max(k[a]);
            }
        }
        let dims = hi.map(|h| h.saturating_add(1));
        let limit = 4 * order.len() as u64 + 64;
        let ncells = dims
            .iter()
            .try_fold(1u64, |acc, &d| acc.checked_mul(u64::try_from(d).ok()?))
            .filter(|&n| n <= limit);
        if let Some(ncells) = ncells {
            let ncells = ncells as usize;
            let lin = |k: [i64; 3]| ((k[0] * dims[1] + k[1]) * dims[2] + k[2]) as usize;
            let mut start = vec![0u32; ncells + 1];
            for (k, _) in order.iter() {
                start[lin(*k) + 1] += 1;
            }
            for c in 0..ncells {
                start[c + 1] += start[c];
            }
            let mut fill = start.clone();
            let mut sorted = vec![([0i64; 3], 0u32); order.len()];
            for &(k, i) in order.iter() {
                let c = lin(k);
                sorted[fill[c] as usize] = (k, i);
                fill[c] += 1;
            }
            order.copy_from_slice(&sorted);
            Cells::Dense { dims, start }
        } else {
            order.sort_unstable();
            let mut map = HashMap::new();
            let mut s = 0;
            for k in 1..=order.len() {
                if k == order.len() || order[k].0 != order[s].0 {
                    map.insert(order[s].0, (s, k));
                    s = k;
                }
            }
            Cells::Hash(map)
        }
    }

    /// The range of `order` in cell `k`, if that cell holds any atom.
    fn get(&self, k: [i64; 3]) -> Option<(usize, usize)> {
        match self {
            Cells::Dense { dims, start } => {
                if (0..3).any(|a| k[a] < 0 || k[a] >= dims[a]) {
                    return None;
                }
                let c = ((k[0] * dims[1] + k[1]) * dims[2] + k[2]) as usize;
                let (s, e) = (start[c] as usize, start[c + 1] as usize);
                (s < e).then_some((s, e))
            }
            Cells::Hash(map) => map.get(&k).copied(),
        }
    }
}

/// Clamps a user tolerance to `-MAX_TOLERANCE..=MAX_TOLERANCE`; NaN counts as 0.
pub(crate) fn sanitize_tolerance(tolerance: f32) -> f32 {
    if tolerance.is_nan() {
        0.0
    } else {
        tolerance.clamp(-MAX_TOLERANCE, MAX_TOLERANCE)
    }
}

/// True when atoms `a` and `b` are close enough to be bonded (see
/// [`super::Molecule::infer_bonds`] for the rule).
#[inline]
pub(crate) fn bonded(a: &Atom, b: &Atom, tolerance: f32) -> bool {
    let d2 = a.position.distance_squared(b.position);
    if d2.is_nan() || d2 <= MIN_BOND_DISTANCE * MIN_BOND_DISTANCE {
        return false;
    }
    let max = a.element.covalent_radius() + b.element.covalent_radius() + tolerance;
    if max <= 0.0 || d2 >= max * max {
        return false;
    }
    !(a.element == Element::H
        && b.element == Element::H
        && d2 >= MAX_HH_BOND_DISTANCE * MAX_HH_BOND_DISTANCE)
}

/// Bonds by distance between atoms with finite positions, sorted, `i < j`, no duplicates.
/// `skip(i, j)` (with `i < j`) rejects a candidate pair before the distance test.
///
/// Atoms are binned into cubic cells of edge `2 * max covalent radius + tolerance` (the
/// longest possible bond) — a dense grid filled by counting sort when it has at most about
/// four cells per atom, else a hash map of the occupied cells — so only atoms in the same
/// or adjacent cells are compared: linear time for molecular densities.
pub(crate) fn infer(
    atoms: &[Atom],
    tolerance: f32,
    skip: impl Fn(u32, u32) -> bool,
) -> Vec<[u32; 2]> {
    let tol = sanitize_tolerance(tolerance);
    let live: Vec<u32> = (0..atoms.len())
        .filter(|&i| atoms[i].position.is_finite())
        .map(|i| i as u32)
        .collect();
    if live.len() < 2 {
        return Vec::new();
    }
    let max_r = live
        .iter()
        .map(|&i| atoms[i as usize].element.covalent_radius())
        .fold(0.0f32, f32::max);
    let cell = f64::from((2.0 * max_r + tol).max(MIN_BOND_DISTANCE));
    let mut origin = [f64::INFINITY; 3];
    for &i in &live {
        let p = atoms[i as usize].position;
        for (o, v) in origin.iter_mut().zip([p.x, p.y, p.z]) {
            *o = o.min(f64::from(v));
        }
    }
    // Cell coordinates; `as i64` saturates, so far-flung coordinates share edge cells
    // (slower, never wrong: every candidate pair is still tested by distance).
    let key = |i: u32| -> [i64; 3] {
        let p = atoms[i as usize].position;
        [
            ((f64::from(p.x) - origin[0]) / cell).floor() as i64,
            ((f64::from(p.y) - origin[1]) / cell).floor() as i64,
            ((f64::from(p.z) - origin[2]) / cell).floor() as i64,
        ]
    };
    let mut order: Vec<([i64; 3], u32)> = live.iter().map(|&i| (key(i), i)).collect();
    let cells = Cells::build(&mut order);
    // Runs of atoms sharing a cell, in key order.
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut start = 0;
    for k in 1..=order.len() {
        if k == order.len() || order[k].0 != order[start].0 {
            runs.push((start, k));
            start = k;
        }
    }

    let mut degree = vec![0u8; atoms.len()];
    let mut bonds: Vec<[u32; 2]> = Vec::new();
    let consider = |i: u32, j: u32, degree: &mut [u8], bonds: &mut Vec<[u32; 2]>| {
        let (i, j) = if i < j { (i, j) } else { (j, i) };
        if usize::from(degree[i as usize]) >= MAX_INFERRED_BONDS_PER_ATOM
            || usize::from(degree[j as usize]) >= MAX_INFERRED_BONDS_PER_ATOM
            || skip(i, j)
            || !bonded(&atoms[i as usize], &atoms[j as usize], tol)
        {
            return;
        }
        degree[i as usize] += 1;
        degree[j as usize] += 1;
        bonds.push([i, j]);
    };
    for &(s, e) in &runs {
        let here = &order[s..e];
        for (a, &(_, i)) in here.iter().enumerate() {
            for &(_, j) in here[a + 1..].iter().take(MAX_CANDIDATES_PER_CELL) {
                consider(i, j, &mut degree, &mut bonds);
            }
        }
        let k = here[0].0;
        for d in HALF_NEIGHBOURS {
            let nk = [
                k[0].saturating_add(d[0]),
                k[1].saturating_add(d[1]),
                k[2].saturating_add(d[2]),
            ];
            if nk == k {
                continue; // saturated at the edge of i64: the same cell
            }
            let Some((ns, ne)) = cells.get(nk) else {
                continue;
            };
            for &(_, i) in here {
                for &(_, j) in order[ns..ne].iter().take(MAX_CANDIDATES_PER_CELL) {
                    consider(i, j, &mut degree, &mut bonds);
                }
            }
        }
    }
    bonds.sort_unstable();
    bonds.dedup();
    bonds
}
