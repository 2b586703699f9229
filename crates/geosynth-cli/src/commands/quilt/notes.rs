//! Notes `geosynth quilt` prints before a run about an exemplar or an output that may
//! not be what the user meant.

use geosynth::core::KdIndex;
use geosynth::mls::{Covariance, MlsParams};
use geosynth::quilt::{GeometryTexture, MAX_PLANE_SPREAD, QuiltParams, TextureFile};
use glam::{DMat3, DVec3};

use crate::commands::point_prep::isolated_note;

/// A hint when the exemplar looks stood on its side: its samples reach further along the
/// up axis than across the narrower side of the plane, which a texture rarely does and a
/// Y-up file read as Z-up always does.
pub(super) fn orientation_note(texture: &GeometryTexture) -> Option<String> {
    let extent = texture
        .canonical_points()
        .bounding_box()
        .map(|b| b.extent())?;
    (extent.z > extent.x.min(extent.y)).then(|| {
        format!(
            "note: the exemplar is taller along its up axis ({:?}) than it is wide; if its \
             file was written with another up axis, pass --up x|y|z (or --up auto); if stray \
             points lie far above or below its surface, --box X0,Y0,Z0,X1,Y1,Z1 leaves them \
             out of the texture's box",
            texture.up()
        )
    })
}

/// What was done with the stray points of a point-set exemplar
/// ([`TextureFile::stray_points`]): left out (of the default box or the fitted plane), or
/// kept under the default box.
pub(super) fn stray_note(file: &TextureFile) -> Option<String> {
    let strays = file.stray_points?;
    let (count, verb, pronoun) = match strays.count {
        1 => ("1 point".to_string(), "lies", "it"),
        n => (format!("{n} points"), "lie", "them"),
    };
    let done = match (strays.left_out, file.frame == DMat3::IDENTITY) {
        (true, true) => {
            format!(
                "left out, since the default box would span {pronoun}; --keep-strays keeps {pronoun}"
            )
        }
        (true, false) => "left out of the fitted plane and its box".to_string(),
        (false, _) => format!("kept (--keep-strays): the default box spans {pronoun}"),
    };
    Some(format!(
        "note: {count} of the exemplar {verb} far outside the rest (beyond twice the span of \
         the middle 99% of the points' coordinates): {done}"
    ))
}

/// What was done with the isolated points of a point-set exemplar
/// ([`TextureFile::isolated_points`]): left out, or kept.
pub(super) fn isolated_points_note(file: &TextureFile) -> Option<String> {
    let isolated = file.isolated_points?;
    let min_neighbours = MlsParams::default().min_neighbours;
    Some(isolated_note(
        &isolated,
        "the exemplar",
        min_neighbours,
        None,
    ))
}

/// A mesh exemplar read by its vertices whose longest edge exceeds this many median vertex
/// spacings gets a note suggesting `--sample`.
const UNDERSAMPLED_EDGE_SPACINGS: f32 = 4.0;

/// A hint when a mesh exemplar's vertices undersample it: some of its triangles are large
/// for the spacing of its vertices ([`TextureFile::longest_edge_spacings`] above
/// [`UNDERSAMPLED_EDGE_SPACINGS`]), and the quilt sees only the vertices.
pub(super) fn undersampled_mesh_note(file: &TextureFile) -> Option<String> {
    let ratio = file.longest_edge_spacings?;
    (ratio > UNDERSAMPLED_EDGE_SPACINGS).then(|| {
        format!(
            "note: the exemplar is a mesh, quilted by its {} vertices, and its longest edge \
             is {ratio:.0} times their median spacing: its large triangles have no samples \
             inside; --sample [N] quilts points sampled evenly on its surface instead",
            file.texture.canonical_points().len()
        )
    })
}

/// Tilts of the points' best plane against the reference plane above this (degrees) get a
/// note suggesting `--up auto`.
const TILT_NOTE_DEGREES: f64 = 15.0;

