//! Quadric surfaces for splatting (002 Ch. 7): conic matrices, parameter space, tight
//! perspective bounding boxes and per-pixel ray–quadric intersection.
//!
//! ## Representation (002 Sec. 7.2.1–7.2.2)
//! A quadric is the zero set of `xᵀ Q x` (Eq. 7.2, `x` homogeneous) with `Q` a symmetric
//! 4x4 *conic matrix*. Every quadric isokit splats is an affine image of a normalized one:
//! `Q = T⁻ᵀ D T⁻¹` (Eq. 7.4) with `D` diagonal with entries in {0, ±1} and
//! `T = [u v t c; 0 0 0 1]` (Eq. 7.5, the *variance matrix*: axes and centre in world
//! coordinates). In parameter space (`x_p = T⁻¹ x`) the classes are
//!
//! | kind | `D` | solid in parameter space |
//! | --- | --- | --- |
//! | ellipsoid (sphere) | `diag(1, 1, 1, −1)` | `x² + y² + z² ≤ 1` |
//! | cylinder | `diag(1, 1, 0, −1)` | `x² + y² ≤ 1`, `−1 ≤ z ≤ 1` |
//! | cone (or frustum) | `diag(1, 1, −1, 0)` | `x² + y² ≤ z²`, `z_lo ≤ z ≤ 1`, `0 ≤ z_lo < 1` |
//!
//! Cylinders and cones are clipped by the slab of the unit cube in parameter space (002
//! Sec. 7.2.3) and closed by flat caps, so that every splatted quadric is a convex solid
//! (002 leaves them open; a closed solid is what intersects other solids correctly in the
//! depth buffer). Inside is `xᵀQx ≤ 0` (negative inside, as everywhere in isokit).
//!
//! General input: [`Quadric::from_conic`] diagonalizes the upper 3x3 block of any symmetric
//! `Q` with nalgebra's symmetric eigen-decomposition and recognizes ellipsoids, elliptic
//! cylinders and elliptic cones (the others, hyperboloids and paraboloids, are refused).
//!
//! ## Set-up (host, f64) and per-pixel work (f32, both twins)
//! [`Quadric::setup`] computes, per quadric and view, in f64 (cancellation bites in the
//! bounding box of a quadric far from the eye, and WGSL has no f64): the screen bounding
//! box and the f32 data of [`QuadricSetup`] that the per-pixel function
//! [`intersect`] reads. [`intersect`] is written over plain f32 arithmetic the way its
//! WGSL twin (`shaders/splat.wgsl`) is written.
//!
//! ### Bounding boxes (Eq. 7.9, extended to the near plane)
//! With `P` the map from world to *pixel* homogeneous coordinates (`X/W`, `Y/W` are pixel
//! coordinates, top-left origin; `N` is the depth along the view direction; `W = N` for
//! perspective, 1 for orthographic), let `r1, r2, rN, r4` be the rows of `P·T` (the rows
//! of Eq. 7.8 in parameter space). The visible part of the solid is its part with
//! `N ≥ near`. The extreme `X/W` over that part is attained at one of:
//! 1. a silhouette point of the ellipsoid: `b` a root of
//!    `(r4ᵀD r4) b² − 2 (r1ᵀD r4) b + r1ᵀD r1 = 0` (Eq. 7.9), the tangent point being the
//!    pole `D (r1 − b r4)`; kept if that point has `N ≥ near`;
//! 2. a point of a cap's rim (cylinders and cones: their extremes lie on the caps, 002
//!    Sec. 7.2.3, because `X/W` is monotone along every ruling), kept where `N ≥ near`,
//!    and the rim's points at `N = near` (ends of the visible arcs); a cone's apex;
//! 3. an extreme of the section of the surface by the near plane (within the slab).
//!
//! Every curve in 2 and 3 is a homogeneous trigonometric curve `P0 + P1 cos θ + P2 sin θ`
//! in parameter space, so its extremes of `X/W` are closed-form (`extremes_on_curve`).
//! Perspective boxes of quadrics that cross the near plane or reach behind the eye are
//! therefore tight, not just conservative.
//!
//! ### Intersection (Eq. 7.12–7.13, 7.15)
//! The pixel's ray `o + t d` (t in world units along the unit direction) is mapped to
//! parameter space, `a + t b` (Eq. 7.12 with the ray origin instead of the near-plane
//! point), and the quadratic `(bᵀDb) t² + 2 (aᵀDb) t + aᵀDa = 0` (Eq. 7.13) solved with
//! `a` first moved to the point of the ray nearest to the quadric's centre in parameter
//! space, which keeps the discriminant accurate for a quadric far from the eye. The solid's
//! interval along the ray is intersected with the slab; its entry is the hit. If the entry
//! lies before the near plane and the exit after it, the near plane cuts the solid and the
//! pixel shows the cut ([`HitKind::NearCut`], normal −forward). The normal is `T⁻ᵀ D x_p`
//! (Eq. 7.15) and the principal curvatures come from the world gradient and the constant
//! Hessian `2 T⁻¹ᵀ D T⁻¹` of `xᵀQx`.

use glam::{DMat3, DMat4, DVec3, DVec4, Mat3, Vec3};

use crate::RenderError;

/// The class of a quadric ([`Quadric::kind`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum QuadricKind {
    /// Ellipsoid (spheres included): `D = diag(1, 1, 1, −1)`.
    Ellipsoid,
    /// Elliptic cylinder clipped to `|z| ≤ 1`, closed by caps: `D = diag(1, 1, 0, −1)`.
    Cylinder,
    /// Elliptic cone with apex at the parameter origin clipped to `z_lo ≤ z ≤ 1`, closed by
    /// caps: `D = diag(1, 1, −1, 0)`.
    Cone,
}

impl QuadricKind {
    /// The GPU code of the kind (`kind` in [`QuadricSetup`]).
    pub fn code(self) -> u32 {
        match self {
            Self::Ellipsoid => 0,
            Self::Cylinder => 1,
            Self::Cone => 2,
        }
    }
    /// The normalized diagonal `D` (Eq. 7.4).
    pub fn diag(self) -> [f64; 4] {
        match self {
            Self::Ellipsoid => [1.0, 1.0, 1.0, -1.0],
            Self::Cylinder => [1.0, 1.0, 0.0, -1.0],
            Self::Cone => [1.0, 1.0, -1.0, 0.0],
        }
    }
}

