//! The 3D thin-plate spline (Wahba 1990): fitting, evaluation, Jacobian, normal transport.

use glam::{DMat3, DVec3, Vec3};
use nalgebra::{DMatrix, Matrix3xX, SymmetricEigen};
use rayon::prelude::*;

use crate::error::{Result, TpsError};

mod batch;
mod blocked_lu;

/// What to do when the control points do not span 3D (all coplanar, collinear, or a single
/// point) and the affine part of the spline is therefore undetermined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum AffineRegularization {
    /// Return [`TpsError::DegenerateControlPoints`].
    Reject,
    /// Resolve the undetermined affine directions toward the identity map (the default):
    /// the affine block of the system becomes `Pᵀw − μ a = −μ a₀` with `a₀` the identity,
    /// `μ = 1e-9 ·` trace scale, which fixes the components of `a` that the points cannot
    /// see to those of the identity and perturbs the others by `O(μ)`. Points off a
    /// coplanar control set then keep their offset along its normal — what warping a
    /// nearly flat patch needs.
    #[default]
    TowardIdentity,
}

/// Parameters of [`ThinPlateSpline::fit`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct TpsParams {
    /// Smoothing `λ ≥ 0` (regularized TPS; 0 = interpolation, the default): the spline
    /// minimizes `Σ |W(sᵢ) − qᵢ|² + λ E(W)` with `E` =
    /// [`ThinPlateSpline::bending_energy`], so it tends to the least-squares affine map as
    /// `λ` grows. `λ` has units of length (the kernel is `φ(r) = r`).
    pub smoothing: f64,
    /// Handling of control points that do not span 3D; default
    /// [`AffineRegularization::TowardIdentity`].
    pub affine_regularization: AffineRegularization,
    /// Control points closer than this fraction of the bounding-box diagonal count as
    /// coincident; default 1e-9.
    pub duplicate_tolerance: f64,
}

impl Default for TpsParams {
    fn default() -> Self {
        Self {
            smoothing: 0.0,
            affine_regularization: AffineRegularization::TowardIdentity,
            duplicate_tolerance: 1e-9,
        }
    }
}

impl TpsParams {
    /// Sets the smoothing `λ` (default 0).
    pub fn smoothing(mut self, lambda: f64) -> Self {
        self.smoothing = lambda;
        self
    }

    /// Sets the degenerate-configuration policy (default toward identity).
    pub fn affine_regularization(mut self, policy: AffineRegularization) -> Self {
        self.affine_regularization = policy;
        self
    }

    /// Sets the coincidence tolerance, a fraction of the bounding-box diagonal (default
    /// 1e-9).
    pub fn duplicate_tolerance(mut self, fraction: f64) -> Self {
        self.duplicate_tolerance = fraction;
        self
    }

    /// Checks that the smoothing and the coincidence tolerance are finite and ≥ 0.
    pub fn validate(&self) -> Result<()> {
        for (name, value) in [
            ("smoothing", self.smoothing),
            ("duplicate_tolerance", self.duplicate_tolerance),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(TpsError::InvalidParameter {
                    name,
                    value: value.to_string(),
                    expected: "a finite number ≥ 0",
                });
            }
        }
        Ok(())
    }
}

/// Most control points (pairs) [`ThinPlateSpline::fit`] accepts: its dense system needs
/// `n²` memory (512 MiB at this size) and `n³` time. Paper 000's warps use tens to hundreds.
pub const MAX_CONTROL_POINTS: usize = 8192;

/// `W(x) = c + A x + Σ wᵢ φ(|x − sᵢ|)` with the 3D biharmonic kernel `φ(r) = r`, fitted with
/// the side conditions `Σ wᵢ = 0`, `Σ wᵢ sᵢᵀ = 0`.
///
/// With the `serde` feature a spline is stored as its terms (`centers`, `weights`,
/// `translation`, `linear` column by column) and read back through
/// [`ThinPlateSpline::from_terms`]'s checks, so that a fitted warp can be kept and applied
/// again without its pairs (`serde_json` reads a double back to within its last bit, and
/// exactly with its `float_roundtrip` feature).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(
        try_from = "crate::spline_serde::SplineTerms",
        into = "crate::spline_serde::SplineTerms"
    )
)]
pub struct ThinPlateSpline {
    centers: Vec<DVec3>,
    weights: Vec<DVec3>,
    translation: DVec3,
    /// Column-major `A`: `W(x) = c + linear * x + …`.
    linear: DMat3,
}

