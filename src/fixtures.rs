//! Procedural exemplars: deterministic oriented point samplings of analytic shapes and
//! small meshes. `geosynth fixtures` writes them; the demo and the tests use them.
//!
//! Every generator is a pure function of its arguments (random ones take a seed), so the
//! committed files under `fixtures/` can be regenerated bit for bit.

use std::f32::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use pointset_core::io::{self, Geometry, WriteOptions};
use pointset_core::{Error as CoreError, PointSet, TriMesh, rng};
use rand::RngExt;

use crate::Result;
use crate::preview::UpAxis;

/// Seed used for the committed fixtures.
pub const FIXTURE_SEED: u64 = 20_061_124;

/// One named exemplar.
#[derive(Debug, Clone)]
pub struct Fixture {
    /// Short name, also the file stem.
    pub name: &'static str,
    /// One line saying what it is.
    pub description: &'static str,
    /// The geometry.
    pub geometry: Geometry,
    /// The natural up axis for previews.
    pub up: UpAxis,
}

impl Fixture {
    /// File name under `fixtures/` (always binary little-endian PLY).
    pub fn file_name(&self) -> String {
        format!("{}.ply", self.name)
    }
}

/// `n` points on the unit sphere on a Fibonacci spiral, with outward normals.
pub fn sphere_points(n: usize) -> Result<PointSet> {
    let golden = PI * (3.0 - 5f32.sqrt());
    let dirs: Vec<Vec3> = (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect();
    Ok(PointSet::new(dirs.clone())?.with_normals(dirs)?)
}

/// `n` points uniformly distributed by area on a torus (radii `major`, `minor`, axis +Y),
/// with outward normals.
pub fn torus_points(n: usize, major: f32, minor: f32, seed: u64) -> Result<PointSet> {
    let mut r = rng::rng_from_seed(seed);
    let (mut p, mut nrm) = (Vec::with_capacity(n), Vec::with_capacity(n));
    while p.len() < n {
        let (u, v) = (r.random::<f32>() * TAU, r.random::<f32>() * TAU);
        // Area element ∝ (major + minor cos v): rejection keeps the density uniform.
        if r.random::<f32>() * (major + minor) > major + minor * v.cos() {
            continue;
        }
        let ring = Vec3::new(u.cos(), 0.0, u.sin());
        let normal = ring * v.cos() + Vec3::Y * v.sin();
        p.push(ring * major + normal * minor);
        nrm.push(normal);
    }
    Ok(PointSet::new(p)?.with_normals(nrm)?)
}

/// `n` points uniformly on the open side of a cylinder (radius, height, axis +Y, centred at
/// the origin), with outward normals.
pub fn cylinder_points(n: usize, radius: f32, height: f32, seed: u64) -> Result<PointSet> {
    let mut r = rng::rng_from_seed(seed);
    let (mut p, mut nrm) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for _ in 0..n {
        let a = r.random::<f32>() * TAU;
        let y = (r.random::<f32>() - 0.5) * height;
        let normal = Vec3::new(a.cos(), 0.0, a.sin());
        p.push(normal * radius + Vec3::Y * y);
        nrm.push(normal);
    }
    Ok(PointSet::new(p)?.with_normals(nrm)?)
}

/// A bumpy height field `z = h(x, y)` over `[0, size]²` (Z up): a jittered `res × res`
/// sampling of a sum of random Gaussian bumps, with exact normals from the analytic
/// gradient. Returns the points (with a `height` attribute).
pub fn heightfield_points(res: usize, size: f32, seed: u64) -> Result<PointSet> {
    let mut r = rng::rng_from_seed(seed);
    let bumps: Vec<(Vec2, f32, f32)> = (0..24)
        .map(|_| {
            let c = Vec2::new(r.random::<f32>(), r.random::<f32>()) * size;
            let amp = (0.04 + 0.08 * r.random::<f32>()) * size;
            let width = (0.05 + 0.07 * r.random::<f32>()) * size;
            (c, amp, width)
        })
        .collect();
    let height = |q: Vec2| -> (f32, Vec2) {
        bumps.iter().fold((0.0, Vec2::ZERO), |(h, g), &(c, a, w)| {
            let d = q - c;
            let e = a * (-d.length_squared() / (w * w)).exp();
            (h + e, g - d * (2.0 * e / (w * w)))
        })
    };
    let cell = size / res as f32;
    let (mut p, mut nrm, mut hs) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..res {
        for i in 0..res {
            let jitter = Vec2::new(r.random::<f32>(), r.random::<f32>());
            let q = (Vec2::new(i as f32, j as f32) + jitter) * cell;
            let (h, g) = height(q);
            p.push(Vec3::new(q.x, q.y, h));
            nrm.push(Vec3::new(-g.x, -g.y, 1.0).normalize());
            hs.push(h);
        }
    }
    Ok(PointSet::new(p)?
        .with_normals(nrm)?
        .with_attribute(pointset_core::Attribute::new("height", hs))?)
}

/// The unit icosphere after `subdivisions` midpoint subdivisions of an icosahedron
/// (3 → 642 vertices, 1280 faces), outward-oriented, with exact normals.
pub fn icosphere_mesh(subdivisions: u32) -> Result<TriMesh> {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut verts: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, verts: &mut Vec<Vec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                verts.push(((verts[a as usize] + verts[b as usize]) * 0.5).normalize());
                (verts.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let ab = midpoint(a, b, &mut verts);
            let bc = midpoint(b, c, &mut verts);
            let ca = midpoint(c, a, &mut verts);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    let points = PointSet::new(verts.clone())?.with_normals(verts)?;
    Ok(TriMesh::new(points, faces)?)
}

/// A welded torus mesh (radii `major`, `minor`, axis +Y) with `nu × nv` quads split into
/// triangles, outward-oriented, with exact normals.
pub fn torus_mesh(nu: u32, nv: u32, major: f32, minor: f32) -> Result<TriMesh> {
    if nu < 3 || nv < 3 {
        return Err(CoreError::InvalidParameter {
            name: "nu/nv",
            value: format!("{nu}/{nv}"),
            expected: "at least 3 segments each way".into(),
        }
        .into());
    }
    let (mut p, mut nrm) = (Vec::new(), Vec::new());
    for i in 0..nu {
        let u = TAU * i as f32 / nu as f32;
        let ring = Vec3::new(u.cos(), 0.0, u.sin());
        for j in 0..nv {
            let v = TAU * j as f32 / nv as f32;
            let normal = ring * v.cos() + Vec3::Y * v.sin();
            p.push(ring * major + normal * minor);
            nrm.push(normal);
        }
    }
    let id = |i: u32, j: u32| (i % nu) * nv + (j % nv);
    let mut faces = Vec::with_capacity((2 * nu * nv) as usize);
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            faces.push([a, d, c]);
            faces.push([a, c, b]);
        }
    }
    Ok(TriMesh::new(PointSet::new(p)?.with_normals(nrm)?, faces)?)
}

