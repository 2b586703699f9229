//! The check behind every function that takes a caller's [`KdIndex`] of a point set.

use pointset_core::{KdIndex, PointSet};

use crate::error::{MlsError, Result};

/// Whether `index` was built from `points`' positions, in their order: the functions that
/// take an index read neighbours' indices from it and look the points up in `points`.
pub(crate) fn check_index_of(index: &KdIndex, points: &PointSet) -> Result<()> {
    if index.points() == points.positions() {
        Ok(())
    } else {
        Err(MlsError::InvalidParameter {
            name: "index",
            value: format!("an index of {} points", index.len()),
            expected: "an index built from the point set's own positions, in their order",
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use glam::Vec3;
    use pointset_core::RunContext;

    use super::*;
    use crate::{fit_normals_with, orient_normals_with, orientation_disagreement_with};

    fn is_index_error<T: std::fmt::Debug>(result: Result<T>) -> bool {
        matches!(
            result,
            Err(MlsError::InvalidParameter { name: "index", .. })
        )
    }

    #[test]
    fn an_index_of_other_positions_is_refused_by_every_function_that_takes_one() {
        let grid: Vec<Vec3> = (0..100)
            .map(|i| Vec3::new((i % 10) as f32, (i / 10) as f32, 0.0))
            .collect();
        let points = PointSet::new(grid.clone())
            .unwrap()
            .with_normals(vec![Vec3::Z; 100])
            .unwrap();
        let mut reversed = grid.clone();
        reversed.reverse();
        let others = [
            KdIndex::new(&reversed).unwrap(),
            KdIndex::new(&grid[..99]).unwrap(),
            KdIndex::new(&[]).unwrap(),
        ];
        let mut ctx = RunContext::new(0);
        for index in &others {
            assert!(is_index_error(fit_normals_with(
                index, &points, 8, &mut ctx
            )));
            assert!(is_index_error(orient_normals_with(
                index,
                &points,
                Vec3::Z,
                &mut ctx
            )));
            assert!(is_index_error(orientation_disagreement_with(
                index, &points
            )));
        }
        let own = KdIndex::new(&grid).unwrap();
        assert!(fit_normals_with(&own, &points, 8, &mut ctx).is_ok());
        assert!(orient_normals_with(&own, &points, Vec3::Z, &mut ctx).is_ok());
        assert_eq!(orientation_disagreement_with(&own, &points).unwrap(), 0.0);
    }
}