/// A quadric solid: a normalized class in parameter space and the affine map `T` from
/// parameter space to world space (Eq. 7.5).
///
/// ```
/// use isokit_render::quadric::{Quadric, QuadricKind};
/// use glam::DVec3;
/// let s = Quadric::sphere(DVec3::new(1.0, 0.0, 0.0), 2.0).unwrap();
/// assert_eq!(s.kind(), QuadricKind::Ellipsoid);
/// // xᵀQx is negative inside, zero on the surface.
/// assert!(s.eval(DVec3::new(1.0, 0.0, 0.0)) < 0.0);
/// assert!(s.eval(DVec3::new(3.0, 0.0, 0.0)).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quadric {
    kind: QuadricKind,
    t: DMat4,
    t_inv: DMat4,
    z_lo: f64,
}

/// Largest ratio of a quadric's longest to shortest axis that is accepted (beyond it the
/// f32 per-pixel work loses all precision).
pub const MAX_AXIS_RATIO: f64 = 1e6;

fn finite3(v: DVec3) -> bool {
    v.is_finite()
}

impl Quadric {
    /// The quadric with parameter-to-world map `T` given by its columns (axes `u, v, t` and
    /// centre `c`). Errors when a value is not finite, the axes are (nearly) dependent or
    /// their lengths differ by more than [`MAX_AXIS_RATIO`], or `z_lo` is outside `[0, 1)`
    /// for a cone (ignored otherwise).
    pub fn from_axes(
        kind: QuadricKind,
        u: DVec3,
        v: DVec3,
        t: DVec3,
        c: DVec3,
        z_lo: f64,
    ) -> Result<Self, RenderError> {
        if !(finite3(u) && finite3(v) && finite3(t) && finite3(c) && z_lo.is_finite()) {
            return Err(RenderError::bad(
                "quadric",
                format!("axes {u} {v} {t}, centre {c}"),
                "must be finite",
            ));
        }
        let lens = [u.length(), v.length(), t.length()];
        let lmax = lens.iter().cloned().fold(0.0, f64::max);
        let lmin = lens.iter().cloned().fold(f64::INFINITY, f64::min);
        let det = DMat3::from_cols(u, v, t).determinant();
        if !(lmin > 0.0 && lmax / lmin <= MAX_AXIS_RATIO)
            || det.abs() <= lens[0] * lens[1] * lens[2] / MAX_AXIS_RATIO
        {
            return Err(RenderError::bad(
                "quadric",
                format!("axes {u} {v} {t}"),
                "axes must be nonzero, within a ratio of 1e6 in length, and not nearly dependent (|det| above 1e-6 of the product of their lengths)",
            ));
        }
        if kind == QuadricKind::Cone && !(0.0..1.0).contains(&z_lo) {
            return Err(RenderError::bad(
                "cone",
                z_lo,
                "the small radius must be smaller than the large one",
            ));
        }
        let t_mat = DMat4::from_cols(u.extend(0.0), v.extend(0.0), t.extend(0.0), c.extend(1.0));
        Ok(Self {
            kind,
            t: t_mat,
            t_inv: t_mat.inverse(),
            z_lo: if kind == QuadricKind::Cone {
                z_lo
            } else {
                -1.0
            },
        })
    }

    /// A sphere. Errors when the radius is not finite and positive.
    pub fn sphere(center: DVec3, radius: f64) -> Result<Self, RenderError> {
        positive("sphere radius", radius)?;
        Self::ellipsoid(center, DVec3::splat(radius), DMat3::IDENTITY)
    }

    /// An ellipsoid with semi-axes `radii` along the columns of `rotation` (orthonormal).
    pub fn ellipsoid(center: DVec3, radii: DVec3, rotation: DMat3) -> Result<Self, RenderError> {
        Self::from_axes(
            QuadricKind::Ellipsoid,
            rotation.x_axis * radii.x,
            rotation.y_axis * radii.y,
            rotation.z_axis * radii.z,
            center,
            -1.0,
        )
    }

    /// A solid circular cylinder from `p0` to `p1` of radius `radius`, closed by caps.
    pub fn cylinder(p0: DVec3, p1: DVec3, radius: f64) -> Result<Self, RenderError> {
        positive("cylinder radius", radius)?;
        let (u, v, axis) = frame(p0, p1)?;
        Self::from_axes(
            QuadricKind::Cylinder,
            u * radius,
            v * radius,
            0.5 * axis,
            0.5 * (p0 + p1),
            -1.0,
        )
    }

    /// A solid circular cone frustum with radius `r0` at `p0` and `r1` at `p1` (a pointed
    /// cone when one radius is 0), closed by caps. Equal radii give a cylinder.
    pub fn cone(p0: DVec3, r0: f64, p1: DVec3, r1: f64) -> Result<Self, RenderError> {
        if !(r0.is_finite() && r1.is_finite() && r0 >= 0.0 && r1 >= 0.0 && r0.max(r1) > 0.0) {
            return Err(RenderError::bad(
                "cone radii",
                format!("{r0}, {r1}"),
                "must be finite, non-negative and not both zero",
            ));
        }
        // Large end at parameter z = 1.
        let (a, ra, b, rb) = if r1 >= r0 {
            (p0, r0, p1, r1)
        } else {
            (p1, r1, p0, r0)
        };
        // A frustum whose apex lies beyond the axis-ratio limit is a cylinder to f32
        // precision: the mean radius, not a refusal.
        let len = (b - a).length();
        if (rb - ra) * MAX_AXIS_RATIO <= 2.0 * len.max(rb) || (ra - rb).abs() <= 1e-12 * rb {
            return Self::cylinder(a, b, 0.5 * (ra + rb));
        }
        let (u, v, axis) = frame(a, b)?;
        let z_lo = ra / rb;
        // The apex lies where the radius would be 0: z = 0 at apex, z = 1 at `b`.
        let t = axis / (1.0 - z_lo);
        let apex = b - t;
        Self::from_axes(QuadricKind::Cone, u * rb, v * rb, t, apex, z_lo)
    }

