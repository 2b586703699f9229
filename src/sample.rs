//! Stage: a mesh → oriented points on its surface, for the algorithms that work on
//! point-set surfaces (MLS, [`crate::quilt`]) when the mesh's vertices are too few or too
//! uneven to stand for it (what `geosynth sample` runs); stage: a point set → fewer of its
//! own points, when a scan is far denser than they need ([`ThinPoints`]); and the points'
//! colours from a texture image at their texture coordinates ([`texture_colours`]).

use image::RgbImage;
use pointset_core::surface_sampling::{
    PointThinning, SampleNormals, SurfaceSamples, SurfaceSampling, ThinnedPoints, UV_CHANNELS,
    sample_surface, thin_points,
};
use pointset_core::{PointSet, RunContext, Stage, TriMesh};

use crate::error::{Error, Result};

/// Stage: mesh → points sampled on its surface
/// ([`pointset_core::surface_sampling::sample_surface`]), seeded by the run's seed: with
/// the normals asked for and the vertex attributes interpolated, and the triangle each
/// sample lies on. `map(|samples| samples.points)` hands the points on.
///
/// Errors: a mesh without area, a count or spacing out of range, or cancellation.
///
/// ```
/// use geosynth::reconstruct::{FieldParams, Reconstruct};
/// use geosynth::sample::SampleSurface;
/// use geosynth::{RunContext, Stage};
///
/// // A coarse torus (288 vertices) sampled at 4000 points and reconstructed.
/// let torus = geosynth::fixtures::torus_mesh(24, 12, 1.0, 0.35)?;
/// let to_mesh = SampleSurface::about(&torus, 4000)?
///     .map(|samples| samples.points)
///     .then(Reconstruct { params: FieldParams::default().resolution(40) });
/// let mesh = to_mesh.run(torus, &mut RunContext::new(1))?;
/// let topology = mesh.topology();
/// assert!(topology.is_closed_manifold() && topology.components == 1);
/// assert_eq!(topology.euler_characteristic, 0); // a torus
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SampleSurface {
    /// How many samples, and how they spread.
    pub sampling: SurfaceSampling,
    /// Where the samples' normals come from.
    #[cfg_attr(feature = "serde", serde(default))]
    pub normals: SampleNormals,
}

impl SampleSurface {
    /// Poisson-disk samples, about `count` of them on `mesh`'s surface
    /// ([`SurfaceSampling::poisson_disk_for_count`]), with the triangles' normals.
    ///
    /// Errors: a count of 0, or a mesh without area.
    pub fn about(mesh: &TriMesh, count: usize) -> Result<Self> {
        Ok(Self {
            sampling: SurfaceSampling::poisson_disk_for_count(mesh.area(), count)?,
            normals: SampleNormals::Faces,
        })
    }
}

impl Stage for SampleSurface {
    type Input = TriMesh;
    type Output = SurfaceSamples;
    type Error = Error;

    fn name(&self) -> &str {
        "sample surface"
    }

    fn run(&self, input: TriMesh, ctx: &mut RunContext) -> Result<SurfaceSamples> {
        Ok(sample_surface(&input, &self.sampling, self.normals, ctx)?)
    }
}

/// Stage: point set → the points kept by a Poisson disk of its own points, or at random
/// ([`pointset_core::surface_sampling::thin_points`]), seeded by the run's seed; each kept
/// point exactly as it was, with its normal and attributes. `map(|thinned| thinned.points)`
/// hands the points on.
///
/// Errors: an empty point set, a count or spacing out of range, or cancellation.
///
/// ```
/// use geosynth::core::surface_sampling::PointThinning;
/// use geosynth::sample::ThinPoints;
/// use geosynth::{RunContext, Stage};
///
/// // 20,000 points on a sphere, thinned to about 2,000 no closer together than they
/// // need to be.
/// let sphere = geosynth::fixtures::sphere_points(20_000)?;
/// let thin = ThinPoints { thinning: PointThinning::PoissonDiskCount { count: 2_000 } };
/// let thinned = thin.run(sphere.clone(), &mut RunContext::new(1))?;
/// assert!(thinned.points.len().abs_diff(2_000) <= 20);
/// let spacing = thinned.spacing.unwrap_or_default();
/// assert!(spacing > 0.05 && spacing < 0.1); // about √(4π · 0.65 / 2000)
/// // The kept points are the sphere's own, with their normals.
/// let first = thinned.kept[0] as usize;
/// assert_eq!(thinned.points.positions()[0], sphere.positions()[first]);
/// assert_eq!(thinned.points.normals().unwrap()[0], sphere.normals().unwrap()[first]);
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct ThinPoints {
    /// Which points to keep.
    pub thinning: PointThinning,
}

impl Stage for ThinPoints {
    type Input = PointSet;
    type Output = ThinnedPoints;
    type Error = Error;

    fn name(&self) -> &str {
        "thin points"
    }

    fn run(&self, input: PointSet, ctx: &mut RunContext) -> Result<ThinnedPoints> {
        Ok(thin_points(&input, &self.thinning, ctx)?)
    }
}

