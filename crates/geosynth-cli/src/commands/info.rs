//! `geosynth info`.

use std::path::{Path, PathBuf};

use clap::Args;
use geosynth::core::io::{Geometry, LoadedGeometry};
use geosynth::core::strays::kept_indices;
use geosynth::core::{KdIndex, MeshTopology, PointSet};
use geosynth::imagery;
use geosynth::mls::{
    IsolatedFate, IsolatedPoints, LIKELY_UNORIENTED, MlsParams, isolated_points,
    orientation_disagreement,
};
use geosynth::sdf::nrrd;
use glam::Vec3;
use serde::Serialize;

use super::three_digits;
use crate::input_file::{named, read_geometry};
use crate::output::{print_line, spinner, status};
use crate::{CliResult, Globals};

/// Arguments of `geosynth info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The file to describe: .ply, .obj, .off, .stl, .xyz (.xyzn, .xyzrgb: point clouds, a
    /// point a line), .las (LiDAR points), .pcd (PCL point clouds), .glb or .gltf (glTF
    /// scenes, merged), a picture (.png, .jpg), a raw height field
    /// (`name_WxH.f32le`, or a raw file with an ENVI header beside it: `.f32le`, `.bil`,
    /// `.bsq`, `.bip`, `.img`, `.dat`, `.raw`, `.bin`), a one-band TIFF height field (.tif,
    /// .tiff: a GeoTIFF DEM) or an NRRD volume (.nrrd as `sdf` and `voxel --field` write,
    /// or a detached .nhdr header).
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
    /// Triangles on the same three corners (by position) as an earlier one
    /// ([`TriMesh::duplicate_faces`](geosynth::core::TriMesh::duplicate_faces) after welding).
    duplicate_faces: usize,
    /// How many of those face the other way from the first triangle on their corners.
    reversed_duplicates: usize,
    /// Vertices no face uses (meshes only): some tools drop them or warn.
    unreferenced_vertices: usize,
    topology: Option<TopologyInfo>,
    /// The topology with the vertices that share a position welded
    /// ([`TriMesh::welded`](geosynth::core::TriMesh::welded)), when some do (OBJ files
    /// split vertices along UV seams): the surface's own, seams closed.
    welded_topology: Option<WeldedTopology>,
    normals: bool,
    /// Share of points whose normal faces away from most of their nearest neighbours'
    /// (`mls_surface::orientation_disagreement`); `None` without normals.
    normal_disagreement: Option<f32>,
    /// Normals without a direction (zero), which a tool writes where it computed none
    /// ([`PointSet::directionless_normals`](geosynth::core::PointSet::directionless_normals)).
    zero_normals: usize,
    /// A mesh's vertex normals that face against the faces around their vertex
    /// ([`TriMesh::normals_against_faces`](geosynth::core::TriMesh::normals_against_faces)):
    /// renderers shade them dark. `None` for point sets and meshes without normals.
    normals_against_faces: Option<usize>,
    colors: bool,
    uvs: bool,
    attributes: Vec<AttributeInfo>,
    bbox_min: Option<[f64; 3]>,
    bbox_max: Option<[f64; 3]>,
    /// A point set's points that lie far outside the rest
    /// ([`PointSet::stray_count`](geosynth::core::PointSet::stray_count)), which `reconstruct`, `sdf`
    /// and `quilt` leave out; `None` for meshes, whose far vertices belong to faces.
    stray_points: Option<usize>,
    /// Of a point set's other points, those with fewer than 3 others within twice the
    /// default MLS kernel's reach ([`geosynth::mls::without_isolated`]), which
    /// `reconstruct`, `sdf` and `quilt` leave out unless they are most of the points; `None`
    /// for meshes and for points whose kernel cannot be estimated (all coincident).
    isolated_points: Option<usize>,
    /// How far the reach is, when some are isolated.
    isolated_reach: Option<f32>,
    /// Whether they are more than half of the points, which those commands keep: the
    /// default kernel is too small for the sampling.
    isolated_sparse_sampling: bool,
    comments: Vec<String>,
    /// What the file had that the reader could not keep
    /// ([`LoadedGeometry::notes`](geosynth::core::io::LoadedGeometry::notes)).
    not_kept: Vec<String>,
}

