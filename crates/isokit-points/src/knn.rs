//! Nearest samples: a thin wrapper around kiddo's `ImmutableKdTree` over f64 points.

use crate::PointsError;
use glam::{DVec3, Vec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use std::num::NonZero;

/// A static kd-tree over the samples, answering k-nearest queries in f64.
pub struct Knn {
    tree: ImmutableKdTree<f64, 3>,
    len: usize,
}

impl std::fmt::Debug for Knn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Knn").field("len", &self.len).finish()
    }
}

impl Knn {
    /// Builds the tree. The points must be finite (checked by the callers) and fewer than
    /// 2^32.
    pub fn new(points: &[Vec3]) -> Result<Self, PointsError> {
        if points.is_empty() {
            return Err(PointsError::Empty);
        }
        if points.len() > u32::MAX as usize {
            return Err(PointsError::Parameter(format!(
                "{} points exceed the 2^32 limit of the tree",
                points.len()
            )));
        }
        let entries: Vec<[f64; 3]> = points.iter().map(|p| p.as_dvec3().to_array()).collect();
        let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&entries)
            .map_err(|e| PointsError::Tree(format!("{e:?}")))?;
        Ok(Self {
            tree,
            len: points.len(),
        })
    }

    /// Number of samples in the tree.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when the tree holds no samples (never, by construction).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The `k` nearest samples of `p` (fewer when the tree holds fewer), as (index, squared
    /// distance) sorted by distance, written into `out`.
    pub fn nearest(&self, p: DVec3, k: usize, out: &mut Vec<(usize, f64)>) {
        out.clear();
        let Some(k) = NonZero::new(k.min(self.len)) else {
            return;
        };
        let res = self
            .tree
            .query(&p.to_array())
            .nearest_n::<SquaredEuclidean<f64>>(k)
            .execute();
        out.extend(res.into_iter().map(|r| (r.item as usize, r.distance)));
    }

    /// The nearest sample of `p`: (index, squared distance).
    pub fn nearest_one(&self, p: DVec3) -> (usize, f64) {
        let r = self
            .tree
            .query(&p.to_array())
            .nearest_one::<SquaredEuclidean<f64>>()
            .execute();
        (r.item as usize, r.distance)
    }

    /// All samples within distance `sqrt(r2)` of `p` (unsorted), as (index, squared distance).
    pub fn within(&self, p: DVec3, r2: f64, out: &mut Vec<(usize, f64)>) {
        out.clear();
        let res = self
            .tree
            .query(&p.to_array())
            .within::<SquaredEuclidean<f64>>(r2)
            .unsorted()
            .execute();
        out.extend(res.into_iter().map(|r| (r.item as usize, r.distance)));
    }
}
