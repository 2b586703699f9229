//! Height fields in the files GIS tools write: raw `.f32le` sized by an ENVI header, and
//! one-band TIFFs (GeoTIFF DEMs), read by `info` and quilted with `--heightfield`.

use std::path::Path;

use geosynth::imagery::{GeoReference, read_height_samples, write_geotiff};
use serde_json::json;

use crate::{Scratch, arg, height_map_entry, info_json, ok, quilt_height_field_into, refused};

/// A terrain of 40 × 30 heights between about 112 and 128, varying along both axes.
fn terrain() -> (usize, usize, Vec<f32>) {
    let (w, h) = (40usize, 30usize);
    let heights = (0..w * h)
        .map(|i| 120.0 + 8.0 * (0.3 * (i % w) as f32).sin() * (0.2 * (i / w) as f32).cos())
        .collect();
    (w, h, heights)
}

#[test]
fn a_raw_height_field_with_an_envi_header_needs_no_size_in_its_name() {
    let dir = Scratch::new();
    // The terrain in the layout `gdal_translate -of ENVI -ot Float32` writes.
    let (w, h, heights) = terrain();
    let bytes: Vec<u8> = heights.iter().flat_map(|v| v.to_le_bytes()).collect();
    let header = format!(
        "ENVI\ndescription = {{\ndem.f32le}}\nsamples = {w}\nlines = {h}\nbands = 1\n\
         header offset = 0\nfile type = ENVI Standard\ndata type = 4\ninterleave = bsq\n\
         byte order = 0\nmap info = {{UTM, 1, 1, 500000, 4000030, 1, 1, 10, North,WGS-84}}\n"
    );
    // `name` with `data` and, when given, `header` beside it as `name`'s stem + `.hdr`.
    let write = |name: &str, data: &[u8], header: Option<&str>| {
        let raw = dir.path(name);
        std::fs::write(&raw, data).unwrap();
        if let Some(header) = header {
            std::fs::write(raw.with_extension("hdr"), header).unwrap();
        }
        arg(&raw)
    };
    let dem = write("dem.f32le", &bytes, Some(&header));
    let info = info_json(Path::new(&dem));
    assert_eq!(
        (info["width"].as_u64(), info["height"].as_u64()),
        (Some(40), Some(30))
    );
    let (lo, hi) = (info["min"].as_f64().unwrap(), info["max"].as_f64().unwrap());
    assert!(
        lo > 111.9 && lo < 113.0 && hi > 127.0 && hi < 128.1,
        "{lo}..{hi}"
    );
    let (out, map) = (arg(&dir.path("out.ply")), arg(&dir.path("map.f32le")));
    ok(&[
        "quilt",
        "--heightfield",
        &dem,
        "-o",
        &out,
        "--resolution",
        "20",
        "--no-quality",
        "--heightfield-out",
        &map,
    ]);
    // A header that promises more samples than the file has, a no-data marker among the
    // samples, and no size at all: errors that say which.
    let short = write("short.f32le", &bytes[..bytes.len() - 4], Some(&header));
    let mut marked = heights.clone();
    marked[17] = -9999.0;
    let marked: Vec<u8> = marked.iter().flat_map(|v| v.to_le_bytes()).collect();
    let no_data = format!("{header}data ignore value = -9999\n");
    let holed = write("holed.f32le", &marked, Some(&no_data));
    let bare = write("bare.f32le", &bytes, None);
    for (file, message) in [
        (&short, "needs 4800 bytes"),
        (&bare, "or an ENVI header beside it"),
    ] {
        refused(&["info", file], message);
    }
    // `info` describes the void (and leaves it out of the range); the quilt refuses it.
    let info = info_json(Path::new(&holed));
    assert_eq!(
        [&info["voids"], &info["no_data"], &info["first_void"]],
        [&json!(1), &json!(-9999.0), &json!([17, 0])]
    );
    assert!(info["min"].as_f64().unwrap() > 111.9);
    let out = arg(&dir.path("holed.ply"));
    refused(
        &["quilt", "--heightfield", &holed, "-o", &out],
        "1 of its 1200 samples holds the no-data value -9999, the first at column 17, row 0",
    );
    // NaN marks a void without a header's marker, as float DEMs often do.
    let mut nan = heights.clone();
    nan[45] = f32::NAN;
    nan[46] = f32::NAN;
    let nan: Vec<u8> = nan.iter().flat_map(|v| v.to_le_bytes()).collect();
    let nan = write("nan.f32le", &nan, Some(&header));
    let info = info_json(Path::new(&nan));
    assert_eq!(
        [&info["voids"], &info["no_data"], &info["first_void"]],
        [&json!(2), &json!(null), &json!([5, 1])]
    );
    refused(
        &["quilt", "--heightfield", &nan, "-o", &out],
        "2 of its 1200 samples are not finite (NaN or infinite), the first at column 5, row 1",
    );
    // Rendered, the voids are holes: the picture differs from that of the same terrain
    // with the voids filled as the quilt fills them.
    let render = |input: &str, name: &str| {
        let png = dir.path(name);
        ok(&["render", input, "-o", &arg(&png)]);
        std::fs::read(png).unwrap()
    };
    let samples = read_height_samples(Path::new(&nan)).unwrap();
    let (filled, _) = samples.filled().unwrap();
    let filled: Vec<u8> = filled
        .heights()
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let filled = write("filled.f32le", &filled, Some(&header));
    assert!(render(&nan, "holed.png") != render(&filled, "filled.png"));
    // A file without voids is said to have none to fill.
    let said = ok(&[
        "quilt",
        "--heightfield",
        &filled,
        "-o",
        &out,
        "--fill-voids",
        "--resolution",
        "20",
        "--no-quality",
    ]);
    assert!(said.contains("no voids to fill"), "{said}");
    // Filled, the quilt runs; the report counts the voids, and a rerun from it fills
    // them again to the same output.
    let report = arg(&dir.path("filled.json"));
    let quilt = |extra: &[&str]| {
        let mut all = vec!["quilt", "--heightfield", &nan, "-o", &out];
        all.extend_from_slice(extra);
        let said = ok(&all);
        (std::fs::read(&out).unwrap(), said)
    };
    let (filled, said) = quilt(&[
        "--fill-voids",
        "--resolution",
        "20",
        "--no-quality",
        "--report",
        &report,
    ]);
    let recorded: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(recorded["voids_filled"], json!(2));
    assert_eq!(recorded["input_options"]["fill_voids"], json!(true));
    assert!(
        said.contains("filled 2 voids (0.17% of its samples)"),
        "{said}"
    );
    assert!(filled == quilt(&["--params", &report]).0);
}

