//! `geosynth convert`: a point set or mesh from one file format into another.

use std::path::PathBuf;

use clap::Args;
use geosynth::core::io::ply::PlyEncoding;
use geosynth::core::io::{
    FileFormat, Geometry, GltfContainer, PcdEncoding, StlEncoding, WriteOptions,
};

use super::{no_faces_to_orient, orient_faces};
use crate::input_file::read_geometry;
use crate::output::{
    check_geometry_output, check_output_paths, report_not_kept, status, write_geometry_file,
};
use crate::{CliResult, Globals};

/// Arguments of `geosynth convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Point set or mesh to convert (.ply, .obj, .off, .stl, .glb, .gltf; point sets also
    /// .xyz, .xyzn, .xyzrgb, .las and .pcd).
    input: PathBuf,
    /// Output file; its extension picks the format (.ply, .obj, .off, .glb, .gltf; .stl for
    /// a mesh; .xyz, .xyzn, .xyzrgb, .las, .pcd for a point set). Georeferenced input is
    /// written back in place (PLY and PCD as `double`, OBJ, OFF and XYZ with full digits,
    /// LAS as integers on a decimal scale finer than single precision, glTF as the node's
    /// translation); STL, single precision, refuses it.
    #[arg(short, long)]
    output: PathBuf,
    /// Write text: ASCII PLY, STL or PCD (default binary; OBJ, OFF and XYZ are always
    /// text, LAS always binary).
    #[arg(long, conflicts_with = "compressed")]
    ascii: bool,
    /// Write PCD compressed (`DATA binary_compressed`: each field's values together,
    /// compressed with LZF, as PCL writes large clouds); other formats refuse it.
    #[arg(long)]
    compressed: bool,
    /// Turn a mesh's triangles to agree with their neighbours (closed parts facing out,
    /// open parts the way most of their triangles face) before writing. A point set is
    /// written as it is, with a note.
    #[arg(long)]
    orient_faces: bool,
}

/// Runs `geosynth convert`.
pub fn run(args: &ConvertArgs, globals: Globals) -> CliResult {
    check_output_paths([args.output.as_path()], [])?;
    let ext = args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("");
    let format = FileFormat::from_extension(ext);
    if args.compressed && format != Some(FileFormat::Pcd) {
        return Err(format!(
            "cannot write {} compressed: --compressed is for .pcd",
            args.output.display()
        )
        .into());
    }
    let loaded = read_geometry(&args.input, globals)?;
    report_not_kept(globals, &args.input, &loaded.notes);
    let is_mesh = loaded.geometry.mesh().is_some();
    check_geometry_output(&args.output, is_mesh, loaded.origin)?;
    let format = format.ok_or("unknown output format")?;
    let geometry = match loaded.geometry {
        Geometry::Mesh(mesh) if args.orient_faces => {
            let (oriented, line) = orient_faces(mesh)?;
            status(globals, line);
            Geometry::Mesh(oriented)
        }
        Geometry::Points(points) if args.orient_faces => {
            status(globals, no_faces_to_orient(&args.input));
            Geometry::Points(points)
        }
        other => other,
    };
    if args.ascii {
        let always = match format {
            FileFormat::Obj | FileFormat::Off | FileFormat::Xyz(_) => Some("text"),
            FileFormat::Las | FileFormat::Gltf(GltfContainer::Binary) => Some("binary"),
            FileFormat::Gltf(GltfContainer::Json) => Some("JSON, its data in base64"),
            FileFormat::Ply | FileFormat::Stl | FileFormat::Pcd => None,
        };
        if let Some(kind) = always {
            status(
                globals,
                format!("note: {format} is always {kind}; --ascii changes nothing"),
            );
        }
    }
    let (ply, stl, pcd) = if args.ascii {
        (PlyEncoding::Ascii, StlEncoding::Ascii, PcdEncoding::Ascii)
    } else {
        (
            PlyEncoding::BinaryLittleEndian,
            StlEncoding::Binary,
            PcdEncoding::Binary,
        )
    };
    let pcd = if args.compressed {
        PcdEncoding::BinaryCompressed
    } else {
        pcd
    };
    let mut options = WriteOptions::default()
        .origin(loaded.origin)
        .ply_encoding(ply)
        .stl_encoding(stl)
        .pcd_encoding(pcd);
    for comment in &loaded.comments {
        options = options.comment(comment.clone());
    }
    let options = options.comment(format!(
        "converted by geosynth from {}",
        args.input.display()
    ));
    write_geometry_file(&args.output, &geometry, &options, globals)?;
    let faces = geometry.mesh().map_or(0, |m| m.face_count());
    let counts = match format {
        // STL has no vertices of its own: the reader welds corners back by position.
        FileFormat::Stl => format!("{faces} triangles"),
        FileFormat::Xyz(_) | FileFormat::Las | FileFormat::Pcd => {
            format!("{} points", geometry.points().len())
        }
        _ => format!("{} vertices, {faces} triangles", geometry.points().len()),
    };
    status(
        globals,
        format!("wrote {} ({format}): {counts}", args.output.display()),
    );
    Ok(())
}