/// Edge topology of a mesh.
#[derive(Debug, Serialize)]
pub struct TopologyInfo {
    closed_manifold: bool,
    components: usize,
    euler_characteristic: i64,
    boundary_edges: usize,
    non_manifold_edges: usize,
    misoriented_edges: usize,
}

/// A mesh's topology after welding the vertices that share a position.
#[derive(Debug, Serialize)]
pub struct WeldedTopology {
    /// Vertices merged into another at the same position.
    merged_vertices: usize,
    #[serde(flatten)]
    topology: TopologyInfo,
}

impl From<&MeshTopology> for TopologyInfo {
    fn from(t: &MeshTopology) -> Self {
        Self {
            closed_manifold: t.is_closed_manifold(),
            components: t.components,
            euler_characteristic: t.euler_characteristic,
            boundary_edges: t.boundary_edges,
            non_manifold_edges: t.non_manifold_edges,
            misoriented_edges: t.misoriented_edges,
        }
    }
}

impl TopologyInfo {
    fn text(&self) -> String {
        format!(
            "{}, {} component(s), Euler characteristic {}, {} border / {} non-manifold / {} \
             misoriented edges",
            if self.closed_manifold {
                "closed manifold"
            } else if self.components == 0 {
                "no faces"
            } else {
                "open or non-manifold"
            },
            self.components,
            self.euler_characteristic,
            self.boundary_edges,
            self.non_manifold_edges,
            self.misoriented_edges
        )
    }
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
        // A weld fails only with more positions than `u32` numbers: then no duplicates
        // and no welded topology are reported.
        let welded = g.mesh().and_then(|m| m.welded_where_needed().ok());
        let (stray_points, isolated) = match g {
            Geometry::Points(p) => {
                let (strays, isolated) = strays_and_isolated(p);
                (Some(strays), isolated)
            }
            Geometry::Mesh(_) => (None, None),
        };
        let duplicates = welded
            .as_ref()
            .map_or_else(Vec::new, |welded| welded.duplicate_faces());
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
            duplicate_faces: duplicates.len(),
            reversed_duplicates: duplicates.iter().filter(|d| d.reversed).count(),
            unreferenced_vertices: g.mesh().map_or(0, |m| m.unreferenced_vertices()),
            topology: g.mesh().map(|m| TopologyInfo::from(&m.topology())),
            welded_topology: g.mesh().zip(welded.as_ref()).and_then(|(m, welded)| {
                (welded.vertex_count() < m.vertex_count()).then(|| WeldedTopology {
                    merged_vertices: m.vertex_count() - welded.vertex_count(),
                    topology: TopologyInfo::from(&welded.topology()),
                })
            }),
            normals: points.normals().is_some(),
            normal_disagreement: orientation_disagreement(points).ok(),
            zero_normals: points.directionless_normals(),
            normals_against_faces: g
                .mesh()
                .filter(|_| points.normals().is_some())
                .map(|m| m.normals_against_faces()),
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
            // In the file's coordinates, in double precision (georeferenced files are read
            // relative to an origin so that their points keep single precision).
            bbox_min: bbox.map(|b| (b.min.as_dvec3() + loaded.origin).to_array()),
            bbox_max: bbox.map(|b| (b.max.as_dvec3() + loaded.origin).to_array()),
            stray_points,
            isolated_points: isolated.map(|i| i.map_or(0, |i| i.count)),
            isolated_reach: isolated.flatten().map(|i| i.reach),
            isolated_sparse_sampling: isolated
                .flatten()
                .is_some_and(|i| i.fate == IsolatedFate::SparseSampling),
            comments: loaded.comments.clone(),
            not_kept: loaded.notes.clone(),
        }
    }

    fn text(&self) -> String {
        let yes = |b: bool| if b { "yes" } else { "no" };
        let attrs: Vec<String> = self
            .attributes
            .iter()
            .map(|a| format!("{} ({})", a.name, a.storage))
            .collect();
        let fmt3 = |v: Option<[f64; 3]>| v.map_or("-".to_string(), corner_text);
        let mut s = format!(
            "file:        {}\nformat:      {} ({})\nkind:        {}\nvertices:    {}\nfaces:       {}\n",
            self.path, self.format, self.encoding, self.kind, self.vertices, self.faces
        );
        if self.faces > 0 {
            s.push_str(&format!("degenerate:  {}\n", self.degenerate_faces));
            if self.duplicate_faces > 0 {
                s.push_str(&format!(
                    "duplicates:  {} triangles on the same corners as another, {} of them \
                     facing the other way\n",
                    self.duplicate_faces, self.reversed_duplicates
                ));
            }
            if self.unreferenced_vertices > 0 {
                s.push_str(&format!(
                    "unused:      {} vertices no face uses\n",
                    self.unreferenced_vertices
                ));
            }
        }
        if let Some(t) = &self.topology {
            s.push_str(&format!("topology:    {}\n", t.text()));
        }
        if let Some(w) = &self.welded_topology {
            s.push_str(&format!(
                "welded:      {} vertices share a position with another; welded, {}\n",
                w.merged_vertices,
                w.topology.text()
            ));
        }
        // By position, as `sdf` and `voxel` judge it (UV seams are not openings).
        let misoriented = self
            .welded_topology
            .as_ref()
            .map(|w| &w.topology)
            .or(self.topology.as_ref())
            .map_or(0, |t| t.misoriented_edges);
        if misoriented > 0 {
            s.push_str(&format!(
                "orientation: {misoriented} edges join triangles that disagree on which side is \
                 out (geosynth sdf and voxel --orient-faces turn them to agree)\n"
            ));
        }
        s.push_str(&format!(
            "normals:     {}\ncolours:     {}\nuvs:         {}\nattributes:  {}\nbbox min:    {}\nbbox max:    {}",
            match self.normal_disagreement {
                Some(_) if self.zero_normals > 0 => format!(
                    "yes, {} of them zero (unset; geosynth normals estimates them all anew)",
                    self.zero_normals
                ),
                Some(share) if share > LIKELY_UNORIENTED => format!(
                    "yes, {:.1}% facing away from most neighbours (unoriented? geosynth normals \
                     re-estimates them, --orient-normals orients them)",
                    100.0 * share
                ),
                Some(share) => format!("yes, {:.1}% facing away from most neighbours", 100.0 * share),
                None if !self.normals && self.faces == 0 => {
                    "no (geosynth normals estimates them)".to_string()
                }
                None => yes(self.normals).to_string(),
            } + &match self.normals_against_faces {
                Some(n) if n > 0 => format!(
                    "; {n} vertex normals face against their faces (renderers shade them dark)"
                ),
                _ => String::new(),
            },
            yes(self.colors),
            yes(self.uvs),
            if attrs.is_empty() { "none".to_string() } else { attrs.join(", ") },
            fmt3(self.bbox_min),
            fmt3(self.bbox_max),
        ));
        match self.stray_points {
            Some(1) => s.push_str(
                "\nstrays:      1 point lies far outside the rest (reconstruct and sdf leave it \
                 out, and quilt under its default box; --keep-strays keeps it)",
            ),
            Some(n) if n > 1 => s.push_str(&format!(
                "\nstrays:      {n} points lie far outside the rest (reconstruct and sdf leave \
                 them out, and quilt under its default box; --keep-strays keeps them)"
            )),
            _ => {}
        }
        if let (Some(count), Some(reach)) = (self.isolated_points, self.isolated_reach) {
            let (verb, pronoun) = if count == 1 {
                ("has", "it")
            } else {
                ("have", "them")
            };
            let found = format!(
                "\nisolated:    {count} point{} {verb} fewer than 3 others within {} (twice the \
                 default MLS kernel's reach)",
                if count == 1 { "" } else { "s" },
                three_digits(reach),
            );
            s.push_str(&found);
            s.push_str(&if self.isolated_sparse_sampling {
                format!(
                    ": more than half of the points, which reconstruct, sdf and quilt keep: the \
                     kernel is too small for their sampling (a larger --kernel reaches {pronoun})"
                )
            } else {
                format!(
                    ": reconstruct, sdf and quilt leave {pronoun} out; --keep-strays keeps {pronoun}"
                )
            });
        }
        for c in &self.comments {
            s.push_str(&format!("\ncomment:     {c}"));
        }
        for n in &self.not_kept {
            s.push_str(&format!("\nnot kept:    {n}"));
        }
        s
    }
}