/// A big-endian TIFF of one band of `i16` samples, `width` × `height` in strips of
/// `rows_per_strip` rows, uncompressed, with `no_data` in GDAL's tag when given: built
/// byte by byte from the TIFF 6.0 layout, so that the reader is checked against the
/// format rather than against the library it uses.
fn int16_tiff(
    width: u16,
    height: u16,
    rows_per_strip: u16,
    samples: &[i16],
    no_data: Option<&str>,
) -> Vec<u8> {
    const SHORT: u16 = 3;
    const LONG: u16 = 4;
    const ASCII: u16 = 2;
    let mut file = b"MM\0\x2a\0\0\0\0".to_vec();
    let strip_samples = usize::from(width) * usize::from(rows_per_strip);
    let (mut offsets, mut counts) = (Vec::new(), Vec::new());
    for strip in samples.chunks(strip_samples) {
        offsets.push(file.len() as u32);
        counts.push(2 * strip.len() as u32);
        file.extend(strip.iter().flat_map(|s| s.to_be_bytes()));
    }
    // Values longer than four bytes lie outside the directory, at an offset.
    let outside = |file: &mut Vec<u8>, bytes: Vec<u8>| {
        let at = file.len() as u32;
        file.extend(bytes);
        file.extend(std::iter::repeat_n(0, file.len() % 2));
        at
    };
    let longs = |values: &[u32]| values.iter().flat_map(|v| v.to_be_bytes()).collect();
    let offsets_at = outside(&mut file, longs(&offsets));
    let counts_at = outside(&mut file, longs(&counts));
    let short = |v: u16| [v.to_be_bytes(), [0, 0]].concat();
    let mut entries: Vec<(u16, u16, u32, Vec<u8>)> = vec![
        (256, SHORT, 1, short(width)),
        (257, SHORT, 1, short(height)),
        (258, SHORT, 1, short(16)),
        (259, SHORT, 1, short(1)),
        (262, SHORT, 1, short(1)),
        (
            273,
            LONG,
            offsets.len() as u32,
            offsets_at.to_be_bytes().to_vec(),
        ),
        (277, SHORT, 1, short(1)),
        (278, SHORT, 1, short(rows_per_strip)),
        (
            279,
            LONG,
            counts.len() as u32,
            counts_at.to_be_bytes().to_vec(),
        ),
        (339, SHORT, 1, short(2)),
    ];
    if let Some(text) = no_data {
        let ascii = [text.as_bytes(), &[0]].concat();
        let at = outside(&mut file, ascii.clone());
        entries.push((42113, ASCII, ascii.len() as u32, at.to_be_bytes().to_vec()));
    }
    let directory = file.len() as u32;
    file[4..8].copy_from_slice(&directory.to_be_bytes());
    file.extend((entries.len() as u16).to_be_bytes());
    for (tag, kind, count, value) in entries {
        file.extend(tag.to_be_bytes());
        file.extend(kind.to_be_bytes());
        file.extend(count.to_be_bytes());
        file.extend(value);
    }
    file.extend(0u32.to_be_bytes());
    file
}

