//! Compilation of the modeling vocabulary: profiles and their operations (extrude,
//! revolve), mirror, orient and affine maps, repetition, deformations, round and onion,
//! chamfer and stairs blends. Each node checks its parameters (naming the node path and the
//! key), the dimension of its children (profiles only where a profile is meant) and hashes
//! its content.

use crate::SceneError;
use crate::node::{
    AffineNode, ArrayNode, BendNode, CircularArrayNode, ElongateNode, ExtrudeNode, MirrorNode,
    Node, OrientNode, RepeatNode, RevolveNode, TaperNode, TwistNode,
};
use crate::scene::{Builder, Compiled, Dim, f32_bits, hash_of};
use glam::{DMat3, DQuat, DVec3, Vec3};
use isokit_field::Field;
use isokit_field::transform::{Affine, Transformed};
use isokit_levelset::csg::{Blend, SmoothKind};
use isokit_levelset::deform::{Bend, Elongate, Taper, Twist};
use isokit_levelset::profile::{Extrude, Revolve};
use isokit_levelset::repeat::{CircularArray, Repeat};
use std::hash::Hash;
use std::sync::Arc;

fn finite3(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl Builder<'_> {
    /// Compiles `node` when it belongs to the modeling vocabulary (`None` otherwise).
    pub(crate) fn compile_vocabulary(
        &mut self,
        node: &Node,
        path: &str,
    ) -> Result<Option<Compiled>, SceneError> {
        if let Some(p) = node.profile() {
            let prof = p.build().map_err(|e| self.err(path, e.to_string()))?;
            let hash = hash_of(|h| {
                node.kind().hash(h);
                f32_bits(h, &p.numbers());
            });
            let field = self.counted(path.to_owned(), node.kind(), None, prof);
            return Ok(Some(Compiled {
                field: Arc::from(field),
                hash,
                dim: Dim::Two,
            }));
        }
        Ok(Some(match node {
            Node::Extrude(n) => self.extrude(n, path)?,
            Node::Revolve(n) => self.revolve(n, path)?,
            Node::Mirror(n) => self.mirror(n, path)?,
            Node::Orient(n) => self.orient(n, path)?,
            Node::Affine(n) => self.affine(n, path)?,
            Node::Repeat(n) => self.repeat(n, path)?,
            Node::Array(n) => self.array(n, path)?,
            Node::CircularArray(n) => self.circular_array(n, path)?,
            Node::Twist(n) => self.twist(n, path)?,
            Node::Bend(n) => self.bend(n, path)?,
            Node::Taper(n) => self.taper(n, path)?,
            Node::Elongate(n) => self.elongate(n, path)?,
            Node::Round(n) => self.offset(n.radius, &n.of, path, "radius")?,
            Node::Onion(n) => self.shell(n.thickness, &n.of, path)?,
            Node::ChamferUnion(s) => {
                self.blended(SmoothKind::Union, Blend::Chamfer, s.radius, &s.of, path)?
            }
            Node::ChamferIntersection(s) => self.blended(
                SmoothKind::Intersection,
                Blend::Chamfer,
                s.radius,
                &s.of,
                path,
            )?,
            Node::ChamferDifference(s) => self.blended(
                SmoothKind::Difference,
                Blend::Chamfer,
                s.radius,
                &s.of,
                path,
            )?,
            Node::StairsUnion(s) => self.blended(
                SmoothKind::Union,
                Blend::Stairs(s.steps),
                s.radius,
                &s.of,
                path,
            )?,
            Node::StairsIntersection(s) => self.blended(
                SmoothKind::Intersection,
                Blend::Stairs(s.steps),
                s.radius,
                &s.of,
                path,
            )?,
            Node::StairsDifference(s) => self.blended(
                SmoothKind::Difference,
                Blend::Stairs(s.steps),
                s.radius,
                &s.of,
                path,
            )?,
            _ => return Ok(None),
        }))
    }

    /// The child of a profile operation: compiled, and a profile.
    fn profile_child(&mut self, of: &Node, path: &str, op: &str) -> Result<Compiled, SceneError> {
        let c = self.compile(of, &format!("{path}.of"))?;
        if c.dim != Dim::Two {
            return Err(self.err(
                &format!("{path}.of"),
                format!(
                    "{op} needs a 2D profile (circle, rectangle, polygon, … and their CSG), not a \
                     3D shape"
                ),
            ));
        }
        Ok(c)
    }

    /// The child of a 3D-only operation (deformations): compiled below a warp, a solid.
    fn solid_child(&mut self, of: &Node, path: &str, op: &str) -> Result<Compiled, SceneError> {
        let c = self.compile_warped(of, path)?;
        if c.dim != Dim::Three {
            return Err(self.err(
                &format!("{path}.of"),
                format!("{op} needs a 3D shape: extrude or revolve the profile first"),
            ));
        }
        Ok(c)
    }

    fn hashed(kind: &str, params: &[f32], ints: &[u32], child: &Compiled) -> u64 {
        hash_of(|h| {
            kind.hash(h);
            f32_bits(h, params);
            ints.hash(h);
            child.hash.hash(h);
        })
    }

    fn extrude(&mut self, n: &ExtrudeNode, path: &str) -> Result<Compiled, SceneError> {
        if !(n.height.is_finite() && n.height > 0.0) {
            return Err(self.err(
                &format!("{path}.height"),
                format!("{} must be finite and > 0", n.height),
            ));
        }
        if !(n.round.is_finite() && n.round >= 0.0 && n.round <= 0.5 * n.height) {
            return Err(self.err(
                &format!("{path}.round"),
                format!("{} must be finite, ≥ 0 and at most height/2", n.round),
            ));
        }
        let c = self.profile_child(&n.of, path, "extrude")?;
        let hash = Self::hashed("extrude", &[n.height, n.round], &[], &c);
        let field =
            Extrude::new(c.field, n.height, n.round).map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled::solid(Box::new(field), hash))
    }

    fn revolve(&mut self, n: &RevolveNode, path: &str) -> Result<Compiled, SceneError> {
        if !n.offset.is_finite() {
            return Err(self.err(
                &format!("{path}.offset"),
                format!("{} must be finite", n.offset),
            ));
        }
        let c = self.profile_child(&n.of, path, "revolve")?;
        if let Some(y) = axis_seam(&*c.field, -n.offset) {
            return Err(self.err(
                &format!("{path}.of"),
                format!(
                    "the profile's boundary runs along the axis (x = {}) near y = {y}: revolved, \
                     the axis would be a seam of zeros inside the solid; draw the profile \
                     across the axis (to x < {})",
                    -n.offset, -n.offset
                ),
            ));
        }
        let hash = Self::hashed("revolve", &[n.offset], &[], &c);
        let field = Revolve::new(c.field, n.offset).map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled::solid(Box::new(field), hash))
    }

    fn mirror(&mut self, n: &MirrorNode, path: &str) -> Result<Compiled, SceneError> {
        let normal = Vec3::from(n.normal);
        if !(normal.is_finite() && normal != Vec3::ZERO && n.offset.is_finite()) {
            return Err(self.err(
                &format!("{path}.normal"),
                "the normal must be finite and nonzero, the offset finite",
            ));
        }
        let c = self.compile_warped(&n.of, path)?;
        if c.dim == Dim::Two && normal.z != 0.0 {
            return Err(self.err(
                &format!("{path}.normal"),
                "a 2D profile mirrors in planes through the z axis only (normal z = 0)",
            ));
        }
        let hash = Self::hashed("mirror", &[normal.x, normal.y, normal.z, n.offset], &[], &c);
        let dim = c.dim;
        let field =
            Affine::mirror(c.field, normal, n.offset).map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled {
            field: Arc::new(field),
            hash,
            dim,
        })
    }

    fn orient(&mut self, n: &OrientNode, path: &str) -> Result<Compiled, SceneError> {
        let axis = DVec3::from(Vec3::from(n.axis));
        let m = axis.abs().max_element();
        if !(m > 0.0 && m.is_finite()) {
            return Err(self.err(&format!("{path}.axis"), "must be finite and nonzero"));
        }
        // The shortest rotation taking +z to the axis.
        let q = DQuat::from_rotation_arc(DVec3::Z, (axis / m).normalize());
        let (ax, angle) = q.to_axis_angle();
        let c = self.compile_warped(&n.of, path)?;
        if c.dim == Dim::Two {
            return Err(self.err(
                path,
                "orient turns a solid: extrude or revolve the profile first",
            ));
        }
        let hash = Self::hashed("orient", &n.axis, &[], &c);
        let field = Transformed::new(c.field)
            .rotate_axis_degrees(ax.as_vec3(), angle.to_degrees() as f32)
            .map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled::solid(Box::new(field), hash))
    }

    fn affine(&mut self, n: &AffineNode, path: &str) -> Result<Compiled, SceneError> {
        if !n.matrix.iter().all(|r| r.iter().all(|x| x.is_finite())) {
            return Err(self.err(&format!("{path}.matrix"), "must be finite"));
        }
        let r = n.matrix.map(|row| row.map(f64::from));
        let mut m = DMat3::from_cols(
            DVec3::new(r[0][0], r[1][0], r[2][0]),
            DVec3::new(r[0][1], r[1][1], r[2][1]),
            DVec3::new(r[0][2], r[1][2], r[2][2]),
        );
        let t = DVec3::new(r[0][3], r[1][3], r[2][3]);
        let c = self.compile_warped(&n.of, path)?;
        if c.dim == Dim::Two {
            if r[0][2] != 0.0 || r[1][2] != 0.0 || r[2][0] != 0.0 || r[2][1] != 0.0 {
                return Err(self.err(
                    &format!("{path}.matrix"),
                    "a 2D profile maps by matrices that keep z apart (zeros in the third row \
                     and column but the diagonal)",
                ));
            }
            // z is immaterial to a profile: give it the xy part's smallest stretch.
            let xy = glam::DMat2::from_cols(m.x_axis.truncate(), m.y_axis.truncate());
            let e = (xy.transpose() * xy).to_cols_array();
            let (tr, det) = (e[0] + e[3], e[0] * e[3] - e[1] * e[2]);
            let lmin = 0.5 * (tr - (tr * tr - 4.0 * det).max(0.0).sqrt());
            m.z_axis = DVec3::new(0.0, 0.0, lmin.max(0.0).sqrt());
        }
        let flat: Vec<f32> = n.matrix.iter().flatten().copied().collect();
        let hash = Self::hashed("affine", &flat, &[], &c);
        let dim = c.dim;
        let field = Affine::new(c.field, m, t).map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled {
            field: Arc::new(field),
            hash,
            dim,
        })
    }

    fn repeat(&mut self, n: &RepeatNode, path: &str) -> Result<Compiled, SceneError> {
        if !(finite3(n.period)
            && n.period.iter().all(|&x| x >= 0.0)
            && n.period.iter().any(|&x| x > 0.0))
        {
            return Err(self.err(
                &format!("{path}.period"),
                format!(
                    "{:?}: each period must be finite and ≥ 0 (0 leaves the axis alone), one > 0",
                    n.period
                ),
            ));
        }
        let c = self.compile_warped(&n.of, path)?;
        if c.dim == Dim::Two && n.period[2] != 0.0 {
            return Err(self.err(
                &format!("{path}.period"),
                "a 2D profile repeats in the xy-plane only (period z = 0)",
            ));
        }
        let hash = Self::hashed("repeat", &n.period, &[], &c);
        let dim = c.dim;
        let field = Repeat::infinite(c.field, Vec3::from(n.period))
            .map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled {
            field: Arc::new(field),
            hash,
            dim,
        })
    }

    fn array(&mut self, n: &ArrayNode, path: &str) -> Result<Compiled, SceneError> {
        if !finite3(n.spacing) {
            return Err(self.err(&format!("{path}.spacing"), "must be finite"));
        }
        if n.count.contains(&0) {
            return Err(self.err(&format!("{path}.count"), "each count must be at least 1"));
        }
        let c = self.compile_warped(&n.of, path)?;
        if c.dim == Dim::Two && n.count[2] != 1 {
            return Err(self.err(
                &format!("{path}.count"),
                "a 2D profile repeats in the xy-plane only (count z = 1)",
            ));
        }
        let hash = Self::hashed("array", &n.spacing, &n.count, &c);
        let dim = c.dim;
        let field = Repeat::array(c.field, n.count, Vec3::from(n.spacing))
            .map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled {
            field: Arc::new(field),
            hash,
            dim,
        })
    }

    fn circular_array(
        &mut self,
        n: &CircularArrayNode,
        path: &str,
    ) -> Result<Compiled, SceneError> {
        if !(1..=isokit_levelset::repeat::MAX_RING).contains(&n.count) {
            return Err(self.err(
                &format!("{path}.count"),
                format!("{} must be 1 to 65536", n.count),
            ));
        }
        let axis = Vec3::from(n.axis);
        if !(axis.is_finite() && axis != Vec3::ZERO) {
            return Err(self.err(&format!("{path}.axis"), "must be finite and nonzero"));
        }
        let c = self.compile_warped(&n.of, path)?;
        if c.dim == Dim::Two && (axis.x != 0.0 || axis.y != 0.0) {
            return Err(self.err(
                &format!("{path}.axis"),
                "a 2D profile turns about the z axis only",
            ));
        }
        let hash = Self::hashed("circular_array", &n.axis, &[n.count], &c);
        let dim = c.dim;
        let field = CircularArray::new(c.field, n.count, axis)
            .map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled {
            field: Arc::new(field),
            hash,
            dim,
        })
    }

    fn rate(&self, rate: f32, path: &str) -> Result<f32, SceneError> {
        if rate.is_finite() {
            Ok(rate.to_radians())
        } else {
            Err(self.err(&format!("{path}.rate"), format!("{rate} must be finite")))
        }
    }

    fn twist(&mut self, n: &TwistNode, path: &str) -> Result<Compiled, SceneError> {
        let rate = self.rate(n.rate, path)?;
        let c = self.solid_child(&n.of, path, "twist")?;
        let hash = Self::hashed("twist", &[n.rate, n.axis[0], n.axis[1], n.axis[2]], &[], &c);
        let field = Twist::new(c.field, rate, Vec3::from(n.axis))
            .map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled::solid(Box::new(field), hash))
    }

    fn bend(&mut self, n: &BendNode, path: &str) -> Result<Compiled, SceneError> {
        let rate = self.rate(n.rate, path)?;
        let c = self.solid_child(&n.of, path, "bend")?;
        let hash = Self::hashed("bend", &[n.rate], &[], &c);
        let field = Bend::new(c.field, rate).map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled::solid(Box::new(field), hash))
    }

    fn taper(&mut self, n: &TaperNode, path: &str) -> Result<Compiled, SceneError> {
        if !n.rate.is_finite() {
            return Err(self.err(
                &format!("{path}.rate"),
                format!("{} must be finite", n.rate),
            ));
        }
        let c = self.solid_child(&n.of, path, "taper")?;
        let hash = Self::hashed("taper", &[n.rate, n.axis[0], n.axis[1], n.axis[2]], &[], &c);
        let field = Taper::new(c.field, n.rate, Vec3::from(n.axis))
            .map_err(|e| self.err(path, e.to_string()))?;
        Ok(Compiled::solid(Box::new(field), hash))
    }

    fn elongate(&mut self, n: &ElongateNode, path: &str) -> Result<Compiled, SceneError> {
        if !(finite3(n.by) && n.by.iter().all(|&x| x >= 0.0)) {
            return Err(self.err(
                &format!("{path}.by"),
                format!("{:?}: each component must be finite and ≥ 0", n.by),
            ));
        }
        let c = self.compile_warped(&n.of, path)?;
        let by = if c.dim == Dim::Two {
            [n.by[0], n.by[1], 0.0]
        } else {
            n.by
        };
        let hash = Self::hashed("elongate", &by, &[], &c);
        let dim = c.dim;
        let field: Box<dyn Field> = Box::new(
            Elongate::new(c.field, Vec3::from(by)).map_err(|e| self.err(path, e.to_string()))?,
        );
        Ok(Compiled {
            field: Arc::from(field),
            hash,
            dim,
        })
    }
}