    /// The quadric `xᵀ Q x ≤ 0` of a symmetric conic matrix `Q` (Eq. 7.2; row-major, only
    /// the upper triangle is read), clipped for cylinders and cones to the part of their
    /// axis between the projections of the two points `clip` (for a cone, both on one side
    /// of the apex).
    ///
    /// The upper 3x3 block `A` is diagonalized with nalgebra (`A = R Λ Rᵀ`); with centre
    /// `c` solving `A c = −b` the form becomes `Σ λᵢ yᵢ² + k` and the class follows from
    /// the signs of `λᵢ` and `k`: ellipsoid (all `λᵢ` one sign, `k` the other), elliptic
    /// cylinder (one `λᵢ` zero, the others and `−k` one sign), elliptic cone (`k = 0`, two
    /// `λᵢ` of one sign). Errors for the other classes, and when a clip range is missing.
    pub fn from_conic(q: [[f64; 4]; 4], clip: Option<(DVec3, DVec3)>) -> Result<Self, RenderError> {
        if q.iter().flatten().any(|v| !v.is_finite()) {
            return Err(RenderError::bad(
                "conic matrix",
                format!("{q:?}"),
                "must be finite",
            ));
        }
        let a = nalgebra::Matrix3::from_fn(|i, j| q[i.min(j)][i.max(j)]);
        let b = DVec3::new(q[0][3], q[1][3], q[2][3]);
        let j = q[3][3];
        // Scale by the quadratic part alone: the linear and constant terms grow with the
        // distance of the centre from the origin and must not decide what counts as zero.
        let scale = a.abs().max();
        if scale == 0.0 || !scale.is_finite() {
            return Err(RenderError::bad(
                "conic matrix",
                format!("{q:?}"),
                "has no quadratic part (a plane), or it overflows",
            ));
        }
        let eig = nalgebra::SymmetricEigen::new(a / scale);
        let (b, j) = (b / scale, j / scale);
        // Eigenvalues below this (relative to the largest, 1 after scaling) count as zero.
        let tol = 1e-9;
        let lam: [f64; 3] = [eig.eigenvalues[0], eig.eigenvalues[1], eig.eigenvalues[2]];
        let col = |i: usize| {
            let c = eig.eigenvectors.column(i);
            DVec3::new(c[0], c[1], c[2])
        };
        let unsupported = |why| Err(RenderError::bad("conic matrix", format!("{q:?}"), why));
        let lmax = lam.iter().map(|l| l.abs()).fold(0.0, f64::max);
        let zero: Vec<usize> = (0..3).filter(|&i| lam[i].abs() <= tol * lmax).collect();
        // Centre: least-squares solution of A c = −b in the eigenbasis; b must lie in the
        // range of A (else a paraboloid).
        let mut c = DVec3::ZERO;
        for (i, &l) in lam.iter().enumerate() {
            let bi = col(i).dot(b);
            if zero.contains(&i) {
                if bi.abs() > tol * (b.length() + lmax) {
                    return unsupported("a paraboloid (not splatted)");
                }
            } else {
                c -= col(i) * (bi / l);
            }
        }
        // Form: Σ λᵢ yᵢ² + k with k = j − cᵀ A c = j + b·c; k is zero (a cone) relative to
        // the terms that cancel in it.
        let k = j + b.dot(c);
        let k_zero = k.abs() <= 1e-13 * (j.abs() + b.dot(c).abs());
        let nonzero: Vec<usize> = (0..3).filter(|i| !zero.contains(i)).collect();
        let axis = |i: usize, l: f64, k: f64| col(i) * (k / l).abs().sqrt();
        match (zero.len(), k_zero) {
            (0, false) => {
                // Ellipsoid: every λ has the sign opposite to k.
                if lam.iter().any(|&l| l * k >= 0.0) {
                    return unsupported(
                        "not an ellipsoid, cylinder or cone (a hyperboloid or empty)",
                    );
                }
                let [u, v, t] = [0, 1, 2].map(|i| axis(i, lam[i], k));
                Self::from_axes(QuadricKind::Ellipsoid, u, v, t, c, -1.0)
            }
            (1, false) => {
                let (i0, i1) = (nonzero[0], nonzero[1]);
                if lam[i0] * k >= 0.0 || lam[i1] * k >= 0.0 {
                    return unsupported("not an elliptic cylinder (hyperbolic or empty)");
                }
                let dir = col(zero[0]);
                let Some((lo, hi)) = axis_range(clip, c, dir).filter(|(l, h)| h > l) else {
                    return Err(RenderError::bad(
                        "clip",
                        format!("{clip:?}"),
                        "a cylinder needs two finite points apart along its axis",
                    ));
                };
                let centre = c + dir * (0.5 * (lo + hi));
                Self::from_axes(
                    QuadricKind::Cylinder,
                    axis(i0, lam[i0], k),
                    axis(i1, lam[i1], k),
                    dir * (0.5 * (hi - lo)),
                    centre,
                    -1.0,
                )
            }
            (0, true) => {
                // Cone: two eigenvalues of one sign, the third of the other.
                let pos: Vec<usize> = (0..3).filter(|&i| lam[i] > 0.0).collect();
                let neg: Vec<usize> = (0..3).filter(|&i| lam[i] < 0.0).collect();
                let (pair, single) = match (pos.len(), neg.len()) {
                    (2, 1) => (pos, neg[0]),
                    (1, 2) => (neg, pos[0]),
                    _ => return unsupported("a point, not a cone"),
                };
                let dir0 = col(single);
                let Some((lo, hi)) =
                    axis_range(clip, c, dir0).filter(|(l, h)| h > l && (*l >= 0.0 || *h <= 0.0))
                else {
                    return Err(RenderError::bad(
                        "clip",
                        format!("{clip:?}"),
                        "a cone needs two finite points apart along its axis, on one side of the apex",
                    ));
                };
                // Radius per unit axis length: sqrt(|λ_axis / λ_i|).
                let (dir, near, far) = if lo >= 0.0 {
                    (dir0, lo, hi)
                } else {
                    (-dir0, -hi, -lo)
                };
                let s = far;
                let u = col(pair[0]) * (lam[single] / lam[pair[0]]).abs().sqrt() * s;
                let v = col(pair[1]) * (lam[single] / lam[pair[1]]).abs().sqrt() * s;
                Self::from_axes(QuadricKind::Cone, u, v, dir * s, c, near / far)
            }
            _ => unsupported("not an ellipsoid, cylinder or cone"),
        }
    }