/// The colour of `texture` at each point's texture coordinates (the attributes `s` and
/// `t`, [`UV_CHANNELS`], which [`SampleSurface`] interpolates from a mesh with UVs), in
/// `0..=1`, for [`PointSet::set_colors`].
///
/// The OBJ convention: `(0, 0)` is the image's lower-left corner and `(1, 1)` its
/// upper-right; texel centres sit at half-integers; colours are interpolated bilinearly
/// between the four nearest texels; coordinates outside `[0, 1]` repeat the image.
///
/// Errors: points without both attributes, or an image without pixels.
///
/// ```
/// use geosynth::core::{Attribute, PointSet};
/// use geosynth::sample::texture_colours;
/// use glam::Vec3;
///
/// // A 2 × 1 image, red on the left and blue on the right.
/// let texture = image::RgbImage::from_fn(2, 1, |x, _| {
///     if x == 0 { image::Rgb([255, 0, 0]) } else { image::Rgb([0, 0, 255]) }
/// });
/// let points = PointSet::new(vec![Vec3::ZERO; 3])?
///     .with_attribute(Attribute::new("s", vec![0.25, 0.5, 1.75]))?
///     .with_attribute(Attribute::new("t", vec![0.5; 3]))?;
/// let colours = texture_colours(&points, &texture)?;
/// assert_eq!(colours[0], [1.0, 0.0, 0.0]); // the left texel's centre
/// assert_eq!(colours[1], [0.5, 0.0, 0.5]); // halfway between the two
/// assert_eq!(colours[2], [0.0, 0.0, 1.0]); // 1.75 repeats 0.75
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn texture_colours(points: &PointSet, texture: &RgbImage) -> Result<Vec<[f32; 3]>> {
    let [Some(s), Some(t)] = UV_CHANNELS.map(|name| points.attribute(name)) else {
        return Err(pointset_core::Error::InvalidParameter {
            name: "points",
            value: "without texture coordinates".into(),
            expected: "the attributes `s` and `t` (points sampled from a mesh with UVs)".into(),
        }
        .into());
    };
    let (width, height) = (texture.width() as i64, texture.height() as i64);
    if width == 0 || height == 0 {
        return Err(pointset_core::Error::EmptyInput {
            what: "the texture image".into(),
        }
        .into());
    }
    let texel = |x: i64, y: i64| {
        let pixel = texture.get_pixel(x.rem_euclid(width) as u32, y.rem_euclid(height) as u32);
        pixel.0.map(|c| f64::from(c) / 255.0)
    };
    Ok(s.values()
        .iter()
        .zip(t.values())
        .map(|(&u, &v)| {
            // Texel centres at half-integers, rows from the top.
            let x = f64::from(u) * width as f64 - 0.5;
            let y = (1.0 - f64::from(v)) * height as f64 - 0.5;
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            let (x0, y0) = (x0 as i64, y0 as i64);
            let corners = [
                (texel(x0, y0), (1.0 - fx) * (1.0 - fy)),
                (texel(x0 + 1, y0), fx * (1.0 - fy)),
                (texel(x0, y0 + 1), (1.0 - fx) * fy),
                (texel(x0 + 1, y0 + 1), fx * fy),
            ];
            [0, 1, 2].map(|c| corners.iter().map(|(rgb, w)| rgb[c] * w).sum::<f64>() as f32)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn samples_of_a_sphere_lie_on_it_and_a_flat_mesh_is_an_error() {
        let sphere = crate::fixtures::icosphere_mesh(3).unwrap();
        let stage = SampleSurface {
            sampling: SurfaceSampling::Uniform { count: 5000 },
            normals: SampleNormals::Interpolated,
        };
        let samples = stage.run(sphere.clone(), &mut RunContext::new(2)).unwrap();
        let points = samples.points.positions();
        let normals = samples.points.normals().unwrap();
        assert_eq!(points.len(), 5000);
        for (p, n) in points.iter().zip(normals) {
            // Flat triangles sag inside the sphere by at most 1 − cos(half an edge's
            // angle); the interpolated normals point out, near the radial direction.
            assert!(p.length() <= 1.0 + 1e-6 && p.length() > 0.98, "{p}");
            assert!(n.angle_between(p.normalize()) < 0.05, "{p}: {n}");
        }
        let flat = TriMesh::new(
            pointset_core::PointSet::new(vec![
                glam::Vec3::ZERO,
                glam::Vec3::X,
                glam::Vec3::X * 3.0,
            ])
            .unwrap(),
            vec![[0, 1, 2]],
        )
        .unwrap();
        assert!(SampleSurface::about(&flat, 100).is_err());
        assert!(stage.run(flat, &mut RunContext::new(2)).is_err());
    }

    #[test]
    fn texture_rows_run_from_the_top_and_points_without_coordinates_are_an_error() {
        // Two rows: red on top, blue below. v = 0.75 is the top row's centre.
        let texture = RgbImage::from_fn(1, 2, |_, y| {
            image::Rgb(if y == 0 { [255, 0, 0] } else { [0, 0, 255] })
        });
        let at = |v: f32| {
            let points = PointSet::new(vec![glam::Vec3::ZERO])
                .unwrap()
                .with_attribute(pointset_core::Attribute::new("s", vec![0.3]))
                .unwrap()
                .with_attribute(pointset_core::Attribute::new("t", vec![v]))
                .unwrap();
            texture_colours(&points, &texture).unwrap()[0]
        };
        assert_eq!(at(0.75), [1.0, 0.0, 0.0]);
        assert_eq!(at(0.25), [0.0, 0.0, 1.0]);
        // A quarter of the way from the top row's centre to the bottom one's.
        let between = at(0.625);
        assert!((between[0] - 0.75).abs() < 1e-6 && (between[2] - 0.25).abs() < 1e-6);
        let bare = PointSet::new(vec![glam::Vec3::ZERO]).unwrap();
        assert!(texture_colours(&bare, &texture).is_err());
        let with_uvs = bare
            .with_attribute(pointset_core::Attribute::new("s", vec![0.3]))
            .unwrap()
            .with_attribute(pointset_core::Attribute::new("t", vec![0.3]))
            .unwrap();
        assert!(texture_colours(&with_uvs, &RgbImage::new(0, 0)).is_err());
    }
}