/// All committed fixtures, generated with [`FIXTURE_SEED`].
pub fn all() -> Result<Vec<Fixture>> {
    all_with_seed(FIXTURE_SEED)
}

/// All fixtures, with the random ones generated from `seed`.
pub fn all_with_seed(seed: u64) -> Result<Vec<Fixture>> {
    Ok(vec![
        Fixture {
            name: "sphere_points",
            description: "2000 oriented points on the unit sphere (Fibonacci spiral)",
            geometry: Geometry::Points(sphere_points(2000)?),
            up: UpAxis::Y,
        },
        Fixture {
            name: "torus_points",
            description: "3000 oriented points uniform by area on a torus (R = 1, r = 0.35)",
            geometry: Geometry::Points(torus_points(3000, 1.0, 0.35, seed)?),
            up: UpAxis::Y,
        },
        Fixture {
            name: "cylinder_points",
            description: "2000 oriented points on an open cylinder (r = 0.5, h = 2)",
            geometry: Geometry::Points(cylinder_points(2000, 0.5, 2.0, seed)?),
            up: UpAxis::Y,
        },
        Fixture {
            name: "heightfield_points",
            description: "64x64 jittered samples of a bumpy height field over [0,2]^2, Z up",
            geometry: Geometry::Points(heightfield_points(64, 2.0, seed)?),
            up: UpAxis::Z,
        },
        Fixture {
            name: "icosphere_mesh",
            description: "unit icosphere, 3 subdivisions (642 vertices, 1280 faces)",
            geometry: Geometry::Mesh(icosphere_mesh(3)?),
            up: UpAxis::Y,
        },
        Fixture {
            name: "torus_mesh",
            description: "welded torus mesh, 48x24 quads (R = 1, r = 0.35)",
            geometry: Geometry::Mesh(torus_mesh(48, 24, 1.0, 0.35)?),
            up: UpAxis::Y,
        },
    ])
}

/// Writes every fixture (random ones from `seed`; [`FIXTURE_SEED`] reproduces the committed
/// files) into `dir`, created if missing, and returns the written paths.
pub fn write_all(dir: &Path, seed: u64) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|source| CoreError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let options = WriteOptions::default().comment("geosynth procedural fixture");
    all_with_seed(seed)?
        .iter()
        .map(|f| {
            let path = dir.join(f.file_name());
            io::write_geometry(&path, &f.geometry, &options.clone().comment(f.description))?;
            Ok(path)
        })
        .collect()
}

/// The `fixtures/` folder of this source tree (where the committed fixtures live).
pub fn bundled_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures")
}