    /// The class.
    pub fn kind(&self) -> QuadricKind {
        self.kind
    }
    /// The parameter-to-world map `T` (Eq. 7.5).
    pub fn variance_matrix(&self) -> DMat4 {
        self.t
    }
    /// Lower clip of a cone in parameter `z` (the ratio of the small to the large radius);
    /// −1 for the other kinds.
    pub fn z_lo(&self) -> f64 {
        self.z_lo
    }
    /// Parameter-space slab `[z_lo, z_hi]` (infinite for ellipsoids).
    pub fn slab(&self) -> (f64, f64) {
        match self.kind {
            QuadricKind::Ellipsoid => (f64::NEG_INFINITY, f64::INFINITY),
            _ => (self.z_lo, 1.0),
        }
    }
    /// The world conic matrix `Q = T⁻ᵀ D T⁻¹` (Eq. 7.3–7.4).
    pub fn conic(&self) -> DMat4 {
        let d = self.kind.diag();
        self.t_inv.transpose() * DMat4::from_diagonal(DVec4::from_array(d)) * self.t_inv
    }
    /// `xᵀ Q x` at a world point (negative inside the unclipped quadric).
    pub fn eval(&self, p: DVec3) -> f64 {
        let x = self.t_inv * p.extend(1.0);
        let d = self.kind.diag();
        d[0] * x.x * x.x + d[1] * x.y * x.y + d[2] * x.z * x.z + d[3] * x.w * x.w
    }
    /// True when `p` lies in the clipped solid.
    pub fn contains(&self, p: DVec3) -> bool {
        let x = self.t_inv * p.extend(1.0);
        let (lo, hi) = self.slab();
        self.eval(p) <= 0.0 && x.z >= lo && x.z <= hi
    }
    /// A world-space box containing the clipped solid.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        // Extent along world axis e: max of e·(T x_p) over the solid.
        let c = self.t.w_axis.truncate();
        let cols = [
            self.t.x_axis.truncate(),
            self.t.y_axis.truncate(),
            self.t.z_axis.truncate(),
        ];
        let mut lo = DVec3::ZERO;
        let mut hi = DVec3::ZERO;
        for k in 0..3 {
            let (u, v, t) = (cols[0][k], cols[1][k], cols[2][k]);
            let (a, b) = match self.kind {
                QuadricKind::Ellipsoid => {
                    let r = (u * u + v * v + t * t).sqrt();
                    (c[k] - r, c[k] + r)
                }
                QuadricKind::Cylinder => {
                    let r = (u * u + v * v).sqrt();
                    (c[k] - t.abs() - r, c[k] + t.abs() + r)
                }
                QuadricKind::Cone => {
                    let r = (u * u + v * v).sqrt();
                    let e = [self.z_lo, 1.0].map(|z| (c[k] + z * t - z * r, c[k] + z * t + z * r));
                    (e[0].0.min(e[1].0), e[0].1.max(e[1].1))
                }
            };
            lo[k] = a;
            hi[k] = b;
        }
        (lo, hi)
    }
    /// The world Hessian of `xᵀQx`, `2 T⁻¹ᵀ D T⁻¹` (upper 3x3), constant.
    pub fn hessian(&self) -> DMat3 {
        let d = self.kind.diag();
        let l = DMat3::from_mat4(self.t_inv);
        2.0 * l.transpose() * DMat3::from_diagonal(DVec3::new(d[0], d[1], d[2])) * l
    }
}

/// The increasing range of the projections of the clip points on the axis `c + s dir`.
fn axis_range(clip: Option<(DVec3, DVec3)>, c: DVec3, dir: DVec3) -> Option<(f64, f64)> {
    let (p0, p1) = clip?;
    let (s0, s1) = (dir.dot(p0 - c), dir.dot(p1 - c));
    (s0.is_finite() && s1.is_finite()).then(|| (s0.min(s1), s0.max(s1)))
}

fn positive(name: &'static str, v: f64) -> Result<(), RenderError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(RenderError::bad(name, v, "must be finite and positive"))
    }
}

/// An orthonormal pair perpendicular to `p1 − p0`, and `p1 − p0`.
fn frame(p0: DVec3, p1: DVec3) -> Result<(DVec3, DVec3, DVec3), RenderError> {
    let axis = p1 - p0;
    if !(axis.is_finite() && axis.length() > 0.0) {
        return Err(RenderError::bad(
            "axis",
            format!("{p0} to {p1}"),
            "end points must be finite and distinct",
        ));
    }
    let n = axis.normalize();
    let u = n.any_orthonormal_vector();
    Ok((u, n.cross(u), axis))
}

/// The view a set-up is made for, in f64: the camera's frame and image, and the near plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Eye (perspective) or image-plane centre (orthographic).
    pub eye: DVec3,
    /// Unit right vector.
    pub right: DVec3,
    /// Unit up vector.
    pub up: DVec3,
    /// Unit viewing direction.
    pub forward: DVec3,
    /// Half the view height at unit distance (perspective) or in world units (orthographic).
    pub half_height: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// True for orthographic projection.
    pub ortho: bool,
    /// Near plane: distance along `forward` below which nothing is visible (> 0 for
    /// perspective).
    pub near: f64,
}

impl View {
    /// The view of ray-caster uniforms ([`crate::Uniforms`]) with a near plane.
    pub fn from_uniforms(u: &crate::Uniforms, near: f64) -> Self {
        let d = |a: [f32; 3]| DVec3::new(a[0].into(), a[1].into(), a[2].into());
        Self {
            eye: d(u.eye),
            right: d(u.right),
            up: d(u.up),
            forward: d(u.forward),
            half_height: u.half_height.into(),
            width: u.width,
            height: u.height,
            ortho: u.ortho != 0,
            near,
        }
    }

    /// The rows `(X, Y, N, W)` of the world-to-pixel homogeneous map: pixel coordinates are
    /// `X/W, Y/W` (top-left origin), `N` the depth along `forward`.
    pub fn pixel_rows(&self) -> [DVec4; 4] {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let aspect = w / h;
        let sx = w / (2.0 * self.half_height * aspect);
        let sy = h / (2.0 * self.half_height);
        let row = |v: DVec3| v.extend(-v.dot(self.eye));
        let n = row(self.forward);
        let xr = row(self.right) * sx;
        let yr = row(self.up) * -sy;
        if self.ortho {
            let one = DVec4::new(0.0, 0.0, 0.0, 1.0);
            [xr + one * (0.5 * w), yr + one * (0.5 * h), n, one]
        } else {
            [xr + n * (0.5 * w), yr + n * (0.5 * h), n, n]
        }
    }
}

