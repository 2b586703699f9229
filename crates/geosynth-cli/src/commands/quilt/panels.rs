//! The preview of a quilt: the exemplar beside its results.

use std::path::Path;

use geosynth::core::io::Geometry;
use geosynth::preview::{self, Panel, RenderOptions, UpAxis as ViewUp};
use geosynth::quilt::{GeometryTexture, QuiltOutput, UpAxis};
use glam::Vec3;

use crate::CliResult;

/// Renders exemplar | result panels (Z-up textures are viewed with Z up), all at one
/// scale, the largest at which each fits its panel, so the exemplar's features and the
/// results' are drawn the same size.
pub fn texture_preview(
    texture: &GeometryTexture,
    outputs: &[&QuiltOutput],
    path: &Path,
    w: u32,
    h: u32,
) -> CliResult {
    let up = match texture.up() {
        UpAxis::X | UpAxis::Y => ViewUp::Y,
        UpAxis::Z => ViewUp::Z,
    };
    // Points far above or below the box (stray points a given or fitted box leaves out)
    // would shrink the exemplar to a speck in its panel: it shows those within the box's
    // own height of it along the up axis, which is every point of a default box.
    let bounds = texture.canonical_bounds();
    let reach = bounds.extent().z;
    let near_box = |_, p: Vec3| (bounds.min.z - reach..=bounds.max.z + reach).contains(&p.z);
    let exemplar = Geometry::Points(texture.canonical_points().filter(near_box));
    let results: Vec<Geometry> = outputs
        .iter()
        .map(|o| Geometry::Points(o.points.clone()))
        .collect();
    let mut panels = vec![Panel::Geometry(&exemplar, ViewUp::Z)];
    panels.extend(results.iter().map(|g| Panel::Geometry(g, up)));
    let image = preview::render_panels_at_one_scale(
        &panels,
        &RenderOptions::default().size(w, h).view(30.0, 40.0),
    )?;
    preview::save_png(&image, path)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use geosynth::core::{HeightField, PointSet};

    use super::*;

    #[test]
    fn the_exemplar_panel_leaves_out_points_far_from_the_box() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let field = HeightField::new(40, 40, (0..1600).map(|i| (i % 7) as f32 * 0.01).collect())
            .unwrap_or_else(|e| panic!("{e}"));
        let texture = GeometryTexture::from_heightfield(&field, 0.1, 1.0, 4)
            .unwrap_or_else(|e| panic!("{e}"));
        let points = texture.canonical_points();
        let render = |points: &PointSet, name: &str| {
            let bounds = texture.canonical_bounds();
            let t =
                GeometryTexture::new(points, bounds, UpAxis::Z).unwrap_or_else(|e| panic!("{e}"));
            let path = dir.path().join(name);
            texture_preview(&t, &[], &path, 160, 120).unwrap_or_else(|e| panic!("{e}"));
            std::fs::read(path).unwrap_or_else(|e| panic!("{e}"))
        };
        let clean = render(points, "clean.png");
        // One point 100 above the box: left out, the same picture.
        let mut positions = points.positions().to_vec();
        positions.push(Vec3::new(2.0, 2.0, 100.0));
        let mut normals = points.normals().unwrap_or_default().to_vec();
        normals.push(Vec3::Z);
        let stray = PointSet::new(positions.clone())
            .and_then(|p| p.with_normals(normals.clone()))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(render(&stray, "stray.png") == clean);
        // One point within the box's height of it is shown.
        let top = texture.canonical_bounds().max.z;
        *positions.last_mut().unwrap_or_else(|| panic!("no points")) =
            Vec3::new(2.0, 2.0, top + 0.03);
        let near = PointSet::new(positions)
            .and_then(|p| p.with_normals(normals))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(render(&near, "near.png") != clean);
    }
}