fn check_finite(points: &[Vec3], what: &'static str) -> Result<()> {
    match points.iter().position(|p| !p.is_finite()) {
        Some(index) => Err(TpsError::NonFinite { what, index }),
        None => Ok(()),
    }
}

/// Dimension of the affine hull of the points (0 to 3), from the centred covariance.
fn affine_rank(points: &[DVec3]) -> usize {
    let n = points.len() as f64;
    let mean = points.iter().copied().sum::<DVec3>() / n;
    let mut m = Matrix3xX::<f64>::zeros(points.len());
    for (i, p) in points.iter().enumerate() {
        let d = *p - mean;
        m[(0, i)] = d.x;
        m[(1, i)] = d.y;
        m[(2, i)] = d.z;
    }
    let cov = &m * m.transpose();
    let eig = SymmetricEigen::new(cov);
    let largest = eig.eigenvalues.iter().copied().fold(0.0f64, f64::max);
    if largest <= 0.0 {
        return 0;
    }
    eig.eigenvalues
        .iter()
        .filter(|&&l| l > 1e-12 * largest)
        .count()
}

impl ThinPlateSpline {
    /// Fits the spline mapping each `sources[i]` to `targets[i]`.
    ///
    /// Exact duplicates (same source, same target) are merged. Errors: empty or unequal
    /// inputs, non-finite coordinates, coincident sources with different targets, control
    /// points not spanning 3D under [`AffineRegularization::Reject`], or a singular system.
    pub fn fit(sources: &[Vec3], targets: &[Vec3], params: &TpsParams) -> Result<Self> {
        if sources.len() != targets.len() {
            return Err(TpsError::LengthMismatch {
                what: "sources and targets",
                left: sources.len(),
                right: targets.len(),
            });
        }
        if sources.is_empty() {
            return Err(TpsError::EmptyInput {
                what: "control point set",
            });
        }
        if sources.len() > MAX_CONTROL_POINTS {
            return Err(TpsError::InvalidParameter {
                name: "control points",
                value: sources.len().to_string(),
                expected: "at most MAX_CONTROL_POINTS (8192) pairs: the dense system takes n² \
                           memory and n³ time",
            });
        }
        check_finite(sources, "source point")?;
        check_finite(targets, "target point")?;
        params.validate()?;
        let (s, q) = Self::merge_duplicates(sources, targets, params.duplicate_tolerance)?;
        let n = s.len();
        let rank = affine_rank(&s);
        let regularize = rank < 3;
        if regularize && params.affine_regularization == AffineRegularization::Reject {
            return Err(TpsError::DegenerateControlPoints { rank });
        }
        // Assemble [K + λI, P; Pᵀ, −μI] [w; a] = [q; −μ a₀].
        let size = n + 4;
        let mut m = DMatrix::<f64>::zeros(size, size);
        for i in 0..n {
            for j in 0..n {
                m[(i, j)] = s[i].distance(s[j]);
            }
            // `φ(r) = r` is the 3D biharmonic Green's function up to the negative factor
            // `−1/8π`, so the smoothing that penalizes bending enters with a minus sign.
            m[(i, i)] -= params.smoothing;
            let row = [1.0, s[i].x, s[i].y, s[i].z];
            for (c, v) in row.iter().enumerate() {
                m[(i, n + c)] = *v;
                m[(n + c, i)] = *v;
            }
        }
        let mut rhs = DMatrix::<f64>::zeros(size, 3);
        for i in 0..n {
            rhs[(i, 0)] = q[i].x;
            rhs[(i, 1)] = q[i].y;
            rhs[(i, 2)] = q[i].z;
        }
        if regularize {
            let scale = s.iter().map(|p| p.length_squared()).sum::<f64>() / n as f64 + 1.0;
            let mu = 1e-9 * scale;
            for c in 0..4 {
                m[(n + c, n + c)] = -mu;
            }
            // a₀: zero translation, identity linear part (rows 1..4 of the affine block).
            for k in 0..3 {
                rhs[(n + 1 + k, k)] = -mu;
            }
        }
        let solution = if size >= blocked_lu::BLOCKED_LU_MIN_SIZE {
            blocked_lu::solve(m, rhs)
        } else {
            m.lu().solve(&rhs)
        }
        .ok_or(TpsError::Singular)?;
        if solution.iter().any(|v| !v.is_finite()) {
            return Err(TpsError::Singular);
        }
        let row = |r: usize| DVec3::new(solution[(r, 0)], solution[(r, 1)], solution[(r, 2)]);
        let weights = (0..n).map(row).collect();
        let translation = row(n);
        // Row n+1+k holds ∂W/∂x_k: these are the columns of A.
        let linear = DMat3::from_cols(row(n + 1), row(n + 2), row(n + 3));
        Ok(Self {
            centers: s,
            weights,
            translation,
            linear,
        })
    }