/// What the per-pixel work of one quadric reads: `QuadricSetup` in `shaders/splat.wgsl`
/// (`#[repr(C)]`, 144 bytes, vec4 rows).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct QuadricSetup {
    /// Columns of the linear part of `T⁻¹` (world direction → parameter direction), w 0.
    pub inv: [[f32; 4]; 3],
    /// `T⁻¹` applied to the eye (perspective: every ray's origin), w = 1.
    pub eye_p: [f32; 4],
    /// The diagonal `D`.
    pub diag: [f32; 4],
    /// Upper triangle of the world Hessian `(xx, yy, zz, xy)`.
    pub hess_a: [f32; 4],
    /// Upper triangle of the world Hessian `(xz, yz, 0, 0)`.
    pub hess_b: [f32; 4],
    /// Screen box `(x_min, y_min, x_max, y_max)` in continuous pixel coordinates.
    pub bbox: [f32; 4],
    /// Parameter slab `z_lo`, `z_hi` (±3.4e38 for ellipsoids), then the kind code and the
    /// object index.
    pub clip: [f32; 2],
    /// [`QuadricKind::code`].
    pub kind: u32,
    /// Index of the quadric in its scene (the G-buffer's object index).
    pub object: u32,
}

// The WGSL twin, member by member (`QuadricSetup` in `shaders/splat.wgsl`; checked by the
// GPU host code's unit tests).
isokit_gpu::wgsl_layout!(QuadricSetup {
    inv: "array<vec4<f32>, 3>",
    eye_p: "vec4<f32>",
    diag: "vec4<f32>",
    hess_a: "vec4<f32>",
    hess_b: "vec4<f32>",
    bbox: "vec4<f32>",
    clip: "vec2<f32>",
    kind: "u32",
    object: "u32",
});

/// Which part of the solid a ray hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HitKind {
    /// The quadric surface.
    Surface,
    /// A flat cap: a cylinder's or cone's end.
    Cap,
    /// The cut of the solid by the near plane; the normal is left 0 for the caller to set
    /// (−forward: the cut faces the viewer).
    NearCut,
}

/// A ray's first visible point on a quadric solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadricHit {
    /// Distance along the (unit) ray from its origin, world units.
    pub t: f32,
    /// Unit outward normal (0 for [`HitKind::NearCut`]).
    pub normal: Vec3,
    /// World gradient of `xᵀQx` at a surface hit, `2 T⁻ᵀ D x_p` (0 for caps).
    pub gradient: Vec3,
    /// Surface or cap.
    pub kind: HitKind,
}

/// Solves `a t² + 2 b t + c = 0` stably: the real roots in increasing order (`None` when
/// there are none). A (near) linear equation gives its single root twice.
pub fn solve_quadratic(a: f32, b: f32, c: f32) -> Option<(f32, f32)> {
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let q = -(b + b.signum() * disc.sqrt());
    if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        let r = -c / (2.0 * b);
        return Some((r, r));
    }
    let r1 = q / a;
    let r2 = if q != 0.0 { c / q } else { r1 };
    Some((r1.min(r2), r1.max(r2)))
}

fn quad_form(d: [f32; 4], x: [f32; 4], y: [f32; 4]) -> f32 {
    d[0] * x[0] * y[0] + d[1] * x[1] * y[1] + d[2] * x[2] * y[2] + d[3] * x[3] * y[3]
}

