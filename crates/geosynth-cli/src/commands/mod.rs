//! One module per subcommand.

pub mod convert;
pub mod demo;
pub mod demo_terrain;
pub mod fixtures;
pub mod info;
pub mod normals;
pub mod point_prep;
pub mod quilt;
pub mod reconstruct;
pub mod render;
pub mod sample;
pub mod sheet_heights;
pub mod sheet_mesh;
pub mod simplify;
pub mod voxel;
pub mod voxel_memory;
pub mod warp;

use std::path::Path;

use clap::Args;
use geosynth::core::{KdIndex, PointSet, TriMesh};
use geosynth::mls::{
    LIKELY_UNORIENTED, ORIENTATION_NEIGHBOURS, orientation_disagreement,
    orientation_disagreement_with,
};
use geosynth::reconstruct::FieldParams;
use geosynth::sdf::{MeshSign, MeshSurface, PointSign};
use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};

use crate::CliResult;
use crate::params_file::{ParamsFile, RecordedInput};

/// The `N` comma-separated values of a flag such as `--size W,H`, each parsed as a `T`;
/// the error names the expected `form` (`"W,H"`).
pub(crate) fn comma_values<T: std::str::FromStr, const N: usize>(
    s: &str,
    form: &str,
) -> Result<[T; N], String> {
    let values: Vec<T> = s
        .split(',')
        .map(|p| p.trim().parse::<T>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("`{s}` is not {form}"))?;
    <[T; N]>::try_from(values).map_err(|_| format!("`{s}` needs {N} values, {form}"))
}

/// Triangles probed for intersecting parts before a mesh is signed by pseudo-normals
/// (about 0.1 s on 2 cores).
const PROBED_TRIANGLES: usize = 4096;

/// `--sign`, for the commands that sample a signed distance (`sdf`, `reconstruct`,
/// `voxel`).
#[derive(Debug, Clone, Copy, Args)]
pub struct SignArgs {
    /// How distances are signed: `local`, by the nearest piece of surface (a mesh's
    /// pseudo-normals, exact on one closed mesh; a point set's MLS surface; open sheets
    /// such as terrains and scans keep a sign; alias `pseudo-normal`), or `winding`,
    /// inside where the generalized winding number exceeds ½ (solids built from
    /// intersecting or nearly closed pieces, such as the Utah teapot; closed point sets
    /// with parts thinner than the kernel or stray normals, such as the chameleon).
    #[arg(long, value_enum, default_value_t = SignArg::Local)]
    sign: SignArg,
    /// Turn a mesh's triangles to agree with their neighbours before signing (closed parts
    /// facing out, open parts the way most of their triangles face): for meshes whose
    /// triangles disagree on which side is out (`info` counts misoriented edges), which
    /// either sign rule gets wrong near them. Point sets are left as they are, with a note.
    #[arg(long)]
    orient_faces: bool,
}

/// `mesh` with its triangles made to agree
/// ([`TriMesh::consistently_oriented`](geosynth::core::TriMesh::consistently_oriented)), and
/// a line saying what changed (`--orient-faces`).
pub fn orient_faces(mesh: TriMesh) -> CliResult<(TriMesh, String)> {
    let (oriented, change) = mesh.consistently_oriented()?;
    let mut line = format!(
        "oriented faces: {} of {} turned over ({} part(s))",
        change.flipped_faces,
        oriented.face_count(),
        change.parts
    );
    if change.conflicting_edges > 0 {
        line.push_str(&format!(
            "; {} edges could not be made to agree (a non-orientable part, or edges of more \
             than two triangles)",
            change.conflicting_edges
        ));
    }
    Ok((oriented, line))
}

/// The note for `--orient-faces` given a point set, read from `path`: it has no triangles
/// to turn and is left as it is.
pub fn no_faces_to_orient(path: &Path) -> String {
    format!(
        "note: {} is a point set: --orient-faces turns a mesh's triangles, and it has none \
         (`geosynth normals` orients a point set's normals)",
        path.display()
    )
}

/// `--sign` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum SignArg {
    /// The nearest piece of surface.
    #[value(alias = "pseudo-normal")]
    Local,
    /// The generalized winding number.
    Winding,
}

/// How `sdf` and `voxel` read a mesh: the option their reports record under
/// [`INPUT_OPTIONS_KEY`](crate::params_file::INPUT_OPTIONS_KEY), so that `--params REPORT`
/// reads it as the reported run did.
#[derive(Debug, Default, Clone, Copy, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MeshInputOptions {
    /// `--orient-faces`.
    pub orient_faces: bool,
}

impl RecordedInput for MeshInputOptions {}

impl SignArgs {
    /// These settings with `--orient-faces` on also when `file` records it, and the input
    /// options to record in the report.
    pub fn with_recorded(&self, file: &ParamsFile) -> CliResult<(Self, MeshInputOptions)> {
        let recorded: MeshInputOptions = file.input_options()?;
        let orient_faces = self.orient_faces || recorded.orient_faces;
        Ok((
            Self {
                orient_faces,
                ..*self
            },
            MeshInputOptions { orient_faces },
        ))
    }

    /// The rule asked for, for meshes.
    pub fn mesh_rule(&self) -> MeshSign {
        match self.sign {
            SignArg::Local => MeshSign::PseudoNormal,
            SignArg::Winding => MeshSign::WindingNumber,
        }
    }

    /// `params` with both sign rules set as asked.
    pub fn apply(&self, params: FieldParams) -> FieldParams {
        let points = match self.sign {
            SignArg::Local => PointSign::Implicit,
            SignArg::Winding => PointSign::WindingNumber,
        };
        params.mesh_sign(self.mesh_rule()).point_sign(points)
    }