/// A hint when the exemplar's points lie in a plane tilted against its reference plane (a
/// scan of a sloping wall read with an axis): the angle between the plane fitted to them
/// and the up axis, when they have a dominant plane and it exceeds
/// [`TILT_NOTE_DEGREES`]. `None` for a fitted frame, which is the plane itself.
pub(super) fn tilt_note(file: &TextureFile) -> Option<String> {
    if file.frame != DMat3::IDENTITY {
        return None;
    }
    let points = file.texture.canonical_points().positions();
    let fit = Covariance::of(points, 0..points.len())?;
    let [across, narrow, _] = fit.eigenvalues;
    let normal = fit.eigenvectors[0].as_dvec3();
    let tilt = normal.dot(DVec3::Z).abs().min(1.0).acos().to_degrees();
    (across <= MAX_PLANE_SPREAD * narrow && tilt > TILT_NOTE_DEGREES).then(|| {
        format!(
            "note: the exemplar's points lie in a plane tilted {tilt:.0}° from its reference \
             plane; --up auto quilts it in that plane"
        )
    })
}

/// A note when the exemplar file stored coordinates far from the origin in single
/// precision, on a grid coarser than a hundredth of its sample spacing (georeferenced data
/// written as `float`: at 4e6 the values are 0.25 apart). Reading in double precision
/// cannot restore that; `None` when it is fine or its spacing cannot be estimated.
pub(super) fn precision_note(file: &TextureFile) -> Option<String> {
    let step = file.single_precision_step?;
    let points = file.texture.canonical_points().positions();
    let spacing = f64::from(KdIndex::new(points).ok()?.median_spacing().ok()?);
    crate::commands::single_precision_note(file.origin, step, spacing, "its sample spacing")
}

/// Expected output sizes above this many points get a note before the run starts.
const LARGE_OUTPUT_POINTS: f64 = 1.0e6;

/// A note when the output will be large (more than [`LARGE_OUTPUT_POINTS`] points at the
/// exemplar's density, [`GeometryTexture::expected_output_points`]): such runs take
/// minutes (the warp's spline systems grow with the exemplar's density, so the time grows
/// faster than the output), and on sparse exemplars the measure, which is on by default, can take longer
/// than the synthesis.
pub(super) fn size_note(texture: &GeometryTexture, params: &QuiltParams) -> Option<String> {
    let expected = texture.expected_output_points(params.output);
    (expected > LARGE_OUTPUT_POINTS).then(|| {
        format!(
            "note: about {:.1} million output points expected; runs this large take minutes, \
             and the time grows faster than the output (on 2 cores, without the quality \
             measure: a 1024 × 1024 image read as a height field, 1.9 million points in \
             about 53 s; a 2048 × 2048 one, 7.4 million, in about 10 minutes and 1.8 GB of \
             memory). --scale or --size make the output smaller; --no-quality skips the \
             measure",
            expected / 1.0e6
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use geosynth::core::HeightField;
    use geosynth::quilt::OutputSize;

    /// A 40 × 40 height field 0.1 apart (about 107 samples per unit area in its box).
    fn small_texture() -> GeometryTexture {
        let heights = (0..1600).map(|i| (i % 7) as f32 * 0.01).collect();
        let field = HeightField::new(40, 40, heights).unwrap_or_else(|e| panic!("{e}"));
        GeometryTexture::from_heightfield(&field, 0.1, 1.0, 4).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn large_outputs_get_a_note_before_the_run() {
        let texture = small_texture();
        let params = QuiltParams::default();
        assert_eq!(size_note(&texture, &params), None, "a 2 × 2 quilt is small");
        // 100 × 100 at about 107 samples per unit area: about 1.07 million points.
        let large = params.output(OutputSize::Absolute(100.0, 100.0));
        let note = size_note(&texture, &large).unwrap_or_default();
        assert!(note.contains("about 1.1 million output points"), "{note}");
        assert!(note.contains("--no-quality"), "{note}");
    }
}
