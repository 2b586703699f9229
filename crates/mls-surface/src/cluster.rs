//! Adaptive clustering after Pauly, Gross & Kobbelt (2002): recursive splitting by the
//! plane through the centroid orthogonal to the covariance's principal direction.

use glam::Vec3;

use crate::error::{MlsError, Result};
use crate::pca::Covariance;

/// Limits of [`adaptive_clusters`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct ClusterParams {
    /// A cluster may hold at most this many points (`n_max`); default 20.
    pub max_points: usize,
    /// A cluster's surface variation may be at most this (`σ_max`); default 0.05.
    pub max_variation: f32,
}

impl Default for ClusterParams {
    fn default() -> Self {
        Self {
            max_points: 20,
            max_variation: 0.05,
        }
    }
}

impl ClusterParams {
    /// Sets `n_max` (default 20).
    pub fn max_points(mut self, n: usize) -> Self {
        self.max_points = n;
        self
    }

    /// Sets `σ_max` (default 0.05).
    pub fn max_variation(mut self, sigma: f32) -> Self {
        self.max_variation = sigma;
        self
    }

    /// Checks that `n_max` is at least 1 and `σ_max` finite and ≥ 0.
    pub fn validate(&self) -> Result<()> {
        if self.max_points == 0 {
            return Err(MlsError::InvalidParameter {
                name: "max_points",
                value: "0".into(),
                expected: "at least 1",
            });
        }
        if !(self.max_variation.is_finite() && self.max_variation >= 0.0) {
            return Err(MlsError::InvalidParameter {
                name: "max_variation",
                value: self.max_variation.to_string(),
                expected: "a finite number ≥ 0",
            });
        }
        Ok(())
    }
}

/// One cluster: its members, a representative and its surface variation.
#[derive(Debug, Clone, PartialEq)]
pub struct Cluster {
    /// Indices of the member points.
    pub members: Vec<usize>,
    /// The member closest to the cluster's centroid (lowest index on ties): a real sample,
    /// so it carries a normal — paper 000 uses these as the TPS target set Q.
    pub representative: usize,
    /// Surface variation of the members.
    pub variation: f32,
}

/// Splits `points` into clusters of at most `max_points` points and variation at most
/// `max_variation`. A set that cannot be split further (all points identical along the
/// principal direction) is kept as one cluster even if it is larger. Deterministic.
pub fn adaptive_clusters(points: &[Vec3], params: &ClusterParams) -> Result<Vec<Cluster>> {
    params.validate()?;
    let mut out = Vec::new();
    let mut stack: Vec<Vec<usize>> = vec![(0..points.len()).collect()];
    while let Some(set) = stack.pop() {
        let Some(cov) = Covariance::of(points, set.iter().copied()) else {
            continue;
        };
        let variation = cov.variation();
        let small_and_flat = set.len() <= params.max_points && variation <= params.max_variation;
        let axis = cov.eigenvectors[2];
        let (left, right): (Vec<usize>, Vec<usize>) = set
            .iter()
            .partition(|&&i| (points[i] - cov.centroid).dot(axis) < 0.0);
        if small_and_flat || left.is_empty() || right.is_empty() {
            let representative = set
                .iter()
                .copied()
                .min_by(|&a, &b| {
                    points[a]
                        .distance_squared(cov.centroid)
                        .total_cmp(&points[b].distance_squared(cov.centroid))
                        .then(a.cmp(&b))
                })
                .unwrap_or(set[0]);
            out.push(Cluster {
                members: set,
                representative,
                variation,
            });
        } else {
            stack.push(right);
            stack.push(left);
        }
    }
    Ok(out)
}
