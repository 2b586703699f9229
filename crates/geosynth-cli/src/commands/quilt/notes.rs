//! Notes `geosynth quilt` prints before a run about an exemplar or an output that may
//! not be what the user meant.

use geosynth::core::KdIndex;
use geosynth::mls::Covariance;
use geosynth::quilt::{GeometryTexture, MAX_PLANE_SPREAD, QuiltParams, TextureFile};
use glam::{DMat3, DVec3};

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

/// A hint when a few points of a file read with the default box lie far outside the rest
/// ([`TextureFile::stray_points`]): along the file's axes they stretch the box, and the
/// note gives the `--box` that leaves them out, each corner in the fewest digits that the
/// reader takes back to the same box; a fitted plane has left them out already.
pub(super) fn stray_note(file: &TextureFile) -> Option<String> {
    let strays = file.stray_points?;
    let (count, verbs) = match strays.count {
        1 => ("1 point".to_string(), ("lies", "stretches", "it")),
        n => (format!("{n} points"), ("lie", "stretch", "them")),
    };
    let strays_are = format!(
        "note: {count} of the exemplar {} far outside the rest (beyond twice the span of the \
         middle 99% of the points' coordinates)",
        verbs.0
    );
    let Some([lo, hi]) = strays.box_without else {
        return Some(format!(
            "{strays_are}; the fitted plane and its box leave {} out",
            verbs.2
        ));
    };
    let corners = [lo, hi]
        .iter()
        .flat_map(|c| (0..3).map(move |axis| (c[axis], file.origin[axis])))
        .map(|(corner, origin)| shortest_corner(corner, origin))
        .collect::<Vec<_>>();
    Some(format!(
        "{strays_are} and {} its default box; --box {} is the default box without {}",
        verbs.1,
        corners.join(","),
        verbs.2
    ))
}

/// `corner` (a box corner's coordinate in a file whose points were read relative to
/// `origin`) in the fewest significant digits whose value the texture reader stores as the
/// same single-precision offset from `origin`.
fn shortest_corner(corner: f64, origin: f64) -> String {
    let stored = |value: f64| (value - origin) as f32;
    (0..17)
        .filter_map(|digits| format!("{corner:.digits$e}").parse::<f64>().ok())
        .find(|&rounded| stored(rounded) == stored(corner))
        .map_or_else(|| format!("{corner:?}"), |rounded| format!("{rounded:?}"))
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

    #[test]
    fn corners_are_written_in_the_fewest_digits_that_give_the_same_box() {
        for (corner, origin, written) in [
            // f32 offsets near the origin: their shortest form.
            (f64::from(0.000_218_808_65f32), 0.0, "0.00021880865"),
            (f64::from(4.0f32), 0.0, "4.0"),
            (f64::from(8.581_82e-18f32), 0.0, "8.58182e-18"),
            // A georeferenced corner: the offset 0.1 in single precision, from 512,000.
            (512_000.0 + f64::from(0.1f32), 512_000.0, "512000.1"),
            (-3.5, 0.0, "-3.5"),
        ] {
            let shortest = shortest_corner(corner, origin);
            assert_eq!(shortest, written);
            let back: f64 = shortest.parse().unwrap_or(f64::NAN);
            assert_eq!((back - origin) as f32, (corner - origin) as f32);
        }
    }
}