/// The first visible point of a quadric solid along the ray `o + t d` of one pixel (`d`
/// unit world direction, `o` the ray's world origin), at or beyond `t_near`; `None` when
/// the ray misses the solid or sees only what lies before the near plane. f32 throughout,
/// mirrored by `intersect` in `shaders/splat.wgsl`.
///
/// `ortho_offset` is `o − eye` (zero for perspective rays, whose origin is the eye; the
/// set-up holds the eye in parameter space, rounded once from f64).
pub fn intersect(s: &QuadricSetup, ortho_offset: Vec3, d: Vec3, t_near: f32) -> Option<QuadricHit> {
    let m = |v: Vec3| -> [f32; 3] {
        [
            s.inv[0][0] * v.x + s.inv[1][0] * v.y + s.inv[2][0] * v.z,
            s.inv[0][1] * v.x + s.inv[1][1] * v.y + s.inv[2][1] * v.z,
            s.inv[0][2] * v.x + s.inv[1][2] * v.y + s.inv[2][2] * v.z,
        ]
    };
    let off = m(ortho_offset);
    let bd = m(d);
    let b = [bd[0], bd[1], bd[2], 0.0];
    let mut a = [
        s.eye_p[0] + off[0],
        s.eye_p[1] + off[1],
        s.eye_p[2] + off[2],
        1.0,
    ];
    // Move the origin to the point nearest to the parameter-space centre (t = shift).
    let bb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
    if bb.is_nan() || bb <= 0.0 {
        return None;
    }
    let shift = -(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / bb;
    for k in 0..3 {
        a[k] += shift * b[k];
    }
    // Slab interval in t' = t − shift.
    let (mut s0, mut s1) = (f32::NEG_INFINITY, f32::INFINITY);
    if s.kind != 0 {
        if b[2] != 0.0 {
            let u0 = (s.clip[0] - a[2]) / b[2];
            let u1 = (s.clip[1] - a[2]) / b[2];
            s0 = u0.min(u1);
            s1 = u0.max(u1);
        } else if a[2] < s.clip[0] || a[2] > s.clip[1] {
            return None;
        }
    }
    // q(t') = A t'² + 2 B t' + C ≤ 0 inside.
    let qa = quad_form(s.diag, b, b);
    let qb = quad_form(s.diag, a, b);
    let qc = quad_form(s.diag, a, a);
    let q = |t: f32| (qa * t + 2.0 * qb) * t + qc;
    // A ray parallel to a cylinder's axis has no roots but may still pass through the caps.
    let roots = solve_quadratic(qa, qb, qc);
    let (r1, r2) = roots.unwrap_or((f32::NAN, f32::NAN));
    // Entry: s0 when the slab entry is inside; else the first root in (s0, s1] where q
    // turns negative. Exit likewise from the other end.
    let (entry, entry_cap) = if s0.is_finite() && q(s0) <= 0.0 {
        (s0, true)
    } else {
        let into = |r: f32| r > s0 && r <= s1 && qa * r + qb <= 0.0;
        if into(r1) {
            (r1, false)
        } else if into(r2) {
            (r2, false)
        } else {
            return None;
        }
    };
    let exit = if s1.is_finite() && q(s1) <= 0.0 {
        s1
    } else {
        let out = |r: f32| r >= entry && r < s1 && qa * r + qb >= 0.0;
        if out(r2) {
            r2
        } else if out(r1) {
            r1
        } else {
            entry
        }
    };
    let t_entry = entry + shift;
    let t_exit = exit + shift;
    if t_entry >= t_near {
        let (normal, gradient) = if entry_cap {
            // The slab face the ray enters: parameter normal ∓z.
            let sign = if b[2] > 0.0 { -1.0 } else { 1.0 };
            (cap_normal(s, sign), Vec3::ZERO)
        } else {
            let x = [
                a[0] + entry * b[0],
                a[1] + entry * b[1],
                a[2] + entry * b[2],
            ];
            let g = 2.0 * surface_gradient(s, x);
            (g, g)
        };
        Some(QuadricHit {
            t: t_entry,
            gradient,
            normal: normal.normalize_or_zero(),
            kind: if entry_cap {
                HitKind::Cap
            } else {
                HitKind::Surface
            },
        })
    } else if t_exit >= t_near {
        Some(QuadricHit {
            t: t_near,
            normal: Vec3::ZERO,
            gradient: Vec3::ZERO,
            kind: HitKind::NearCut,
        })
    } else {
        None
    }
}

/// `T⁻ᵀ (D x_p)` restricted to xyz (Eq. 7.15, up to the factor 2): the world gradient
/// direction of the surface at parameter point `x`.
fn surface_gradient(s: &QuadricSetup, x: [f32; 3]) -> Vec3 {
    let g = [s.diag[0] * x[0], s.diag[1] * x[1], s.diag[2] * x[2]];
    // T⁻ᵀ's upper 3x3 is inv transposed: world_k = Σ_j inv[k][j] g[j].
    Vec3::new(
        s.inv[0][0] * g[0] + s.inv[0][1] * g[1] + s.inv[0][2] * g[2],
        s.inv[1][0] * g[0] + s.inv[1][1] * g[1] + s.inv[1][2] * g[2],
        s.inv[2][0] * g[0] + s.inv[2][1] * g[1] + s.inv[2][2] * g[2],
    )
}

/// World normal of the parameter plane `z = const` on side `sign` (±1 along parameter z).
fn cap_normal(s: &QuadricSetup, sign: f32) -> Vec3 {
    Vec3::new(s.inv[0][2], s.inv[1][2], s.inv[2][2]) * sign
}

/// The world Hessian stored in a set-up.
pub fn setup_hessian(s: &QuadricSetup) -> Mat3 {
    let (a, b) = (s.hess_a, s.hess_b);
    Mat3::from_cols(
        Vec3::new(a[0], a[3], b[0]),
        Vec3::new(a[3], a[1], b[1]),
        Vec3::new(b[0], b[1], a[2]),
    )
}

/// At most two roots, without allocating (the set-up runs millions of times per frame).
#[derive(Clone, Copy, Debug, Default)]
struct Roots {
    v: [f64; 2],
    n: usize,
}

impl Roots {
    fn none() -> Self {
        Self::default()
    }
    fn one(a: f64) -> Self {
        Self { v: [a, 0.0], n: 1 }
    }
    fn two(a: f64, b: f64) -> Self {
        Self { v: [a, b], n: 2 }
    }
    fn iter(self) -> impl Iterator<Item = f64> {
        self.v.into_iter().take(self.n)
    }
}

/// Roots θ of `α cos θ + β sin θ = γ`.
fn trig_solve(alpha: f64, beta: f64, gamma: f64) -> Roots {
    let r = alpha.hypot(beta);
    if r <= 0.0 || gamma.abs() > r {
        return Roots::none();
    }
    let base = beta.atan2(alpha);
    let off = (gamma / r).clamp(-1.0, 1.0).acos();
    Roots::two(base + off, base - off)
}

/// A homogeneous trigonometric curve `P0 + P1 cos θ + P2 sin θ` in parameter space.
#[derive(Clone, Copy, Debug)]
struct Curve([DVec4; 3]);

impl Curve {
    fn at(&self, th: f64) -> DVec4 {
        self.0[0] + self.0[1] * th.cos() + self.0[2] * th.sin()
    }
    /// `(r·P0, r·P1, r·P2)`.
    fn coef(&self, r: DVec4) -> [f64; 3] {
        [r.dot(self.0[0]), r.dot(self.0[1]), r.dot(self.0[2])]
    }
}

/// θ where `(a0 + a1 c + a2 s)/(b0 + b1 c + b2 s)` is stationary (`(X/W)' = 0`), from
/// `X'W − XW' = 0` ⇔ `(a2 b0 − a0 b2) c + (a0 b1 − a1 b0) s + (a2 b1 − a1 b2) = 0`.
fn ratio_stationary(a: [f64; 3], b: [f64; 3]) -> Roots {
    let alpha = a[2] * b[0] - a[0] * b[2];
    let beta = a[0] * b[1] - a[1] * b[0];
    let gamma = a[2] * b[1] - a[1] * b[2];
    let th = trig_solve(alpha, beta, -gamma);
    if th.n == 0 { Roots::one(0.0) } else { th }
}

/// Accumulates candidate extreme points (homogeneous, parameter space) of the visible
/// solid into a screen box.
struct BoxAcc {
    rows: [DVec4; 4],
    near: f64,
    slab: (f64, f64),
    lo: [f64; 2],
    hi: [f64; 2],
    tol: f64,
}

impl BoxAcc {
    /// Adds point `p` (homogeneous) if it is visible (`N ≥ near`) and within the slab.
    fn add(&mut self, p: DVec4) {
        if p.w.abs() < 1e-300 {
            return;
        }
        let q = p / p.w;
        let n = self.rows[2].dot(q);
        let visible = n >= self.near - self.tol;
        if !visible || q.z < self.slab.0 - 1e-9 || q.z > self.slab.1 + 1e-9 {
            return;
        }
        let w = self.rows[3].dot(q);
        if w <= 0.0 {
            return;
        }
        for k in 0..2 {
            let v = self.rows[k].dot(q) / w;
            if v.is_finite() {
                self.lo[k] = self.lo[k].min(v);
                self.hi[k] = self.hi[k].max(v);
            }
        }
    }
    /// Adds the stationary points of X/W and Y/W on a curve and, when `arc_ends`, the points
    /// where the curve crosses the near plane.
    fn add_curve(&mut self, c: &Curve, arc_ends: bool) {
        let w = c.coef(self.rows[3]);
        for k in 0..2 {
            for th in ratio_stationary(c.coef(self.rows[k]), w).iter() {
                self.add(c.at(th));
            }
        }
        if arc_ends {
            // N(P(θ)) = near · P_w(θ).
            let n = c.coef(self.rows[2]);
            let pw = [c.0[0].w, c.0[1].w, c.0[2].w];
            let (al, be, ga) = (
                n[1] - self.near * pw[1],
                n[2] - self.near * pw[2],
                self.near * pw[0] - n[0],
            );
            for th in trig_solve(al, be, ga).iter() {
                // Exactly on the near plane: accept with the tolerance.
                self.add(c.at(th));
            }
        }
    }
}

impl Quadric {
    /// The tight screen box `(x_min, y_min, x_max, y_max)` (continuous pixel coordinates,
    /// not clamped to the image) of the part of the solid in front of the near plane, or
    /// `None` when no part is. See the module docs for the method.
    pub fn screen_box(&self, view: &View) -> Option<[f64; 4]> {
        let world = view.pixel_rows();
        // Rows in parameter space: r' = Tᵀ r.
        let tt = self.t.transpose();
        let rows = world.map(|r| tt * r);
        let scale = self.t.x_axis.length().max(self.t.z_axis.length());
        let mut acc = BoxAcc {
            rows,
            near: view.near,
            slab: self.slab(),
            lo: [f64::INFINITY; 2],
            hi: [f64::NEG_INFINITY; 2],
            tol: 1e-9 * (view.near.abs() + scale + rows[2].w.abs()),
        };
        let d = DVec4::from_array(self.kind.diag());
        let dq = |x: DVec4, y: DVec4| (x * d).dot(y);
        let e = |i: usize| DVec4::AXES[i];
        match self.kind {
            QuadricKind::Ellipsoid => {
                // Eq. 7.9 per axis; the tangent point is the pole D (r_k − b r4).
                for k in 0..2 {
                    let (r, r4) = (rows[k], rows[3]);
                    let (qa, qb, qc) = (dq(r4, r4), -dq(r, r4), dq(r, r));
                    for b in roots64(qa, qb, qc).iter() {
                        let n = r - r4 * b;
                        acc.add(n * d);
                    }
                }
                // Section by the near plane: g·p = near − n0 on the unit sphere.
                let g = rows[2].truncate();
                let g2 = g.length_squared();
                if g2 > 0.0 {
                    let m = g * ((view.near - rows[2].w) / g2);
                    let rho2 = 1.0 - m.length_squared();
                    if rho2 > 0.0 {
                        let rho = rho2.sqrt();
                        let gn = g / g2.sqrt();
                        let e1 = gn.any_orthonormal_vector();
                        let e2 = gn.cross(e1);
                        let curve = Curve([
                            m.extend(1.0),
                            (e1 * rho).extend(0.0),
                            (e2 * rho).extend(0.0),
                        ]);
                        acc.add_curve(&curve, false);
                    }
                }
            }
            QuadricKind::Cylinder | QuadricKind::Cone => {
                let cone = self.kind == QuadricKind::Cone;
                let (z_lo, z_hi) = self.slab();
                // Cap rims.
                for z in [z_lo, z_hi] {
                    let r = if cone { z } else { 1.0 };
                    let curve = Curve([e(2) * z + e(3), e(0) * r, e(1) * r]);
                    acc.add_curve(&curve, true);
                    if r == 0.0 {
                        acc.add(e(3));
                    }
                }
                // Section of the side by the near plane (homogeneous curves, see docs).
                let nr = rows[2];
                let k0 = view.near - nr.w;
                let curve = if cone {
                    Curve([
                        DVec4::new(0.0, 0.0, k0, nr.z),
                        DVec4::new(k0, 0.0, 0.0, nr.x),
                        DVec4::new(0.0, k0, 0.0, nr.y),
                    ])
                } else {
                    Curve([
                        DVec4::new(0.0, 0.0, k0, nr.z),
                        DVec4::new(nr.z, 0.0, -nr.x, 0.0),
                        DVec4::new(0.0, nr.z, -nr.y, 0.0),
                    ])
                };
                acc.add_curve(&curve, false);
                // A cap's disc cut by the near plane: its chord ends lie on the rim (added
                // above as arc ends); nothing else is extreme on a plane.
            }
        }
        (acc.lo[0] <= acc.hi[0] && acc.lo[1] <= acc.hi[1])
            .then_some([acc.lo[0], acc.lo[1], acc.hi[0], acc.hi[1]])
    }

    /// The per-pixel data for `view`, or `None` when nothing of the solid is in front of the
    /// near plane or its box misses the image. `object` is the quadric's index.
    pub fn setup(&self, view: &View, object: u32) -> Option<QuadricSetup> {
        let b = self.screen_box(view)?;
        let (w, h) = (f64::from(view.width), f64::from(view.height));
        if b[2] < 0.0 || b[3] < 0.0 || b[0] > w || b[1] > h {
            return None;
        }
        // A margin of 1e-3 pixel plus f32 rounding keeps every covered pixel centre inside.
        let pad = |v: f64| 1e-3 + 4.0 * f64::from(f32::EPSILON) * v.abs();
        let bbox = [
            (b[0] - pad(b[0])).max(-1.0) as f32,
            (b[1] - pad(b[1])).max(-1.0) as f32,
            (b[2] + pad(b[2])).min(w + 1.0) as f32,
            (b[3] + pad(b[3])).min(h + 1.0) as f32,
        ];
        let inv = self.t_inv;
        let col = |v: DVec4| [v.x as f32, v.y as f32, v.z as f32, 0.0];
        let eye_p = inv * view.eye.extend(1.0);
        let hs = self.hessian();
        let (slo, shi) = self.slab();
        Some(QuadricSetup {
            inv: [col(inv.x_axis), col(inv.y_axis), col(inv.z_axis)],
            eye_p: [eye_p.x as f32, eye_p.y as f32, eye_p.z as f32, 1.0],
            diag: self.kind.diag().map(|v| v as f32),
            hess_a: [hs.x_axis.x, hs.y_axis.y, hs.z_axis.z, hs.y_axis.x].map(|v| v as f32),
            hess_b: [hs.z_axis.x, hs.z_axis.y, 0.0, 0.0].map(|v| v as f32),
            bbox,
            clip: [
                slo.max(-f64::from(f32::MAX)) as f32,
                shi.min(f64::from(f32::MAX)) as f32,
            ],
            kind: self.kind.code(),
            object,
        })
    }
}

/// Real roots of `a x² + 2 b x + c = 0` in f64 (a linear equation's one root).
fn roots64(a: f64, b: f64, c: f64) -> Roots {
    let scale = a.abs().max(b.abs()).max(c.abs());
    if scale == 0.0 {
        return Roots::none();
    }
    if a.abs() <= 1e-14 * scale {
        return if b != 0.0 {
            Roots::one(-c / (2.0 * b))
        } else {
            Roots::none()
        };
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        // Tangent within rounding: one double root.
        return if disc > -1e-12 * b * b {
            Roots::one(-b / a)
        } else {
            Roots::none()
        };
    }
    let q = -(b + b.signum() * disc.sqrt());
    if q == 0.0 {
        return Roots::one(0.0);
    }
    Roots::two(q / a, c / q)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_round_trip_through_the_conic_matrix() {
        let s = Quadric::sphere(DVec3::new(1.0, 2.0, 3.0), 0.5).unwrap();
        let q = s.conic();
        let m = |q: DMat4| -> [[f64; 4]; 4] {
            std::array::from_fn(|i| std::array::from_fn(|j| q.col(j)[i]))
        };
        let back = Quadric::from_conic(m(q), None).unwrap();
        assert_eq!(back.kind(), QuadricKind::Ellipsoid);
        for p in [
            DVec3::new(1.5, 2.0, 3.0),
            DVec3::new(1.0, 2.3, 3.1),
            DVec3::new(9.0, 0.0, 0.0),
        ] {
            let (a, b) = (s.eval(p), back.eval(p));
            assert!((a - b).abs() < 1e-9 * (1.0 + a.abs()), "{a} {b}");
        }
        let cyl = Quadric::cylinder(DVec3::ZERO, DVec3::new(0.0, 0.0, 2.0), 0.3).unwrap();
        let ends = Some((DVec3::new(0.0, 0.0, 2.0), DVec3::ZERO));
        let back = Quadric::from_conic(m(cyl.conic()), ends).unwrap();
        assert_eq!(back.kind(), QuadricKind::Cylinder);
        assert!(back.contains(DVec3::new(0.1, 0.1, 1.9)));
        assert!(!back.contains(DVec3::new(0.1, 0.1, 2.1)));
        let cone = Quadric::cone(DVec3::ZERO, 0.0, DVec3::new(0.0, 2.0, 0.0), 1.0).unwrap();
        let ends = Some((DVec3::new(0.0, 0.5, 0.0), DVec3::new(0.0, 2.0, 0.0)));
        let back = Quadric::from_conic(m(cone.conic()), ends).unwrap();
        assert_eq!(back.kind(), QuadricKind::Cone);
        assert!(back.contains(DVec3::new(0.0, 1.0, 0.0)));
        assert!(!back.contains(DVec3::new(0.0, 0.25, 0.0)));
        assert!(back.contains(DVec3::new(0.4, 1.9, 0.0)));
        assert!(!back.contains(DVec3::new(0.4, 0.6, 0.0)));
        // A hyperboloid is refused with a reason.
        let mut h = m(DMat4::from_diagonal(DVec4::new(1.0, 1.0, -1.0, -1.0)));
        assert!(Quadric::from_conic(h, Some((DVec3::ZERO, DVec3::Z))).is_err());
        // A cylinder without its clip is refused.
        assert!(Quadric::from_conic(m(cyl.conic()), None).is_err());
        h[3][3] = f64::NAN;
        assert!(Quadric::from_conic(h, None).is_err());
        // Far from the origin and at extreme scales the classes are still recognized.
        for (c, r) in [(1e5, 1.0), (0.0, 1e-5), (0.0, 1e5), (3e3, 2e-2)] {
            let s = Quadric::sphere(DVec3::new(c, -0.5 * c, 0.0), r).unwrap();
            let back = Quadric::from_conic(m(s.conic()), None).unwrap();
            assert_eq!(
                back.kind(),
                QuadricKind::Ellipsoid,
                "centre {c}, radius {r}"
            );
            let p = DVec3::new(c + r, -0.5 * c, 0.0);
            assert!(back.eval(p).abs() < 1e-4, "{}", back.eval(p));
        }
        let far =
            Quadric::cylinder(DVec3::new(1e4, 0.0, 0.0), DVec3::new(1e4, 0.0, 5.0), 0.5).unwrap();
        let ends = Some((DVec3::new(1e4, 0.0, 0.0), DVec3::new(1e4, 0.0, 5.0)));
        assert_eq!(
            Quadric::from_conic(m(far.conic()), ends).unwrap().kind(),
            QuadricKind::Cylinder
        );
    }

    #[test]
    fn bad_parameters_are_refused() {
        assert!(Quadric::sphere(DVec3::ZERO, 0.0).is_err());
        assert!(Quadric::sphere(DVec3::ZERO, f64::NAN).is_err());
        assert!(Quadric::cylinder(DVec3::ZERO, DVec3::ZERO, 1.0).is_err());
        assert!(Quadric::cone(DVec3::ZERO, 0.0, DVec3::X, 0.0).is_err());
        assert!(
            Quadric::ellipsoid(DVec3::ZERO, DVec3::new(1.0, 1.0, 1e-9), DMat3::IDENTITY).is_err()
        );
        // Equal radii make a cylinder, and so do radii too close for an apex within reach.
        let c = Quadric::cone(DVec3::ZERO, 1.0, DVec3::X, 1.0).unwrap();
        assert_eq!(c.kind(), QuadricKind::Cylinder);
        let c = Quadric::cone(DVec3::ZERO, 1.0, DVec3::X, 1.000_001).unwrap();
        assert_eq!(c.kind(), QuadricKind::Cylinder);
        let c = Quadric::cone(DVec3::ZERO, 1.0, DVec3::X, 1.1).unwrap();
        assert_eq!(c.kind(), QuadricKind::Cone);
        // Nearly dependent axes are refused.
        let sheared = Quadric::from_axes(
            QuadricKind::Ellipsoid,
            DVec3::X,
            DVec3::new(1.0, 1e-8, 0.0),
            DVec3::Z,
            DVec3::ZERO,
            -1.0,
        );
        assert!(sheared.is_err());
    }

    #[test]
    fn quadratic_solver_is_stable() {
        assert_eq!(solve_quadratic(1.0, 0.0, -1.0), Some((-1.0, 1.0)));
        assert_eq!(solve_quadratic(1.0, 0.0, 1.0), None);
        // Large b: the small root keeps its digits.
        let (r1, r2) = solve_quadratic(1.0, -1e4, 1.0).unwrap();
        assert!((r1 - 5e-5).abs() < 1e-10 && (r2 - 2e4).abs() < 1.0);
        assert_eq!(solve_quadratic(0.0, 1.0, -4.0), Some((2.0, 2.0)));
    }
}
