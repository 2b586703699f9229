//! Where a height map of a point-set quilt lies in the exemplar's file: the file's
//! coordinates of its grid and of its heights, kept in double precision so that a
//! georeferenced scan's map keeps its place and its elevations.

use glam::{DMat3, DVec3, Vec3};
use pointset_core::{Aabb, HeightField};

use super::HeightFieldFrame;
use crate::Result;
use crate::imagery::{PlanPlacement, mapped_heights};

/// Where in a file lies the height map that [`super::sample_heights`] samples from a
/// quilt of a texture read from that file ([`super::TextureFile`]): sample `(c, r)` of
/// height `h` (in a map of `rows` rows, after [`Self::file_heights`]) lies at
/// `lower_corner + spacing·(c·columns_axis + (rows − 1 − r)·rows_axis) + h·up_axis`.
///
/// ```
/// use geosynth::quilt::{HeightFieldFrame, MapGrid, TextureFile, texture_from_exemplar};
/// use geosynth::quilt::{OutputSize, Quilt, QuiltParams, sample_heights};
/// use geosynth::{RunContext, Stage};
/// use glam::{DMat3, DVec3};
///
/// let exemplar = geosynth::fixtures::textures::bumpy(60.0, 1, 1)?;
/// let mut file = TextureFile::from(texture_from_exemplar(&exemplar)?);
/// // As if read from a tile 1000 units up at (500 000, 4 000 000).
/// file.origin = DVec3::new(5e5, 4e6, 1000.0);
/// let params = QuiltParams::default().output(OutputSize::Scale(1.25)).field_resolution(20);
/// let out = Quilt { params }.run(file.texture.clone(), &mut RunContext::new(3))?;
/// let frame = HeightFieldFrame::of_points(&file.texture, None)?;
/// let sampled = sample_heights(&out.points, &out.bounds, frame)?;
/// let grid = MapGrid::new(&out.bounds, frame, file.origin, file.frame);
/// assert_eq!(grid.offset, 1000.0);
/// let map = grid.file_heights(sampled.field)?;
/// let (lo, hi) = map.range();
/// assert!(lo > 999.0 && hi < 1001.0, "{lo}..{hi}");
/// assert_eq!((grid.lower_corner.x, grid.lower_corner.z), (5e5 + out.bounds.min.x as f64, 0.0));
/// // Along the file's x and y with z up: a world file can place it.
/// assert!(grid.plan_placement(map.height()).is_some());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapGrid {
    /// File coordinates of the bottom row's first sample at height 0.
    pub lower_corner: DVec3,
    /// Along the columns (a unit file direction).
    pub columns_axis: DVec3,
    /// Along the rows, bottom to top (a unit file direction).
    pub rows_axis: DVec3,
    /// The direction heights grow in (a unit file direction).
    pub up_axis: DVec3,
    /// Added to every sampled height by [`Self::file_heights`]: the file origin's
    /// coordinate along `up_axis`.
    pub offset: f64,
    /// The distance between neighbouring samples, the frame's.
    pub spacing: f32,
}

impl MapGrid {
    /// The grid of a map on `frame` over the box `bounds` of a quilt (as
    /// [`super::sample_heights`] samples it), for a texture whose origin and axes in its
    /// file are `origin` and `axes` ([`super::TextureFile::origin`],
    /// [`super::TextureFile::frame`]).
    pub fn new(bounds: &Aabb, frame: HeightFieldFrame, origin: DVec3, axes: DMat3) -> Self {
        let texture_up = frame.up;
        let lo = texture_up.canonical_box(bounds).min;
        let in_file = |v: Vec3| axes * texture_up.to_world(v).as_dvec3();
        let up_axis = in_file(Vec3::Z);
        let offset = origin.dot(up_axis);
        Self {
            lower_corner: origin - offset * up_axis + in_file(Vec3::new(lo.x, lo.y, 0.0)),
            columns_axis: in_file(Vec3::X),
            rows_axis: in_file(Vec3::Y),
            up_axis,
            offset,
            spacing: frame.spacing,
        }
    }

    /// `field` (sampled on this grid) with [`Self::offset`] added to every height in
    /// double precision, so a georeferenced height keeps what `f32` can hold of it.
    pub fn file_heights(&self, field: HeightField) -> Result<HeightField> {
        if self.offset == 0.0 {
            return Ok(field);
        }
        mapped_heights(&field, |h| h + self.offset)
    }

    /// The grid's place in the file's x–y plane for a map `rows` rows tall, when its
    /// columns run along +x, its rows along +y and its heights along +z
    /// ([`PlanPlacement::of_grid`]): what a world file or an ENVI header says.
    pub fn plan_placement(&self, rows: usize) -> Option<PlanPlacement> {
        let axes = [self.columns_axis, self.rows_axis, self.up_axis];
        PlanPlacement::of_grid(self.lower_corner, axes, f64::from(self.spacing), rows)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn offsets_are_added_in_double_precision() {
        let field = HeightField::new(2, 2, vec![0.25, -1.5, 0.0, 1.0]).unwrap();
        let grid = |offset: f64| MapGrid {
            lower_corner: DVec3::ZERO,
            columns_axis: DVec3::X,
            rows_axis: DVec3::Y,
            up_axis: DVec3::Z,
            offset,
            spacing: 1.0,
        };
        let moved = grid(4096.0).file_heights(field.clone()).unwrap();
        assert_eq!(moved.heights(), &[4096.25, 4094.5, 4096.0, 4097.0]);
        // 2²⁴ + 1 has no single-precision value: rounded first, then added, 1 more would
        // give 2²⁴ (a tie, to even); added first, 2²⁴ + 2.
        let far = grid(16_777_217.0).file_heights(field.clone()).unwrap();
        assert_eq!(far.heights()[3], 16_777_218.0);
        assert_eq!(grid(0.0).file_heights(field.clone()).unwrap(), field);
    }
}