/// How many of `points` are stray, and the isolated points among the others, as
/// `reconstruct` counts them ([`isolated_points`] with the default kernel): `Some(None)`
/// when none is, `None` when the points have no kernel (all coincident).
fn strays_and_isolated(points: &PointSet) -> (usize, Option<Option<IsolatedPoints>>) {
    let positions = points.positions();
    let kept = kept_indices(positions);
    let strays = positions.len() - kept.len();
    let index = if strays == 0 {
        drop(kept);
        KdIndex::new(positions)
    } else {
        let rest: Vec<Vec3> = kept.into_iter().map(|i| positions[i]).collect();
        KdIndex::new(&rest)
    };
    let isolated = index.ok().and_then(|index| {
        isolated_points(&index, &MlsParams::default(), false)
            .ok()
            .map(|found| found.map(|(_, isolated)| isolated))
    });
    (strays, isolated)
}

/// What `info` reports about a picture or height field.
#[derive(Debug, Serialize)]
pub struct GridInfo {
    path: String,
    format: String,
    kind: &'static str,
    width: usize,
    height: usize,
    channels: Option<String>,
    /// A height field's lowest and highest height, its voids left out (`None` for a
    /// picture, or when every sample is a void).
    min: Option<f32>,
    max: Option<f32>,
    /// A height field's voids: samples on its no-data value or not finite, which
    /// `quilt --heightfield` refuses (`None` for a picture).
    voids: Option<usize>,
    /// A height field's no-data value, when the file names one.
    no_data: Option<f32>,
    /// The first void's column and row (row 0 at the top).
    first_void: Option<[usize; 2]>,
    /// A placed height field's (GeoTIFF tags or ENVI `map info`): model units per sample
    /// along x and y.
    pixel_size: Option<[f64; 2]>,
    /// A placed height field's model x and y of raster point (0, 0), the top-left
    /// sample's outer corner for pixel-is-area.
    raster_origin: Option<[f64; 2]>,
    /// Its coordinate system, when one is named by EPSG code.
    epsg: Option<u16>,
    /// Whether its placement carries GeoTIFF keys (a TIFF's own, or those made for an
    /// ENVI header's system); without them no coordinate system is named.
    geo_keys: Option<bool>,
}

