//! Covariance analysis of neighbourhoods: eigen-decomposition and surface variation
//! (Pauly, Gross & Kobbelt 2002).

use glam::Vec3;
use nalgebra::{Matrix3, SymmetricEigen};
use pointset_core::KdIndex;
use rayon::prelude::*;

use crate::error::{MlsError, Result};

/// Eigen-decomposition of a 3×3 covariance: eigenvalues ascending and matching unit vectors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Covariance {
    /// Centroid of the points.
    pub centroid: Vec3,
    /// Eigenvalues `λ0 ≤ λ1 ≤ λ2`.
    pub eigenvalues: [f64; 3],
    /// Unit eigenvectors, matching `eigenvalues`.
    pub eigenvectors: [Vec3; 3],
}

impl Covariance {
    /// Covariance of the points at `indices` (computed in `f64`); `None` when empty or when
    /// an index lies outside `points`.
    pub fn of(points: &[Vec3], indices: impl IntoIterator<Item = usize> + Clone) -> Option<Self> {
        let mut n = 0usize;
        let mut sum = [0f64; 3];
        for i in indices.clone() {
            let p = *points.get(i)?;
            sum[0] += f64::from(p.x);
            sum[1] += f64::from(p.y);
            sum[2] += f64::from(p.z);
            n += 1;
        }
        if n == 0 {
            return None;
        }
        let c = sum.map(|s| s / n as f64);
        let mut m = Matrix3::<f64>::zeros();
        for i in indices {
            let p = *points.get(i)?;
            let d = [
                f64::from(p.x) - c[0],
                f64::from(p.y) - c[1],
                f64::from(p.z) - c[2],
            ];
            for r in 0..3 {
                for s in 0..3 {
                    m[(r, s)] += d[r] * d[s];
                }
            }
        }
        m /= n as f64;
        let eig = SymmetricEigen::new(m);
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let vector = |k: usize| {
            let v = eig.eigenvectors.column(k);
            Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32).normalize_or_zero()
        };
        Some(Self {
            centroid: Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32),
            eigenvalues: order.map(|k| eig.eigenvalues[k].max(0.0)),
            eigenvectors: order.map(vector),
        })
    }

    /// Surface variation `σ = λ0 / (λ0 + λ1 + λ2)`: 0 on a plane, at most 1/3 (isotropic).
    /// Zero for a neighbourhood of identical points.
    pub fn variation(&self) -> f32 {
        let total: f64 = self.eigenvalues.iter().sum();
        if total <= 0.0 {
            0.0
        } else {
            (self.eigenvalues[0] / total) as f32
        }
    }
}

/// Surface variation of each point over its `k` nearest neighbours (itself included).
pub fn surface_variation(index: &KdIndex, k: usize) -> Result<Vec<f32>> {
    if k < 3 {
        return Err(MlsError::InvalidParameter {
            name: "k",
            value: k.to_string(),
            expected: "at least 3 neighbours",
        });
    }
    let points = index.points();
    points
        .par_iter()
        .map(|&p| {
            let nn = index.nearest(p, k)?;
            Ok(Covariance::of(points, nn.iter().map(|n| n.index)).map_or(0.0, |c| c.variation()))
        })
        .collect()
}
