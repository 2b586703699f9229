//! Files written beside a height map so that GIS tools (GDAL, and QGIS through it) read
//! it without the run's report ([`write_map_sidecars`]):
//! - a raw `.f32le` map gets an ENVI header (`MAP.f32le.hdr`): its size, sample type and
//!   byte order, which a raw file cannot say;
//! - a map with a [`PlanPlacement`] (its grid along a file's x and y axes, heights along
//!   z) is placed in the file's coordinates: by the header's `map info` for a raw map, by
//!   a world file (`MAP.pgw`) for a PNG;
//! - a PNG whose grey levels were stretched over a range gets a GDAL `MAP.png.aux.xml`
//!   with the band's scale and offset, so that `grey · scale + offset` is the height.
//!
//! None of them names a coordinate reference system: the point-set formats do not carry
//! one, and GDAL calls the plane `LOCAL_CS["Arbitrary"]`.

use std::path::{Path, PathBuf};

use glam::DVec3;
use pointset_core::io::write_whole;

use crate::Result;

/// Where a map's samples lie in the file's x–y plane: the centre of its top-left sample
/// (row 0, column 0) and the distance between neighbouring samples along both axes; rows
/// run towards −y.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanPlacement {
    /// File x and y of the top-left sample's centre.
    pub top_left: [f64; 2],
    /// The grid spacing, in the file's length units.
    pub spacing: f64,
}

impl PlanPlacement {
    /// The placement of a map `rows` samples tall whose sample `(c, r)` lies at
    /// `lower_corner + spacing·(c·columns_axis + (rows − 1 − r)·rows_axis)`, when its
    /// columns run along +x, its rows along +y and its heights along +z; `None` for any
    /// other grid, which a world file or ENVI `map info` without a rotation cannot place.
    pub fn of_grid(
        lower_corner: DVec3,
        [columns_axis, rows_axis, up_axis]: [DVec3; 3],
        spacing: f64,
        rows: usize,
    ) -> Option<Self> {
        let along_file_axes =
            columns_axis == DVec3::X && rows_axis == DVec3::Y && up_axis == DVec3::Z;
        along_file_axes.then(|| Self {
            top_left: [
                lower_corner.x,
                lower_corner.y + spacing * rows.saturating_sub(1) as f64,
            ],
            spacing,
        })
    }
}

/// What a map's sidecars describe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapDescription {
    /// Samples per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// The map's place in the file's x–y plane, when it has one.
    pub placement: Option<PlanPlacement>,
    /// For a PNG whose grey levels were stretched, the heights of grey 0 and 65535.
    pub grey_range: Option<(f32, f32)>,
}

/// Writes the sidecars of the map written to `map` (a raw map when `raw`: the path
/// [`super::write_heightfield`] returns, `_WxH` included) and returns their paths, in the
/// order written. Errors on I/O.
///
/// ```
/// use geosynth::imagery::{MapDescription, PlanPlacement, write_map_sidecars};
///
/// let dir = std::env::temp_dir();
/// let map = MapDescription {
///     width: 4,
///     height: 3,
///     placement: Some(PlanPlacement { top_left: [500_000.0, 4_000_002.0], spacing: 1.0 }),
///     grey_range: Some((120.0, 131.5)),
/// };
/// let written = write_map_sidecars(&dir.join("geosynth_doc_dem.png"), false, &map)?;
/// assert!(written[0].ends_with("geosynth_doc_dem.pgw"));
/// let world = std::fs::read_to_string(&written[0])?;
/// assert_eq!(world, "1\n0\n0\n-1\n500000\n4000002\n");
/// assert!(written[1].ends_with("geosynth_doc_dem.png.aux.xml"));
/// # for file in written { std::fs::remove_file(file)?; }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_map_sidecars(
    map: &Path,
    raw: bool,
    description: &MapDescription,
) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    if raw {
        files.push((
            appended(map, "hdr"),
            envi_header(description.width, description.height, description.placement),
        ));
    } else {
        if let Some(placement) = description.placement {
            files.push((map.with_extension("pgw"), world_file(placement)));
        }
        if let Some(range) = description.grey_range {
            files.push((appended(map, "aux.xml"), pam_scale(range)));
        }
    }
    files
        .into_iter()
        .map(|(path, text)| {
            write_whole(&path, text).map_err(super::io_error(&path))?;
            Ok(path)
        })
        .collect()
}

/// `path` with `.suffix` appended to its whole name (`map.png` → `map.png.aux.xml`).
pub(super) fn appended(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".");
    name.push(suffix);
    PathBuf::from(name)
}

/// An ENVI header for a `width × height` raw map of little-endian `f32` (ENVI data type
/// 4, byte order 0), placed by `map info` when `placement` is given: reference pixel
/// (1.5, 1.5), ENVI's name for the top-left sample's centre.
fn envi_header(width: usize, height: usize, placement: Option<PlanPlacement>) -> String {
    let mut header = format!(
        "ENVI\ndescription = {{geosynth quilt height map}}\nsamples = {width}\n\
         lines = {height}\nbands = 1\nheader offset = 0\nfile type = ENVI Standard\n\
         data type = 4\ninterleave = bsq\nbyte order = 0\nband names = {{height}}\n"
    );
    if let Some(PlanPlacement {
        top_left: [x, y],
        spacing,
    }) = placement
    {
        header.push_str(&format!(
            "map info = {{Arbitrary, 1.5, 1.5, {x}, {y}, {spacing}, {spacing}}}\n"
        ));
    }
    header
}