    /// `mesh` with its triangles made to agree
    /// ([`TriMesh::consistently_oriented`](geosynth::core::TriMesh::consistently_oriented))
    /// when `--orient-faces` was given, with a line saying what changed; otherwise `mesh`
    /// as it is.
    pub fn oriented(&self, mesh: TriMesh) -> CliResult<(TriMesh, Option<String>)> {
        if !self.orient_faces {
            return Ok((mesh, None));
        }
        let (oriented, line) = orient_faces(mesh)?;
        Ok((oriented, Some(line)))
    }

    /// A note when `mesh`'s signs by `rule` may be wrong somewhere: triangles that disagree
    /// on which side is out (either rule; without `--orient-faces`), and, for
    /// pseudo-normals, an open or non-manifold mesh or closed parts that intersect
    /// (triangles inside other parts). `None` otherwise.
    pub fn note(&self, mesh: &TriMesh, rule: MeshSign) -> CliResult<Option<String>> {
        // By position: seams where a file splits its vertices (UVs) are not openings.
        let topology = mesh.welded_where_needed()?.topology();
        if topology.misoriented_edges > 0 && !self.orient_faces {
            return Ok(Some(format!(
                "note: {} edges join triangles that disagree on which side is out, so \
                 signs near them are wrong by either rule; --orient-faces turns the \
                 triangles to agree first",
                topology.misoriented_edges
            )));
        }
        if rule == MeshSign::WindingNumber {
            return Ok(None);
        }
        let remedy = "--sign winding signs by the generalized winding number instead";
        if !topology.is_closed_manifold() {
            return Ok(Some(format!(
                "note: the mesh is not closed ({} open, {} non-manifold, {} misoriented \
                 edges), so each node takes the side of the nearest piece: right for an open \
                 sheet such as a terrain; for a solid with gaps or intersecting pieces, \
                 {remedy}",
                topology.boundary_edges, topology.non_manifold_edges, topology.misoriented_edges
            )));
        }
        if topology.components < 2 {
            return Ok(None);
        }
        let (inside, probed) =
            MeshSurface::new(mesh)?.triangles_inside_other_parts(PROBED_TRIANGLES);
        Ok((inside > 0).then(|| {
            format!(
                "note: {inside} of {probed} triangles probed lie inside other parts of the \
                 mesh (intersecting pieces): near them, the side of the nearest piece is \
                 wrong; {remedy}"
            )
        }))
    }
}

/// A note when a point set's normals look unoriented (signs flipping from point to point,
/// as local PCA estimates come): the MLS surface averages them, so they cancel and leave
/// holes or a wrong surface without an error. `None` when they look consistent, when there
/// are none, and when nearly all face the side of `up` (a sheet seen from above, such as
/// a rough terrain scan, whose neighbouring normals may tilt apart but are oriented).
/// `index`, when given, indexes the points' positions (otherwise one is built if needed).
pub fn unoriented_normals_note(
    points: &PointSet,
    up: Option<Vec3>,
    index: Option<&KdIndex>,
) -> Option<String> {
    let normals = points.normals()?;
    if let Some(up) = up {
        let facing_up = normals.iter().filter(|n| n.dot(up) > 0.0).count();
        if facing_up as f32 >= FACING_UP_ORIENTED * normals.len() as f32 {
            return None;
        }
    }
    let share = match index {
        Some(index) => orientation_disagreement_with(index, points),
        None => orientation_disagreement(points),
    }
    .ok()?;
    (share > LIKELY_UNORIENTED).then(|| {
        format!(
            "note: the normals look unoriented: {:.0}% of the points face away from most of \
             their {ORIENTATION_NEIGHBOURS} nearest neighbours (consistently oriented data \
             scores a few percent); the MLS surface needs consistently oriented normals \
             (--orient-normals orients them by propagation)",
            100.0 * share
        )
    })
}

/// The share of normals on the up side above which a sheet's normals count as oriented
/// in [`unoriented_normals_note`] (a few steep or overhanging samples allowed).
const FACING_UP_ORIENTED: f32 = 0.99;

/// A note when an input file stored coordinates far from its origin in single precision
/// (`step` apart there, around `origin`), coarser than a hundredth of `scale` (the length
/// `scale_name` describes): reading in double precision cannot restore that.
pub fn single_precision_note(
    origin: DVec3,
    step: f64,
    scale: f64,
    scale_name: &str,
) -> Option<String> {
    (scale > 0.0 && step > 0.01 * scale).then(|| {
        format!(
            "note: the exemplar file stores its coordinates (around {:.0}, {:.0}, {:.0}) in \
             single precision, {step} apart there, {:.2} times {scale_name}; write it in \
             double precision (or nearer the origin) for full precision",
            origin.x,
            origin.y,
            origin.z,
            step / scale
        )
    })
}

/// `x` rounded to three significant digits, printed without trailing noise (0.054, not
/// 0.05396507).
pub(crate) fn three_digits(x: f32) -> String {
    format!("{x:.2e}").parse::<f32>().unwrap_or(x).to_string()
}

#[cfg(test)]
mod tests {
    use super::comma_values;

    #[test]
    fn comma_values_take_exactly_their_count_of_numbers() {
        assert_eq!(comma_values::<f32, 2>(" 2.5, -1", "W,H"), Ok([2.5, -1.0]));
        assert_eq!(comma_values::<usize, 3>("4,5,6", "X,Y,Z"), Ok([4, 5, 6]));
        assert_eq!(
            comma_values::<f32, 2>("1,2,3", "W,H"),
            Err("`1,2,3` needs 2 values, W,H".to_string())
        );
        assert_eq!(
            comma_values::<usize, 3>("4,x,6", "X,Y,Z"),
            Err("`4,x,6` is not X,Y,Z".to_string())
        );
    }
}