    fn merge_duplicates(
        sources: &[Vec3],
        targets: &[Vec3],
        tolerance: f64,
    ) -> Result<(Vec<DVec3>, Vec<DVec3>)> {
        let s: Vec<DVec3> = sources.iter().map(|p| p.as_dvec3()).collect();
        let q: Vec<DVec3> = targets.iter().map(|p| p.as_dvec3()).collect();
        let (lo, hi) = s.iter().fold(
            (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let eps = tolerance * (hi - lo).length().max(1e-300);
        // Sort by x so coincident points are neighbours in a sweep.
        let mut order: Vec<usize> = (0..s.len()).collect();
        order.sort_by(|&a, &b| s[a].x.total_cmp(&s[b].x).then(a.cmp(&b)));
        let mut keep = vec![true; s.len()];
        for (pos, &i) in order.iter().enumerate() {
            if !keep[i] {
                continue;
            }
            for &j in &order[pos + 1..] {
                if s[j].x - s[i].x > eps {
                    break;
                }
                if keep[j] && s[i].distance(s[j]) <= eps {
                    if q[i].distance(q[j]) <= eps.max(tolerance * q[i].length()) {
                        keep[j] = false;
                    } else {
                        return Err(TpsError::DuplicateControlPoints {
                            first: i.min(j),
                            second: i.max(j),
                        });
                    }
                }
            }
        }
        let pick = |v: &[DVec3]| {
            v.iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(p, _)| *p)
                .collect::<Vec<_>>()
        };
        Ok((pick(&s), pick(&q)))
    }

    /// The spline with the given terms, as [`ThinPlateSpline::centers`],
    /// [`ThinPlateSpline::weights`] and [`ThinPlateSpline::affine`] give them back: one
    /// weight per center. The side conditions of a fit are not required (any such sum is
    /// a smooth map), so a spline kept from a fit and one built by hand are both accepted.
    ///
    /// Errors: centers and weights of unequal length, more than [`MAX_CONTROL_POINTS`]
    /// centers, a term that is not finite.
    ///
    /// ```
    /// use glam::{DMat3, DVec3, Vec3};
    /// use tps_warp::{ThinPlateSpline, TpsParams};
    ///
    /// let sources = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE];
    /// let targets = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::splat(1.2)];
    /// let fitted = ThinPlateSpline::fit(&sources, &targets, &TpsParams::default())?;
    /// let (translation, linear) = fitted.affine();
    /// let again = ThinPlateSpline::from_terms(
    ///     fitted.centers().to_vec(),
    ///     fitted.weights().to_vec(),
    ///     translation,
    ///     linear,
    /// )?;
    /// assert_eq!(again, fitted);
    /// // A shift alone: no centers.
    /// let shift = ThinPlateSpline::from_terms(vec![], vec![], DVec3::X, DMat3::IDENTITY)?;
    /// assert_eq!(shift.eval(Vec3::ZERO), Vec3::X);
    /// Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn from_terms(
        centers: Vec<DVec3>,
        weights: Vec<DVec3>,
        translation: DVec3,
        linear: DMat3,
    ) -> Result<Self> {
        if centers.len() != weights.len() {
            return Err(TpsError::LengthMismatch {
                what: "centers and weights",
                left: centers.len(),
                right: weights.len(),
            });
        }
        if centers.len() > MAX_CONTROL_POINTS {
            return Err(TpsError::InvalidParameter {
                name: "centers",
                value: centers.len().to_string(),
                expected: "at most MAX_CONTROL_POINTS (8192)",
            });
        }
        for (what, terms) in [("center", &centers), ("weight", &weights)] {
            if let Some(index) = terms.iter().position(|t| !t.is_finite()) {
                return Err(TpsError::NonFinite { what, index });
            }
        }
        if !(translation.is_finite() && linear.is_finite()) {
            return Err(TpsError::NonFinite {
                what: "affine term",
                index: 0,
            });
        }
        Ok(Self {
            centers,
            weights,
            translation,
            linear,
        })
    }