#[test]
fn a_tiff_dem_reads_and_quilts_as_its_raw_twin_does() {
    let dir = Scratch::new();
    // The terrain in centimetres as a 16-bit integer DEM, in three strips of ten rows,
    // and the same heights as a raw float file.
    let (w, h, heights) = terrain();
    let centimetres: Vec<i16> = heights.iter().map(|v| (v * 100.0).round() as i16).collect();
    let tiff = dir.path("dem.tif");
    std::fs::write(&tiff, int16_tiff(40, 30, 10, &centimetres, None)).unwrap();
    let raw = dir.path(&format!("dem_{w}x{h}.f32le"));
    let floats: Vec<u8> = centimetres
        .iter()
        .flat_map(|&c| f32::from(c).to_le_bytes())
        .collect();
    std::fs::write(&raw, floats).unwrap();
    let info = info_json(&tiff);
    assert_eq!(info["format"], "TIFF");
    let lowest = f64::from(*centimetres.iter().min().unwrap());
    let highest = f64::from(*centimetres.iter().max().unwrap());
    assert_eq!(
        [&info["width"], &info["height"], &info["min"], &info["max"]].map(|v| v.as_f64()),
        [Some(40.0), Some(30.0), Some(lowest), Some(highest)]
    );
    // Read sample for sample as the raw file is, the two quilt to the same bytes.
    let quilted = |input: &Path, name: &str| {
        let out = dir.path(name);
        ok(&[
            "quilt",
            "--heightfield",
            &arg(input),
            "-o",
            &arg(&out),
            "--resolution",
            "20",
            "--no-quality",
            "--seed",
            "3",
        ]);
        std::fs::read(out).unwrap()
    };
    assert!(quilted(&tiff, "from_tiff.ply") == quilted(&raw, "from_raw.ply"));
    // The same centimetres as big-endian 16-bit integers after 12 bytes of preamble, in a
    // `.bil` an ENVI header describes: read sample for sample like the others.
    let bil = dir.path("dem.bil");
    let mut data = vec![0xAB; 12];
    data.extend(centimetres.iter().flat_map(|c| c.to_be_bytes()));
    std::fs::write(&bil, &data).unwrap();
    let header = format!(
        "ENVI\nsamples = {w}\nlines = {h}\nbands = 1\nheader offset = 12\n\
         data type = 2\ninterleave = bil\nbyte order = 1\n"
    );
    std::fs::write(dir.path("dem.hdr"), header).unwrap();
    let info = info_json(&bil);
    assert_eq!(info["format"], "raw (ENVI header)");
    assert_eq!(
        [&info["min"], &info["max"]].map(|v| v.as_f64()),
        [Some(lowest), Some(highest)]
    );
    assert!(quilted(&bil, "from_bil.ply") == quilted(&raw, "from_raw.ply"));
    // One sample short of what the header promises.
    std::fs::write(&bil, &data[..data.len() - 2]).unwrap();
    refused(
        &["info", &arg(&bil)],
        "16-bit integers needs 2400 bytes after the header offset of 12",
    );
    // A void on GDAL's no-data value, and a header that promises 30 rows over two strips
    // of 10.
    let mut voided = centimetres.clone();
    voided[123] = -32768;
    let holed = dir.path("holed.tif");
    std::fs::write(&holed, int16_tiff(40, 30, 10, &voided, Some("-32768"))).unwrap();
    let short = dir.path("short.tif");
    std::fs::write(&short, int16_tiff(40, 30, 10, &centimetres[..800], None)).unwrap();
    refused(&["info", &arg(&short)], "cannot read TIFF");
    let info = info_json(&holed);
    assert_eq!(
        [&info["voids"], &info["no_data"], &info["first_void"]],
        [&json!(1), &json!(-32768.0), &json!([3, 3])]
    );
    refused(
        &[
            "quilt",
            "--heightfield",
            &arg(&holed),
            "-o",
            &arg(&dir.path("holed.ply")),
        ],
        "1 of its 1200 samples holds the no-data value -32768",
    );
}