/// A world file: the x and y steps along a row, then down a column, then the top-left
/// sample's centre.
fn world_file(PlanPlacement { top_left, spacing }: PlanPlacement) -> String {
    let [x, y] = top_left;
    format!("{spacing}\n0\n0\n{}\n{x}\n{y}\n", -spacing)
}

/// A GDAL auxiliary file giving band 1 the scale and offset that turn a 16-bit grey level
/// back into the height `lo + grey · (hi − lo) / 65535`.
fn pam_scale((lo, hi): (f32, f32)) -> String {
    let scale = (f64::from(hi) - f64::from(lo)) / 65535.0;
    format!(
        "<PAMDataset>\n  <PAMRasterBand band=\"1\">\n    <Description>height</Description>\n    \
         <Offset>{lo}</Offset>\n    <Scale>{scale}</Scale>\n  </PAMRasterBand>\n\
         </PAMDataset>\n"
    )
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn only_a_grid_along_x_and_y_with_z_up_is_placed() {
        let corner = DVec3::new(500_000.5, 4_000_000.25, 12.0);
        let placed = PlanPlacement::of_grid(corner, [DVec3::X, DVec3::Y, DVec3::Z], 0.5, 11);
        assert_eq!(
            placed,
            Some(PlanPlacement {
                top_left: [500_000.5, 4_000_005.25],
                spacing: 0.5
            })
        );
        for axes in [
            [DVec3::Z, DVec3::X, DVec3::Y],
            [DVec3::Y, DVec3::X, -DVec3::Z],
            [DVec3::X, -DVec3::Y, -DVec3::Z],
        ] {
            assert_eq!(PlanPlacement::of_grid(corner, axes, 0.5, 11), None);
        }
    }

    #[test]
    fn a_world_file_steps_right_then_down_from_the_top_left_centre() {
        let placement = PlanPlacement {
            top_left: [10.5, -2.25],
            spacing: 0.125,
        };
        let lines: Vec<f64> = world_file(placement)
            .lines()
            .map(|l| l.parse().unwrap())
            .collect();
        assert_eq!(lines, [0.125, 0.0, 0.0, -0.125, 10.5, -2.25]);
    }

    #[test]
    fn the_envi_header_places_only_a_placed_map() {
        let placement = PlanPlacement {
            top_left: [1.0, 2.0],
            spacing: 0.5,
        };
        let placed = envi_header(7, 3, Some(placement));
        assert!(placed.starts_with("ENVI\n"));
        for line in [
            "samples = 7",
            "lines = 3",
            "data type = 4",
            "byte order = 0",
        ] {
            assert!(placed.lines().any(|l| l == line), "{line} in {placed}");
        }
        assert!(placed.contains("map info = {Arbitrary, 1.5, 1.5, 1, 2, 0.5, 0.5}"));
        assert!(!envi_header(7, 3, None).contains("map info"));
    }

    #[test]
    fn the_grey_scale_turns_levels_back_into_heights() {
        let xml = pam_scale((100.0, 165.535));
        let value = |tag: &str| -> f64 {
            let start = xml.find(&format!("<{tag}>")).unwrap() + tag.len() + 2;
            let end = xml.find(&format!("</{tag}>")).unwrap();
            xml[start..end].parse().unwrap()
        };
        let (offset, scale) = (value("Offset"), value("Scale"));
        assert_eq!(offset, 100.0);
        let top = offset + 65535.0 * scale;
        assert!((top - f64::from(165.535f32)).abs() < 1e-9, "{top}");
    }

    #[test]
    fn sidecars_follow_the_map_and_its_kind() {
        let dir = std::env::temp_dir().join(format!("geosynth_sidecars_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let placement = Some(PlanPlacement {
            top_left: [0.0, 1.0],
            spacing: 0.25,
        });
        let map = MapDescription {
            width: 4,
            height: 5,
            placement,
            grey_range: Some((0.0, 2.0)),
        };
        let names = |files: Vec<PathBuf>| -> Vec<String> {
            files
                .iter()
                .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
                .collect()
        };
        let png = write_map_sidecars(&dir.join("m.png"), false, &map).unwrap();
        assert_eq!(names(png), ["m.pgw", "m.png.aux.xml"]);
        let raw = write_map_sidecars(&dir.join("m_4x5.f32le"), true, &map).unwrap();
        assert_eq!(names(raw), ["m_4x5.f32le.hdr"]);
        let unplaced = MapDescription {
            placement: None,
            grey_range: None,
            ..map
        };
        let none = write_map_sidecars(&dir.join("h.png"), false, &unplaced).unwrap();
        assert!(none.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