impl GridInfo {
    fn load(path: &Path) -> CliResult<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_uppercase();
        let envi_raw = imagery::is_envi_raw_path(path);
        if imagery::is_heightfield_path(path) || envi_raw {
            let samples = imagery::read_height_samples(path)?;
            let range = samples.range();
            let voids = samples.voids();
            let format = if imagery::is_tiff_path(path) {
                "TIFF"
            } else if envi_raw {
                "raw (ENVI header)"
            } else {
                "raw f32"
            };
            let reference = imagery::GeoReference::of_heightfield(path)?;
            return Ok(Self {
                path: path.display().to_string(),
                format: format.into(),
                kind: "heightfield",
                width: samples.width,
                height: samples.height,
                channels: None,
                min: range.map(|(lo, _)| lo),
                max: range.map(|(_, hi)| hi),
                voids: Some(voids.map_or(0, |v| v.count())),
                no_data: samples.no_data,
                first_void: voids.map(|v| [v.first.0, v.first.1]),
                pixel_size: reference.as_ref().map(|r| [r.scale[0], r.scale[1]]),
                raster_origin: reference.as_ref().map(|r| [r.origin[0], r.origin[1]]),
                epsg: reference.as_ref().and_then(|r| r.epsg()),
                geo_keys: reference.as_ref().map(|r| !r.keys.is_empty()),
            });
        }
        let img = imagery::read_image(path)?;
        Ok(Self {
            path: path.display().to_string(),
            format: if ext == "JPG" { "JPEG".into() } else { ext },
            kind: "image",
            width: img.width() as usize,
            height: img.height() as usize,
            channels: Some(format!("{:?}", img.color())),
            min: None,
            max: None,
            voids: None,
            no_data: None,
            first_void: None,
            pixel_size: None,
            raster_origin: None,
            epsg: None,
            geo_keys: None,
        })
    }

    fn text(&self) -> String {
        let mut s = format!(
            "file:        {}\nformat:      {}\nkind:        {}\nsize:        {} x {}",
            self.path, self.format, self.kind, self.width, self.height
        );
        if let Some(c) = &self.channels {
            s.push_str(&format!("\nchannels:    {c}"));
        }
        if let (Some(lo), Some(hi)) = (self.min, self.max) {
            s.push_str(&format!("\nheights:     {lo} .. {hi}"));
        }
        if let Some([column, row]) = self.first_void {
            let marker = match self.no_data {
                Some(v) => format!("on the no-data value {v} or not finite"),
                None => "not finite".into(),
            };
            s.push_str(&format!(
                "\nvoids:       {} ({marker}; the first at column {column}, row {row}): \
                 `quilt --fill-voids` fills them",
                self.voids.unwrap_or(0)
            ));
        } else if self.voids.is_some() && self.no_data.is_some() {
            s.push_str("\nvoids:       none");
        }
        if let (Some([dx, dy]), Some([x, y])) = (self.pixel_size, self.raster_origin) {
            let system = match (self.epsg, self.geo_keys) {
                (Some(code), _) => format!("EPSG:{code}"),
                (None, Some(true)) => "a coordinate system without an EPSG code".into(),
                _ => "no coordinate system it can name (no EPSG code or GeoTIFF keys)".into(),
            };
            s.push_str(&format!(
                "\nplaced:      {dx} x {dy} per sample from ({x}, {y}), {system}"
            ));
        }
        s
    }
}

