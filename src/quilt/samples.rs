//! The oriented samples a texture file gives: its points with their own normals, a mesh's
//! vertices with normals from its faces, or a bare point set's points with normals
//! estimated and oriented ([`ExemplarNormals`]).

use std::path::Path;

use glam::Vec3;
use pointset_core::io::Geometry;
use pointset_core::{KdIndex, NormalWeighting, PointSet, RunContext, Stage, TriMesh};

use super::files::texture_file_error;
use crate::Result;
use crate::normals::EstimateNormals;
use crate::sample::SampleSurface;

/// Where the texture readers take an exemplar's normals from
/// ([`super::read_texture_file_with`], [`super::read_texture_file_fitted_with`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ExemplarNormals {
    /// The file's own: a point set's as stored (one without normals is refused), a mesh's
    /// vertex normals, or for a mesh that stores none, normals averaged from its faces.
    #[default]
    AsStored,
    /// For a point set stored without normals (a bare scan, an XYZ file of positions):
    /// normals fitted to each point's `neighbours` nearest (itself included, at least 3)
    /// and oriented by propagation toward the texture's up side, as
    /// [`EstimateNormals`] does. Any normals the file stores are replaced. A mesh is
    /// refused: its normals come from its faces. The orientation's limits are
    /// [`mls_surface::orient_normals`]': reliable on sheets such as terrain and height
    /// fields, not on interlinked thin tubes (chain mail).
    Estimated {
        /// The nearest points each tangent plane is fitted to (12,
        /// [`mls_surface::NORMAL_NEIGHBOURS`], is the default elsewhere).
        neighbours: usize,
    },
}

/// The timing a mesh exemplar's sampling records ([`super::TextureReading::mesh_samples`]).
pub const MESH_SAMPLING_STAGE: &str = "sampling the mesh";

/// A texture file's samples with unit normals, and how many of them were estimated from
/// neighbourhoods that define no normal (0 unless normals were estimated).
pub(super) struct Samples {
    /// The oriented points.
    pub points: PointSet,
    /// Points whose estimated normal is arbitrary across a line
    /// ([`mls_surface::NormalFit::undefined`]).
    pub undefined_normals: usize,
    /// For a mesh read by its vertices: [`longest_edge_spacings`]; `None` otherwise.
    pub longest_edge_spacings: Option<f32>,
}

/// What estimates an exemplar's normals, for the errors that ask for them.
const ESTIMATE_REMEDY: &str = "`geosynth quilt --estimate-normals`, or \
    `ExemplarNormals::Estimated` in the library, estimates them";

/// Refuses (as a message) a point set read as stored whose normals a texture cannot use:
/// none, or some zero (written by a tool that computed none there).
fn check_stored_normals(points: &PointSet) -> std::result::Result<(), String> {
    if points.normals().is_none() {
        return Err(format!(
            "the points have no normals, and patch quilting needs oriented points \
             ({ESTIMATE_REMEDY})"
        ));
    }
    match points.directionless_normals() {
        0 => Ok(()),
        zero => Err(format!(
            "{zero} of the {} normals are zero (unset by the tool that wrote them), and patch \
             quilting needs a direction at every point ({ESTIMATE_REMEDY} all anew)",
            points.len()
        )),
    }
}

