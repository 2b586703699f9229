//! `geosynth info`.

use std::path::PathBuf;

use clap::Args;
use geosynth::core::io::{self, Geometry, LoadedGeometry};
use serde::Serialize;

use crate::output::status;
use crate::{CliResult, Globals};

/// Arguments of `geosynth info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The file to describe (.ply, .obj or .off).
    file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// What `info` reports about a file.
#[derive(Debug, Serialize)]
pub struct FileInfo {
    path: String,
    format: String,
    encoding: String,
    kind: &'static str,
    vertices: usize,
    faces: usize,
    degenerate_faces: usize,
    normals: bool,
    colors: bool,
    uvs: bool,
    attributes: Vec<AttributeInfo>,
    bbox_min: Option<[f32; 3]>,
    bbox_max: Option<[f32; 3]>,
    comments: Vec<String>,
}

/// One attribute channel.
#[derive(Debug, Serialize)]
pub struct AttributeInfo {
    name: String,
    storage: String,
}

impl FileInfo {
    fn new(path: &std::path::Path, loaded: &LoadedGeometry) -> Self {
        let g = &loaded.geometry;
        let points = g.points();
        let bbox = g.bounding_box();
        Self {
            path: path.display().to_string(),
            format: loaded.format.to_string(),
            encoding: loaded.encoding.clone(),
            kind: match g {
                Geometry::Points(_) => "points",
                Geometry::Mesh(_) => "mesh",
            },
            vertices: points.len(),
            faces: g.mesh().map_or(0, |m| m.face_count()),
            degenerate_faces: g.mesh().map_or(0, |m| m.degenerate_faces().len()),
            normals: points.normals().is_some(),
            colors: points.colors().is_some(),
            uvs: g.mesh().is_some_and(|m| m.uvs().is_some()),
            attributes: points
                .attributes()
                .iter()
                .map(|a| AttributeInfo {
                    name: a.name().to_string(),
                    storage: a.storage().to_string(),
                })
                .collect(),
            bbox_min: bbox.map(|b| b.min.to_array()),
            bbox_max: bbox.map(|b| b.max.to_array()),
            comments: loaded.comments.clone(),
        }
    }

    fn text(&self) -> String {
        let yes = |b: bool| if b { "yes" } else { "no" };
        let attrs: Vec<String> = self
            .attributes
            .iter()
            .map(|a| format!("{} ({})", a.name, a.storage))
            .collect();
        let fmt3 = |v: Option<[f32; 3]>| {
            v.map_or("-".to_string(), |v| {
                format!("{:.6} {:.6} {:.6}", v[0], v[1], v[2])
            })
        };
        let mut s = format!(
            "file:        {}\nformat:      {} ({})\nkind:        {}\nvertices:    {}\nfaces:       {}\n",
            self.path, self.format, self.encoding, self.kind, self.vertices, self.faces
        );
        if self.faces > 0 {
            s.push_str(&format!("degenerate:  {}\n", self.degenerate_faces));
        }
        s.push_str(&format!(
            "normals:     {}\ncolours:     {}\nuvs:         {}\nattributes:  {}\nbbox min:    {}\nbbox max:    {}",
            yes(self.normals),
            yes(self.colors),
            yes(self.uvs),
            if attrs.is_empty() { "none".to_string() } else { attrs.join(", ") },
            fmt3(self.bbox_min),
            fmt3(self.bbox_max),
        ));
        for c in &self.comments {
            s.push_str(&format!("\ncomment:     {c}"));
        }
        s
    }
}

/// Runs `geosynth info`.
pub fn run(args: &InfoArgs, globals: Globals) -> CliResult {
    let loaded = io::read_geometry(&args.file)?;
    let info = FileInfo::new(&args.file, &loaded);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&info)?);
    } else {
        status(globals, info.text());
    }
    Ok(())
}