/// What `info` reports about an NRRD volume (a distance field, as `sdf` and `voxel` write).
#[derive(Debug, Serialize)]
pub struct VolumeInfo {
    path: String,
    format: &'static str,
    kind: &'static str,
    dims: [usize; 3],
    channels: usize,
    spacing: f32,
    /// Position of node (0, 0, 0), at the file's precision.
    origin: [f64; 3],
    /// Position of the last node.
    far_corner: [f64; 3],
    /// Range of the first channel's finite values (`None` when none is finite).
    min: Option<f32>,
    max: Option<f32>,
    /// Share of nodes with a negative first channel (inside, for a signed distance).
    inside_share: f64,
    /// Values that are NaN or infinite (any channel), of `values`.
    non_finite: usize,
    /// Values in the file (nodes × channels).
    values: usize,
}

impl VolumeInfo {
    fn load(path: &Path) -> CliResult<Self> {
        let volume = nrrd::read_file(path)?;
        let first = volume.data.iter().step_by(volume.channels.max(1));
        let finite: Vec<f32> = first.clone().copied().filter(|v| v.is_finite()).collect();
        let nodes = volume.dims.iter().product::<usize>().max(1);
        Ok(Self {
            path: path.display().to_string(),
            format: "NRRD",
            kind: if volume.channels == 4 {
                "volume (distance + gradient)"
            } else {
                "volume"
            },
            dims: volume.dims,
            channels: volume.channels,
            spacing: volume.spacing,
            origin: volume.origin.to_array(),
            far_corner: volume.far_corner().to_array(),
            min: finite.iter().copied().reduce(f32::min),
            max: finite.iter().copied().reduce(f32::max),
            inside_share: first.filter(|v| **v < 0.0).count() as f64 / nodes as f64,
            non_finite: volume.data.iter().filter(|v| !v.is_finite()).count(),
            values: volume.data.len(),
        })
    }