/// The samples of a texture file `path` whose geometry is `geometry`, with normals as
/// `normals` says; estimated normals are turned toward `up` (the texture's up side). With
/// `mesh_samples`, a mesh gives about that many points sampled on its surface as a Poisson
/// disk with its faces' normals ([`SampleSurface::about`], seeded by `ctx`) instead of its
/// vertices, and a point set is refused.
///
/// A mesh without vertex normals gets its vertices with normals averaged from the faces
/// (angle-weighted), leaving out vertices no face orients (unreferenced, or on degenerate
/// faces only); a mesh whose vertices no face orients is refused, naming `path`, and so is
/// a mesh with [`ExemplarNormals::Estimated`]; so is a point set read as stored without
/// normals or with zero ones, the message naming how to estimate them. Estimation reports progress and may be
/// cancelled through `ctx`.
pub(super) fn texture_samples(
    path: &Path,
    geometry: Geometry,
    normals: ExemplarNormals,
    mesh_samples: Option<usize>,
    up: Vec3,
    ctx: &mut RunContext,
) -> Result<Samples> {
    let file_error = texture_file_error(path);
    let longest_edge_spacings = match (&geometry, mesh_samples) {
        (Geometry::Mesh(mesh), None) => longest_edge_spacings(mesh)?,
        _ => None,
    };
    let points = match (geometry, normals) {
        (Geometry::Points(_), _) if mesh_samples.is_some() => {
            return Err(file_error(
                "it is a point set: only a mesh's surface is sampled for quilting".into(),
            ));
        }
        (Geometry::Mesh(_), ExemplarNormals::Estimated { .. }) => {
            return Err(file_error(
                "it is a mesh: its normals come from its faces, and only a point set's \
                 normals are estimated"
                    .into(),
            ));
        }
        (Geometry::Points(points), ExemplarNormals::Estimated { neighbours }) => {
            let fit = EstimateNormals { neighbours, up }.run(points, ctx)?;
            return Ok(Samples {
                undefined_normals: fit.undefined.len(),
                points: fit.points,
                longest_edge_spacings: None,
            });
        }
        (Geometry::Mesh(mesh), ExemplarNormals::AsStored) if let Some(count) = mesh_samples => {
            if mesh.area() <= 0.0 {
                return Err(file_error(
                    "every triangle of the mesh has zero area: there is no surface to sample"
                        .into(),
                ));
            }
            let stage = SampleSurface::about(&mesh, count)?;
            ctx.timed(MESH_SAMPLING_STAGE, |ctx| stage.run(mesh, ctx))?
                .points
        }
        (Geometry::Mesh(mesh), ExemplarNormals::AsStored)
            if mesh.vertices().normals().is_none() =>
        {
            let normals = mesh.vertex_normals(NormalWeighting::Angle);
            let oriented: Vec<usize> = (0..normals.len())
                .filter(|&i| normals[i] != Vec3::ZERO)
                .collect();
            if oriented.is_empty() && !normals.is_empty() {
                return Err(file_error(format!(
                    "none of the mesh's {} vertices lies on a face with area, so none has a \
                     normal to quilt with",
                    normals.len()
                )));
            }
            let with_normals = mesh.vertices().clone().with_normals(normals)?;
            with_normals.subset(&oriented)?
        }
        (Geometry::Mesh(mesh), ExemplarNormals::AsStored) => mesh.vertices().clone(),
        (Geometry::Points(points), ExemplarNormals::AsStored) => {
            check_stored_normals(&points).map_err(file_error)?;
            points
        }
    };
    Ok(Samples {
        points,
        undefined_normals: 0,
        longest_edge_spacings,
    })
}

