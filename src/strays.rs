//! Stage: a point set → the same without its stray and isolated points, the step before
//! [`crate::reconstruct`] for scans with outliers (what `geosynth reconstruct` and `sdf`
//! do first).

use mls_surface::{IsolatedPoints, MlsParams, without_isolated_indexed};
use pointset_core::{KdIndex, PointSet, RunContext, Stage};

use crate::error::{Error, Result};

/// Stage: points → the same points without those that would spoil their surface:
///
/// - stray points, far outside the rest ([`pointset_core::strays::kept_indices`]), which
///   stretch a distance grid over the points' box until the surface is a speck in it;
/// - then isolated points, with fewer than 3 others within twice the reach of the MLS
///   kernel `kernel` ([`mls_surface::without_isolated`]), each of which would close into
///   a bubble of its own. They are kept when they are most of the points (the kernel is
///   then too small for the sampling).
///
/// With `keep` both are counted and kept. Normals, attributes and the order of the
/// remaining points are kept. The output says what was found; `map(|found| found.points)`
/// hands the points on.
///
/// Errors: a kernel that is not positive and finite, or none to estimate (all points
/// coincident).
///
/// ```
/// use geosynth::reconstruct::{FieldParams, Reconstruct};
/// use geosynth::strays::LeaveOutStrays;
/// use geosynth::{RunContext, Stage};
/// use glam::Vec3;
///
/// // A scan of a sphere with one outlier inside it and one far away.
/// let scan = geosynth::fixtures::sphere_points(2000)?;
/// let mut positions = scan.positions().to_vec();
/// let mut normals = scan.normals().ok_or("no normals")?.to_vec();
/// positions.extend([Vec3::ZERO, Vec3::new(0.0, 0.0, 500.0)]);
/// normals.extend([Vec3::X, Vec3::Z]);
/// let noisy = geosynth::core::PointSet::new(positions)?.with_normals(normals)?;
/// let found = LeaveOutStrays::default().run(noisy.clone(), &mut RunContext::new(0))?;
/// assert_eq!((found.points.len(), found.strays), (2000, 1));
/// assert_eq!(found.isolated.map(|i| i.count), Some(1));
/// // Chained before the reconstruction: one closed sphere.
/// let to_mesh = LeaveOutStrays::default()
///     .map(|found| found.points)
///     .then(Reconstruct { params: FieldParams::default().resolution(32) });
/// let mesh = to_mesh.run(noisy, &mut RunContext::new(0))?;
/// let topology = mesh.topology();
/// assert!(topology.is_closed_manifold() && topology.components == 1);
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct LeaveOutStrays {
    /// The MLS kernel `h` the isolated points are judged for: the one the surface will
    /// use ([`crate::reconstruct::FieldParams::kernel`]); estimated from the points'
    /// spacing by default.
    pub kernel: Option<f32>,
    /// Count the stray and isolated points but keep them.
    pub keep: bool,
}

/// What [`LeaveOutStrays`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct StraysFound {
    /// The points, without the stray and isolated ones unless they were kept.
    pub points: PointSet,
    /// How many points lay far outside the rest (left out unless kept).
    pub strays: usize,
    /// The isolated points among the others, and what was done with them; `None` when
    /// there were none.
    pub isolated: Option<IsolatedPoints>,
}

impl Stage for LeaveOutStrays {
    type Input = PointSet;
    type Output = StraysFound;
    type Error = Error;

    fn name(&self) -> &str {
        "leave out strays"
    }

    fn run(&self, input: PointSet, ctx: &mut RunContext) -> Result<StraysFound> {
        ctx.check_cancelled()?;
        Ok(self.run_indexed(input)?.0)
    }
}

impl LeaveOutStrays {
    /// What [`Stage::run`] finds, with an index of the positions of the points it hands
    /// on ([`mls_surface::without_isolated_indexed`]), for steps after it that search
    /// them: `geosynth reconstruct` and `sdf` estimate or orient normals and check them
    /// with it instead of indexing the points again.
    ///
    /// Errors: those of [`Stage::run`].
    pub fn run_indexed(&self, input: PointSet) -> Result<(StraysFound, KdIndex)> {
        let (points, strays) = if self.keep {
            let count = input.stray_count();
            (input, count)
        } else {
            input.without_strays()
        };
        let params = MlsParams::default().with_kernel(self.kernel);
        let (points, isolated, index) = without_isolated_indexed(points, &params, self.keep)?;
        let found = StraysFound {
            points,
            strays,
            isolated,
        };
        Ok((found, index))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use glam::Vec3;
    use mls_surface::IsolatedFate;

    use super::*;

    #[test]
    fn kept_strays_are_counted_and_a_bad_kernel_is_an_error() {
        let sphere = crate::fixtures::sphere_points(2000).unwrap();
        let mut positions = sphere.positions().to_vec();
        positions.extend([Vec3::ZERO, Vec3::splat(400.0)]);
        let noisy = PointSet::new(positions).unwrap();
        let run = |stage: LeaveOutStrays| stage.run(noisy.clone(), &mut RunContext::new(0));
        let left = run(LeaveOutStrays::default()).unwrap();
        assert_eq!(left.points.positions(), sphere.positions());
        // The same found with an index of the points kept.
        let (indexed, index) = LeaveOutStrays::default()
            .run_indexed(noisy.clone())
            .unwrap();
        assert_eq!((&indexed, index.points()), (&left, sphere.positions()));
        let kept = run(LeaveOutStrays {
            keep: true,
            ..LeaveOutStrays::default()
        })
        .unwrap();
        assert_eq!(kept.points, noisy);
        assert_eq!(kept.strays, 1);
        // Judged with the far point among them (kept): the centre is still alone.
        let isolated = kept.isolated.unwrap();
        assert_eq!((isolated.count, isolated.fate), (2, IsolatedFate::Kept));
        // A kernel reaching from the centre to the sphere takes the centre in.
        let wide = run(LeaveOutStrays {
            kernel: Some(0.3),
            ..LeaveOutStrays::default()
        })
        .unwrap();
        assert_eq!(
            (wide.points.len(), wide.strays, wide.isolated),
            (2001, 1, None)
        );
        for bad in [0.0, -1.0, f32::NAN] {
            let stage = LeaveOutStrays {
                kernel: Some(bad),
                ..LeaveOutStrays::default()
            };
            assert!(run(stage).is_err(), "{bad}");
        }
    }
}