    fn text(&self) -> String {
        let [x, y, z] = self.dims;
        let mut s = format!(
            "file:        {}\nformat:      {}\nkind:        {}\nsize:        {x} x {y} x {z} \
             nodes, spacing {}\norigin:      {}\nfar corner:  {}",
            self.path,
            self.format,
            self.kind,
            numbers_text([f64::from(self.spacing)]).join(""),
            corner_text(self.origin),
            corner_text(self.far_corner)
        );
        if let (Some(lo), Some(hi)) = (self.min, self.max) {
            let [lo, hi] = numbers_text([f64::from(lo), f64::from(hi)]);
            s.push_str(&format!(
                "\nvalues:      {lo} .. {hi}, {:.1}% of nodes negative (inside)",
                100.0 * self.inside_share
            ));
        }
        if self.non_finite > 0 {
            s.push_str(&format!(
                "\nnon-finite:  {} of {} values",
                self.non_finite, self.values
            ));
        }
        s
    }
}

fn print(globals: Globals, json: bool, value: &impl Serialize, text: String) -> CliResult {
    if json {
        print_line(&serde_json::to_string_pretty(value)?)?;
    } else {
        status(globals, text);
    }
    Ok(())
}

/// Runs `geosynth info`.
pub fn run(args: &InfoArgs, globals: Globals) -> CliResult {
    let path = args.file.as_path();
    if nrrd::is_nrrd_path(path) {
        let info = VolumeInfo::load(path).map_err(named(path))?;
        let text = info.text();
        return print(globals, args.json, &info, text);
    }
    if imagery::is_image_path(path)
        || imagery::is_heightfield_path(path)
        || imagery::is_envi_raw_path(path)
    {
        let info = GridInfo::load(path).map_err(named(path))?;
        let text = info.text();
        return print(globals, args.json, &info, text);
    }
    let loaded = read_geometry(path, globals)?;
    // Stray and isolated points, welds and topology take seconds on millions of points.
    let bar = spinner(globals, "examining the geometry");
    let info = FileInfo::new(path, &loaded);
    bar.finish_and_clear();
    let text = info.text();
    print(globals, args.json, &info, text)
}

/// Numbers printed together (a corner's coordinates, a value range) for the text report:
/// six decimals (micrometres of a metre-based georeferenced scan) when the largest lies
/// between a thousandth and a trillion, seven significant digits in exponent form
/// otherwise, where fixed decimals would print zeros or a run of digits no `f32` holds.
fn numbers_text<const N: usize>(values: [f64; N]) -> [String; N] {
    let largest = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let fixed = largest == 0.0 || (1e-3..1e12).contains(&largest);
    values.map(|v| {
        if fixed {
            format!("{v:.6}")
        } else {
            format!("{v:.6e}")
        }
    })
}

/// A corner's coordinates, by [`numbers_text`].
fn corner_text(c: [f64; 3]) -> String {
    numbers_text(c).join(" ")
}

#[cfg(test)]
mod tests {
    use super::corner_text;

    #[test]
    fn corners_print_with_decimals_or_exponents_by_magnitude() {
        assert_eq!(
            corner_text([0.0, 499_999.000_265, -2.5]),
            "0.000000 499999.000265 -2.500000"
        );
        // A near-zero coordinate beside ordinary ones stays in decimals.
        assert_eq!(
            corner_text([8.6e-18, 4.99, 0.0]),
            "0.000000 4.990000 0.000000"
        );
        assert_eq!(
            corner_text([1e-20, -2e-21, 0.0]),
            "1.000000e-20 -2.000000e-21 0.000000e0"
        );
        assert_eq!(
            corner_text([-2.217e21, 0.5, 1.0]),
            "-2.217000e21 5.000000e-1 1.000000e0"
        );
    }
}