/// A mesh's longest edge over the median distance from one of its vertices to the nearest
/// other ([`super::TextureFile::longest_edge_spacings`]); `None` without an edge or a
/// positive spacing.
fn longest_edge_spacings(mesh: &TriMesh) -> Result<Option<f32>> {
    let positions = mesh.positions();
    let longest = mesh
        .triangles()
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .map(|(a, b)| positions[a as usize].distance(positions[b as usize]))
        .fold(0.0f32, f32::max);
    if longest <= 0.0 || positions.len() < 2 {
        return Ok(None);
    }
    let spacing = KdIndex::new(positions)?.median_spacing()?;
    Ok((spacing > 0.0).then(|| longest / spacing))
}

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};

    use glam::{DVec3, Vec3};
    use pointset_core::io::{self, Geometry, WriteOptions};
    use pointset_core::{CancelFlag, PointSet, RunContext, Stage, Surface};

    use super::ExemplarNormals;
    use crate::normals::EstimateNormals;
    use crate::quilt::{TextureReading, read_texture_file_with, texture_comments};
    use crate::quilt::{
        UpAxis, read_texture_file, read_texture_file_fitted, read_texture_file_fitted_with,
    };

    const TWELVE: ExemplarNormals = ExemplarNormals::Estimated { neighbours: 12 };

    /// Reads `path` with `normals` and, when given, `up`.
    fn read_with(
        path: &Path,
        up: Option<UpAxis>,
        normals: ExemplarNormals,
        ctx: &mut RunContext,
    ) -> crate::Result<crate::quilt::TextureFile> {
        let reading = TextureReading {
            up,
            normals,
            ..TextureReading::default()
        };
        read_texture_file_with(path, &reading, ctx)
    }

    /// Ripples `h = 0.1 sin(3u)` over a 40 × 40 grid of spacing 0.1 in texture
    /// coordinates `(u, v, h)`, with their true unit normals, each point moved a little
    /// along the grid (so that no neighbourhood ties).
    fn ripples() -> Vec<(Vec3, Vec3)> {
        (0..1600)
            .map(|k| {
                let jitter = 0.02 * ((k as f32 * 0.7).sin());
                let (u, v) = ((k % 40) as f32 * 0.1 + jitter, (k / 40) as f32 * 0.1);
                let normal = Vec3::new(-0.3 * (3.0 * u).cos(), 0.0, 1.0).normalize();
                (Vec3::new(u, v, 0.1 * (3.0 * u).sin()), normal)
            })
            .collect()
    }

    /// Writes `positions` (no normals) as a binary PLY with `comments`.
    fn bare_ply(dir: &Path, name: &str, positions: Vec<Vec3>, comments: &[String]) -> PathBuf {
        let path = dir.join(name);
        let mut options = WriteOptions::default();
        for c in comments {
            options = options.comment(c.clone());
        }
        let points = Geometry::Points(PointSet::new(positions).unwrap());
        io::write_geometry(&path, &points, &options).unwrap();
        path
    }

    /// The largest angle, in degrees, between `normals` and `truth`.
    fn worst_angle(normals: &[Vec3], truth: impl Iterator<Item = Vec3>) -> f32 {
        normals
            .iter()
            .zip(truth)
            .map(|(n, t)| n.angle_between(t).to_degrees())
            .fold(0.0, f32::max)
    }

    #[test]
    fn estimated_normals_face_the_texture_up_axis_and_follow_the_surface() {
        let dir = tempfile::tempdir().unwrap();
        let surface = ripples();
        for up in [UpAxis::X, UpAxis::Y, UpAxis::Z] {
            let world: Vec<Vec3> = surface.iter().map(|(p, _)| up.to_world(*p)).collect();
            // The axis given by the caller, and the axis (and box) of the file's comments.
            let bounds = pointset_core::Aabb::from_points(&world).unwrap();
            let plain = bare_ply(dir.path(), "plain.ply", world.clone(), &[]);
            let described = bare_ply(
                dir.path(),
                "described.ply",
                world,
                &texture_comments(&bounds, up),
            );
            for file in [
                read_with(&plain, Some(up), TWELVE, &mut RunContext::new(0)),
                read_with(&described, None, TWELVE, &mut RunContext::new(0)),
            ] {
                let file = file.unwrap();
                assert_eq!((file.texture.up(), file.undefined_normals), (up, 0));
                let canonical = file.texture.canonical_points();
                let worst = worst_angle(
                    canonical.normals().unwrap(),
                    surface.iter().map(|(_, n)| *n),
                );
                assert!(worst < 10.0, "{up:?}: {worst}°");
            }
        }
    }

    #[test]
    fn the_estimate_is_the_estimate_normals_stage_with_its_undefined_count() {
        let dir = tempfile::tempdir().unwrap();
        // Ripples, and scan lines 0.5 apart sampled every 0.01, where 3 neighbours lie on
        // one line and define no normal.
        let lines: Vec<Vec3> = (0..1600)
            .map(|k| Vec3::new((k % 400) as f32 * 0.01, (k / 400) as f32 * 0.5, 0.0))
            .collect();
        let cases = [
            (ripples().into_iter().map(|(p, _)| p).collect::<Vec<_>>(), 7),
            (lines, 3),
        ];
        for (positions, neighbours) in cases {
            let path = bare_ply(dir.path(), "bare.ply", positions.clone(), &[]);
            let normals = ExemplarNormals::Estimated { neighbours };
            let mut ctx = RunContext::new(0);
            let file = read_with(&path, None, normals, &mut ctx).unwrap();
            let stage = EstimateNormals {
                neighbours,
                up: Vec3::Z,
            };
            let fit = stage
                .run(PointSet::new(positions).unwrap(), &mut RunContext::new(0))
                .unwrap();
            let read = file.texture.canonical_points();
            assert_eq!(read.positions(), fit.points.positions());
            assert_eq!(read.normals(), fit.points.normals());
            assert_eq!(file.undefined_normals, fit.undefined.len());
            let stages: Vec<&str> = ctx.timings().iter().map(|(s, _)| s.as_str()).collect();
            assert_eq!(
                stages,
                [mls_surface::FITTING_STAGE, mls_surface::ORIENTING_STAGE]
            );
        }
        assert!(
            read_with(
                &dir.path().join("bare.ply"),
                None,
                ExemplarNormals::Estimated { neighbours: 3 },
                &mut RunContext::new(0)
            )
            .unwrap()
            .undefined_normals
                > 0
        );
    }

    #[test]
    fn the_fitted_plane_of_bare_points_faces_plus_z_or_else_plus_y() {
        let dir = tempfile::tempdir().unwrap();
        // The ripples on planes turned about x by 30° (normal (0, −sin, cos): faces +Z) and
        // by 150° (normal faces −Z: the other side is taken as up) and 90° (normal −Y: the
        // plane is vertical, +Y is taken as up).
        for (degrees, expected) in [
            (30.0f64, DVec3::new(0.0, -0.5, 0.75f64.sqrt())),
            (150.0, DVec3::new(0.0, 0.5, 0.75f64.sqrt())),
            (90.0, DVec3::Y),
        ] {
            let (s, c) = degrees.to_radians().sin_cos();
            let turned: Vec<Vec3> = ripples()
                .iter()
                .map(|(p, _)| {
                    let p = p.as_dvec3();
                    DVec3::new(p.x, p.y * c - p.z * s, p.y * s + p.z * c).as_vec3()
                })
                .collect();
            let path = bare_ply(dir.path(), "turned.ply", turned, &[]);
            let file = read_texture_file_fitted_with(&path, TWELVE, None, &mut RunContext::new(0))
                .unwrap();
            let normal = file.frame.z_axis;
            assert!(
                normal.angle_between(expected) < 2f64.to_radians(),
                "{degrees}°: {normal}"
            );
            // In the plane's frame every estimated normal faces up.
            let canonical = file.texture.canonical_points();
            assert!(canonical.normals().unwrap().iter().all(|n| n.z > 0.5));
        }
    }

    #[test]
    fn meshes_bare_points_and_zero_normals_are_refused_with_what_to_do() {
        let dir = tempfile::tempdir().unwrap();
        let positions: Vec<Vec3> = ripples().into_iter().map(|(p, _)| p).collect();
        let bare = bare_ply(dir.path(), "bare.ply", positions.clone(), &[]);
        let refused = read_texture_file(&bare, None).unwrap_err().to_string();
        assert!(
            refused.contains("bare.ply: the points have no normals")
                && refused.contains("--estimate-normals"),
            "{refused}"
        );
        let mut normals = vec![Vec3::Z; positions.len()];
        normals[5] = Vec3::ZERO;
        normals[9] = Vec3::ZERO;
        let zero = dir.path().join("zero.ply");
        let points = PointSet::new(positions)
            .unwrap()
            .with_normals(normals)
            .unwrap();
        io::write_geometry(&zero, &Geometry::Points(points), &WriteOptions::default()).unwrap();
        let refused = read_texture_file(&zero, None).unwrap_err().to_string();
        assert!(
            refused.contains("2 of the 1600 normals are zero") && refused.contains("all anew"),
            "{refused}"
        );
        let mesh = crate::fixtures::bundled_dir().join("icosphere_mesh.ply");
        let refused = read_with(&mesh, None, TWELVE, &mut RunContext::new(0))
            .unwrap_err()
            .to_string();
        assert!(refused.contains("it is a mesh"), "{refused}");
    }

    #[test]
    fn a_cancelled_estimation_stops_the_reading() {
        let dir = tempfile::tempdir().unwrap();
        let positions: Vec<Vec3> = ripples().into_iter().map(|(p, _)| p).collect();
        let bare = bare_ply(dir.path(), "bare.ply", positions, &[]);
        let flag = CancelFlag::new();
        flag.cancel();
        let mut ctx = RunContext::new(0).with_cancel_flag(flag);
        let stopped = read_with(&bare, None, TWELVE, &mut ctx).unwrap_err();
        assert!(stopped.is_cancelled(), "{stopped}");
    }

    #[test]
    fn a_mesh_is_read_by_its_vertices_or_sampled_on_its_surface() {
        let dir = tempfile::tempdir().unwrap();
        let tile = crate::fixtures::brick_tile_mesh().unwrap();
        let path = dir.path().join("bricks.ply");
        io::write_geometry(
            &path,
            &Geometry::Mesh(tile.clone()),
            &WriteOptions::default(),
        )
        .unwrap();
        // By its vertices: the corners of the grid of brick sides, whose longest edge (a
        // 0.4-wide square cell's diagonal) is 5.7 times their median spacing (a joint's
        // width, 0.1).
        let by_vertices = read_texture_file(&path, None).unwrap();
        assert_eq!(
            by_vertices.texture.canonical_points().len(),
            tile.vertex_count()
        );
        let ratio = by_vertices.longest_edge_spacings.unwrap();
        assert!((5.6..5.7).contains(&ratio), "{ratio}");
        // Sampled: about as many points as asked, on the surface, seeded by the context.
        let reading = TextureReading {
            mesh_samples: Some(3000),
            ..TextureReading::default()
        };
        let sampled = read_texture_file_with(&path, &reading, &mut RunContext::new(0)).unwrap();
        assert_eq!(sampled.longest_edge_spacings, None);
        let points = sampled.texture.canonical_points();
        // The count is a Poisson disk's estimate for a plane: the walls, 0.15 high at a
        // spacing of 0.1, hold fewer (2,643 here).
        assert!((2500..3300).contains(&points.len()), "{}", points.len());
        let surface = crate::sdf::MeshSurface::new(&tile).unwrap();
        let normals = points.normals().unwrap();
        let faces = [Vec3::Z, Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y];
        for (&p, &n) in points.positions().iter().zip(normals) {
            let on = surface.closest_point(p).unwrap();
            assert!(on.point.distance(p) < 1e-4, "{p} lies off the tile");
            // The faces' normals: up on the floor and the tops, across on the walls.
            assert!(faces.iter().any(|f| f.dot(n) > 0.99999), "{p}: normal {n}");
            assert!(
                n.z > 0.99999 || (p.z > 0.0 && p.z < 0.15),
                "{p}: normal {n}"
            );
        }
        // The plate between the bricks and the bricks' tops both have their share.
        let share = |z: f32| {
            let near = points.positions().iter().filter(|p| (p.z - z).abs() < 1e-4);
            near.count() as f32 / points.len() as f32
        };
        assert!(
            share(0.0) > 0.1 && share(0.15) > 0.3,
            "{} {}",
            share(0.0),
            share(0.15)
        );
        let again = read_texture_file_with(&path, &reading, &mut RunContext::new(0)).unwrap();
        assert_eq!(again.texture.canonical_points(), points);
        let other = read_texture_file_with(&path, &reading, &mut RunContext::new(1)).unwrap();
        assert_ne!(other.texture.canonical_points(), points);
        // In a fitted plane too.
        let fitted = read_texture_file_fitted_with(
            &path,
            ExemplarNormals::AsStored,
            Some(3000),
            &mut RunContext::new(0),
        )
        .unwrap();
        assert_eq!(fitted.texture.canonical_points().len(), points.len());
        assert_eq!(fitted.longest_edge_spacings, None);
        let fitted_vertices = read_texture_file_fitted(&path).unwrap();
        assert_eq!(fitted_vertices.longest_edge_spacings, Some(ratio));
    }

    #[test]
    fn a_point_set_or_a_mesh_without_area_is_not_sampled() {
        let dir = tempfile::tempdir().unwrap();
        let positions: Vec<Vec3> = ripples().into_iter().map(|(p, _)| p).collect();
        let path = bare_ply(dir.path(), "bare.ply", positions, &[]);
        let reading = TextureReading {
            mesh_samples: Some(100),
            ..TextureReading::default()
        };
        let refusal = |path: &Path| {
            read_texture_file_with(path, &reading, &mut RunContext::new(0))
                .unwrap_err()
                .to_string()
        };
        let refused = refusal(&path);
        assert!(
            refused.contains("bare.ply: it is a point set: only a mesh's surface"),
            "{refused}"
        );
        // A mesh without area has nothing to sample.
        let flat = dir.path().join("flat.ply");
        let corners = PointSet::new(vec![Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]).unwrap();
        let sliver = pointset_core::TriMesh::new(corners, vec![[0, 1, 2]]).unwrap();
        io::write_geometry(&flat, &Geometry::Mesh(sliver), &WriteOptions::default()).unwrap();
        let refused = refusal(&flat);
        assert!(
            refused.contains("flat.ply: every triangle of the mesh has zero area"),
            "{refused}"
        );
    }
}