#[test]
fn a_geotiff_dems_quilt_keeps_its_coordinate_system_and_spacing() {
    let dir = Scratch::new();
    // The terrain as a Float32 GeoTIFF in UTM zone 10N, 30 m samples.
    let (w, h, heights) = terrain();
    let field = geosynth::core::HeightField::new(w, h, heights).unwrap();
    let reference = GeoReference {
        scale: [30.0, 30.0, 0.0],
        origin: [562_000.0, 5_125_000.0, 0.0],
        keys: vec![1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32610],
        doubles: None,
        ascii: Some("WGS 84 / UTM zone 10N|".into()),
    };
    let dem = dir.path("dem.tif");
    write_geotiff(&dem, &field, Some(&reference)).unwrap();
    let (out, map, report) = (dir.path("out.ply"), dir.path("map.tif"), dir.path("r.json"));
    let quilt = |map: &Path| quilt_height_field_into(&dem, map, &out, &report);
    let printed = quilt(&map);
    assert!(
        printed.contains("placed at the input DEM's top-left corner"),
        "{printed}"
    );
    // The map lies on the DEM's grid from its top-left corner on, in its units, and
    // `info` says where both lie.
    assert_eq!(GeoReference::read(&map).unwrap(), Some(reference));
    for file in [&dem, &map] {
        let info = info_json(file);
        let placed = ["pixel_size", "raster_origin", "epsg"].map(|k| info[k].to_string());
        assert_eq!(placed, ["[30.0,30.0]", "[562000.0,5125000.0]", "32610"]);
    }
    assert_eq!(height_map_entry(&report)["georeferenced"], true);
    let quilted = geosynth::imagery::read_heightfield(&map).unwrap();
    let (lo, hi) = quilted.range();
    assert!(lo > 110.0 && hi < 130.0, "{lo}..{hi}");
    // A raw map of the same run has no coordinate system to give: not placed.
    quilt(&dir.path("map.f32le"));
    assert_eq!(height_map_entry(&report)["georeferenced"], false);
}