/// Where a profile's boundary runs along the line `x = x0` (the revolve axis), a `y` on it.
///
/// `opRevolution` (Quilez) evaluates the profile at `(ρ − offset, z)`, `ρ ≥ 0`: the meridian
/// half-plane. An edge of the profile on its border `x = x0` is no surface of the solid, yet
/// the profile's distance is `−(x − x0)` beside it and 0 on it, so the axis becomes a seam of
/// zeros that meshers and ray casters take for surface. Probed on 257 heights over the
/// profile's bounds: a seam is two neighbouring heights where the value is 0 on the line and
/// falls by the full step `δ` just inside it (the slope of a distance to that line); a
/// boundary that only crosses or touches the line matches at one height at most.
fn axis_seam(profile: &dyn Field, x0: f32) -> Option<f32> {
    let b = profile.bounds();
    if !(b.min.x.is_finite() && b.max.x.is_finite() && b.min.y.is_finite() && b.max.y.is_finite())
        || b.max.x <= x0
        || b.min.x > x0
    {
        return None;
    }
    let extent = (b.max.x - b.min.x).max(b.max.y - b.min.y);
    let delta = (1e-3 * extent).max(8.0 * f32::EPSILON * x0.abs());
    let n = 256;
    let mut previous = false;
    for i in 0..=n {
        let y = b.min.y + (b.max.y - b.min.y) * i as f32 / n as f32;
        let on = profile.value(Vec3::new(x0, y, 0.0));
        let inside = profile.value(Vec3::new(x0 + delta, y, 0.0));
        let seam = on.abs() <= 0.01 * delta && inside <= -0.9 * delta;
        if seam && previous {
            return Some(y);
        }
        previous = seam;
    }
    None
}