    /// The control points (sources) after merging duplicates.
    pub fn centers(&self) -> &[DVec3] {
        &self.centers
    }

    /// Kernel weights `wᵢ`, one per center.
    pub fn weights(&self) -> &[DVec3] {
        &self.weights
    }

    /// The affine part: translation `c` and linear map `A`.
    pub fn affine(&self) -> (DVec3, DMat3) {
        (self.translation, self.linear)
    }

    /// `W(x)` in double precision.
    pub fn eval_f64(&self, x: DVec3) -> DVec3 {
        let mut out = self.translation + self.linear * x;
        for (c, w) in self.centers.iter().zip(&self.weights) {
            out += *w * x.distance(*c);
        }
        out
    }

    /// `W(x)`.
    pub fn eval(&self, x: Vec3) -> Vec3 {
        self.eval_f64(x.as_dvec3()).as_vec3()
    }

    /// The Jacobian `J(x) = A + Σ wᵢ (x − sᵢ)ᵀ / |x − sᵢ|`. At a control point the kernel
    /// `φ(r) = r` has no derivative; its term is taken as zero there — the mean of the
    /// one-sided derivatives over all directions.
    pub fn jacobian(&self, x: Vec3) -> DMat3 {
        let x = x.as_dvec3();
        let mut j = self.linear;
        for (c, w) in self.centers.iter().zip(&self.weights) {
            let d = x - *c;
            let r = d.length();
            if r > 0.0 {
                // Outer product w dᵀ / r: column k is w · d_k / r.
                let g = d / r;
                j += DMat3::from_cols(*w * g.x, *w * g.y, *w * g.z);
            }
        }
        j
    }

    /// Transports a normal through the warp as paper 000 §5.2 does: with `u, v` orthonormal
    /// tangents of `n`, `n' = (J u × J v) / |J u × J v|`. Returns `n` unchanged if the warp
    /// collapses the tangent plane (a degenerate Jacobian).
    pub fn transform_normal(&self, x: Vec3, n: Vec3) -> Vec3 {
        Self::normal_through(self.jacobian(x), n)
    }

    /// [`Self::transform_normal`] with the Jacobian `j` at the point already known (from
    /// [`Self::jacobians`]): `n' = (J u × J v) / |J u × J v|`, or `n` unchanged where `J`
    /// collapses the tangent plane or `n` has no direction.
    pub fn normal_through(j: DMat3, n: Vec3) -> Vec3 {
        let Some(n) = n.try_normalize() else {
            return n;
        };
        let n = n.as_dvec3();
        let u = n.any_orthonormal_vector();
        let v = n.cross(u);
        let m = (j * u).cross(j * v);
        m.try_normalize().map_or(n.as_vec3(), |m| m.as_vec3())
    }

    /// Warps many points (and their normals, when given) in parallel: [`Self::eval_many`]
    /// and [`Self::normal_through`] the [`Self::jacobians`]. Normals pair with points in
    /// order; the turned normals are as many as the shorter of the two.
    pub fn warp(
        &self,
        points: &[Vec3],
        normals: Option<&[Vec3]>,
    ) -> (Vec<Vec3>, Option<Vec<Vec3>>) {
        let moved = self.eval_many(points);
        let turned = normals.map(|ns| {
            let count = points.len().min(ns.len());
            self.jacobians(&points[..count])
                .into_par_iter()
                .zip(&ns[..count])
                .map(|(j, &n)| Self::normal_through(j, n))
                .collect()
        });
        (moved, turned)
    }

    /// Bending energy up to the positive constant `8π`: `−Σ_k w_kᵀ K w_k`, where `K` is the
    /// kernel matrix of the centers (conditionally negative definite, so this is ≥ 0).
    pub fn bending_energy(&self) -> f64 {
        let mut e = 0.0;
        for (i, ci) in self.centers.iter().enumerate() {
            for (j, cj) in self.centers.iter().enumerate() {
                e -= self.weights[i].dot(self.weights[j]) * ci.distance(*cj);
            }
        }
        e
    }
}