#[test]
fn rough_terrain_gets_no_notes_meant_for_point_set_files() {
    let dir = Scratch::new();
    // White noise: neighbouring normals tilt apart, but a height field's all face up.
    let mut state = 12345u32;
    let heights: Vec<u8> = (0..48 * 48)
        .flat_map(|_| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (f32::from((state >> 16) as u16) / 65535.0).to_le_bytes()
        })
        .collect();
    let noise = dir.path("noise_48x48.f32le");
    std::fs::write(&noise, heights).unwrap();
    let out = dir.path("noise.ply");
    let said = ok(&[
        "quilt",
        "--heightfield",
        &arg(&noise),
        "--relief",
        "1",
        "-o",
        &arg(&out),
        "--no-quality",
        "--resolution",
        "16",
    ]);
    assert!(said.contains("wrote"), "{said}");
    // Neither that its normals look unoriented nor, at a relief as tall as it is wide,
    // that it might have been written with another up axis.
    assert!(!said.contains("note"), "{said}");
    // Its quilt, a rough sheet whose normals all face up, is oriented as a point set too;
    // with every other normal turned over it is not, and the note says so.
    let quilt_again = |path: &std::path::Path| {
        let again = dir.path("again.ply");
        let args = ["quilt", &arg(path), "-o", &arg(&again), "--no-quality"];
        ok(&[&args[..], &["--resolution", "16"]].concat())
    };
    assert!(!quilt_again(&out).contains("unoriented"));
    let sheet = geosynth::core::io::read_geometry(&out).unwrap().geometry;
    let normals: Vec<_> = sheet.points().normals().unwrap().to_vec();
    let flipped: Vec<_> = normals
        .iter()
        .enumerate()
        .map(|(i, &n)| if i % 2 == 0 { -n } else { n })
        .collect();
    let points = sheet.points().clone().with_normals(flipped).unwrap();
    let unoriented = dir.path("unoriented.ply");
    crate::write_with_defaults(&unoriented, &geosynth::core::io::Geometry::Points(points));
    assert!(quilt_again(&unoriented).contains("the normals look unoriented"));
}

#[test]
fn an_envi_dems_map_info_places_its_quilts_geotiff_map() {
    let dir = Scratch::new();
    // The terrain as 32-bit floats in a `.bil`, placed in UTM zone 10N at 30 m by its
    // header's `map info` as GDAL's ENVI driver writes one (ESRI WKT, no EPSG code).
    let (w, h, heights) = terrain();
    let dem = dir.path("dem.bil");
    std::fs::write(
        &dem,
        heights
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<u8>>(),
    )
    .unwrap();
    let header = format!(
        "ENVI\nsamples = {w}\nlines = {h}\nbands = 1\ndata type = 4\nbyte order = 0\n\
         map info = {{UTM, 1, 1, 562000, 5125000, 30, 30, 10, North,WGS-84}}\n\
         coordinate system string = {{PROJCS[\"WGS_1984_UTM_Zone_10N\",UNIT[\"Meter\",1.0]]}}\n"
    );
    std::fs::write(dir.path("dem.hdr"), header).unwrap();
    let info = info_json(&dem);
    assert_eq!(info["epsg"], 32610);
    assert_eq!(
        info["raster_origin"],
        serde_json::json!([562000.0, 5125000.0])
    );
    let (map, out, report) = (dir.path("map.tif"), dir.path("q.ply"), dir.path("r.json"));
    quilt_height_field_into(&dem, &map, &out, &report);
    let placed = GeoReference::read(&map).unwrap().unwrap();
    assert_eq!(
        (placed.scale, placed.origin),
        ([30.0, 30.0, 0.0], [562000.0, 5125000.0, 0.0])
    );
    assert_eq!(placed.epsg(), Some(32610));
}
