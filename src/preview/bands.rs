//! Drawing an image band by band: the buffers a band needs are allocated for its rows
//! only, and bands are drawn in parallel.
//!
//! Each primitive is listed in the bands its rows reach, in the order it was given, so
//! every pixel sees the same primitives in the same order as in an image drawn whole: the
//! picture does not depend on the bands' height or the number of threads.

use glam::Vec3;
use rayon::prelude::*;

use super::raster::{FrameBuffer, pixel_span};

/// The rows of a band. At the largest previews (8192 pixels wide) a band's buffers take
/// about 29 MB (56 bytes a pixel with surface splats), where the whole image's took 3.8 GB.
pub(crate) const BAND_ROWS: usize = 64;

/// An image `width × height` drawn in bands of `band_rows` rows, as 8-bit RGB bytes row
/// after row. `rows[k]` is the top and bottom of primitive `k` in pixel coordinates;
/// `draw(band, drawn)` draws the primitives listed in `drawn` (in increasing order) into
/// a band filled with `background`.
pub(crate) fn draw_in_bands(
    (width, height): (usize, usize),
    band_rows: usize,
    background: Vec3,
    rows: impl Iterator<Item = (f32, f32)>,
    draw: impl Fn(&mut FrameBuffer, &[usize]) + Sync,
) -> Vec<u8> {
    let band_rows = band_rows.max(1);
    let mut drawn_in_band = vec![Vec::new(); height.div_ceil(band_rows)];
    for (k, (top, bottom)) in rows.enumerate() {
        if let Some((first, last)) = pixel_span(top, bottom, 0, height) {
            for drawn in &mut drawn_in_band[first / band_rows..=last / band_rows] {
                drawn.push(k);
            }
        }
    }
    let mut rgb = vec![0u8; width * height * 3];
    rgb.par_chunks_mut(width * band_rows * 3)
        .zip(drawn_in_band.par_iter())
        .enumerate()
        .for_each(|(b, (out, drawn))| {
            let mut band =
                FrameBuffer::band(width, b * band_rows, out.len() / (3 * width), background);
            draw(&mut band, drawn);
            band.write_rgb8(out);
        });
    rgb
}
