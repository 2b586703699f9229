//! Mesh simplification under error quadrics: topology kept, shape kept (against brute-force
//! distances and the analytic surface), boundaries, seams and vertex data, limits and
//! errors, and the shared meshes.

use glam::{DVec3, Vec3};
use pointset_core::simplify::{Simplified, SimplifiedNormals, SimplifyParams, simplify_mesh};
use pointset_core::{
    Attribute, CancelFlag, Error, NormalWeighting, PointSet, RunContext, ScalarType, TriMesh, rng,
};
use proptest::prelude::*;
use rand::RngExt;

use super::load;

fn simplified(mesh: &TriMesh, params: &SimplifyParams) -> Simplified {
    simplify_mesh(mesh, params, &mut RunContext::new(0)).unwrap()
}

/// A torus of major radius `big` and tube radius `small` about the z axis: `around` ×
/// `tube` quads split into triangles facing out; each vertex pushed along its normal by
/// `bump(i, j)`.
fn torus(around: u32, tube: u32, big: f32, small: f32, bump: impl Fn(u32, u32) -> f32) -> TriMesh {
    let mut positions = Vec::new();
    for i in 0..around {
        for j in 0..tube {
            let (u, v) = (
                i as f32 / around as f32 * std::f32::consts::TAU,
                j as f32 / tube as f32 * std::f32::consts::TAU,
            );
            let r = small + bump(i, j);
            let ring = big + r * v.cos();
            positions.push(Vec3::new(ring * u.cos(), ring * u.sin(), r * v.sin()));
        }
    }
    let index = |i: u32, j: u32| (i % around) * tube + (j % tube);
    let mut faces = Vec::new();
    for i in 0..around {
        for j in 0..tube {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    TriMesh::new(PointSet::new(positions).unwrap(), faces).unwrap()
}

/// A `n` × `n` grid over the unit square, its heights `height(x, y)`.
fn sheet(n: u32, height: impl Fn(f32, f32) -> f32) -> TriMesh {
    let side = n + 1;
    let positions = (0..side * side)
        .map(|k| {
            let (x, y) = ((k % side) as f32 / n as f32, (k / side) as f32 / n as f32);
            Vec3::new(x, y, height(x, y))
        })
        .collect();
    let mut faces = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let v = y * side + x;
            faces.push([v, v + 1, v + side + 1]);
            faces.push([v, v + side + 1, v + side]);
        }
    }
    TriMesh::new(PointSet::new(positions).unwrap(), faces).unwrap()
}

/// The distance from `p` to the triangle `abc` (Ericson's closest-point regions).
fn point_triangle_distance(p: DVec3, [a, b, c]: [DVec3; 3]) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return p.distance(a + ab * (d1 / (d1 - d3)));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return p.distance(a + ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return p.distance(b + (c - b) * w);
    }
    let denom = 1.0 / (va + vb + vc);
    p.distance(a + ab * (vb * denom) + ac * (vc * denom))
}

/// The largest distance from a vertex of `from` to the surface of `to`, by brute force.
fn one_sided_distance(from: &TriMesh, to: &TriMesh) -> f64 {
    let triangles: Vec<[DVec3; 3]> = to
        .triangles()
        .iter()
        .map(|t| t.map(|v| to.positions()[v as usize].as_dvec3()))
        .collect();
    from.positions()
        .iter()
        .map(|p| {
            triangles
                .iter()
                .map(|&t| point_triangle_distance(p.as_dvec3(), t))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

#[test]
fn the_reference_distance_agrees_with_sampled_triangles() {
    let mut g = rng::stream(3, 0);
    for _ in 0..200 {
        let mut point = || DVec3::new(g.random(), g.random(), g.random()) * 2.0 - 1.0;
        let (t, p) = ([point(), point(), point()], point());
        let sampled = (0..=60)
            .flat_map(|i| (0..=60 - i).map(move |j| (i, j)))
            .map(|(i, j)| {
                let (u, v) = (f64::from(i) / 60.0, f64::from(j) / 60.0);
                p.distance(t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v)
            })
            .fold(f64::INFINITY, f64::min);
        let exact = point_triangle_distance(p, t);
        assert!(
            exact <= sampled + 1e-12 && sampled - exact < 0.05,
            "{exact} {sampled}"
        );
    }
}

#[test]
fn a_torus_stays_a_closed_torus_near_its_surface() {
    let mesh = torus(64, 32, 1.0, 0.35, |_, _| 0.0);
    let out = simplified(&mesh, &SimplifyParams::faces(400));
    let topology = out.mesh.topology();
    assert!(topology.is_closed_manifold(), "{topology:?}");
    assert_eq!((topology.components, topology.euler_characteristic), (1, 0));
    assert!(
        out.mesh.face_count() <= 400 && out.mesh.face_count() >= 390,
        "{:?}",
        out.report
    );
    assert_eq!(out.report.faces_after, out.mesh.face_count());
    assert_eq!(
        out.report.faces_before - out.report.faces_after,
        2 * out.report.collapses
    );
    // Every vertex near the analytic torus, every face facing out of the tube.
    for p in out.mesh.positions() {
        let ring = (p.x.hypot(p.y) - 1.0).hypot(p.z);
        assert!(
            (ring - 0.35).abs() < 0.02,
            "{p} is {ring} from the tube's centre line"
        );
    }
    for (t, n) in out.mesh.triangles().iter().zip(out.mesh.face_normals()) {
        let centroid = t
            .iter()
            .map(|&v| out.mesh.positions()[v as usize])
            .sum::<Vec3>()
            / 3.0;
        let axis = Vec3::new(centroid.x, centroid.y, 0.0).normalize();
        assert!(
            n.dot(centroid - axis) > 0.0,
            "a face turned inward at {centroid}"
        );
    }
    // Two-sided distance to the input, brute force, against the regular torus of as many
    // faces (20 × 10 quads), whose vertices lie on the surface.
    let regular = torus(20, 10, 1.0, 0.35, |_, _| 0.0);
    let there = one_sided_distance(&mesh, &out.mesh);
    let back = one_sided_distance(&out.mesh, &mesh);
    let regular_there = one_sided_distance(&mesh, &regular);
    assert!(
        there < regular_there && back < regular_there,
        "{there} {back} {regular_there}"
    );
}

#[test]
fn the_error_limit_bounds_every_collapse() {
    let mesh = torus(48, 24, 1.0, 0.35, |_, _| 0.0);
    // A curved surface: no two vertices merge on all their planes.
    let none = simplified(&mesh, &SimplifyParams::faces(0).max_error(0.0));
    assert_eq!(none.report.collapses, 0);
    assert!(none.report.refused_error > 0);
    assert_eq!(none.mesh, mesh);
    let some = simplified(&mesh, &SimplifyParams::faces(0).max_error(0.004));
    assert!(some.report.collapses > 100, "{:?}", some.report);
    assert!(some.report.max_collapse_error <= 0.004);
    // A looser limit goes further.
    let more = simplified(&mesh, &SimplifyParams::faces(0).max_error(0.02));
    assert!(more.mesh.face_count() < some.mesh.face_count());
    assert!(more.mesh.topology().is_closed_manifold());
}

#[test]
fn a_flat_sheet_keeps_its_outline_and_its_plane() {
    let mesh = sheet(16, |_, _| 0.5);
    let out = simplified(&mesh, &SimplifyParams::faces(2));
    assert!(out.mesh.face_count() <= 4, "{:?}", out.report);
    assert!((out.mesh.area() - 1.0).abs() < 1e-5, "{}", out.mesh.area());
    assert!(out.mesh.positions().iter().all(|p| p.z == 0.5));
    let topology = out.mesh.topology();
    assert_eq!((topology.components, topology.euler_characteristic), (1, 1));
    assert_eq!(topology.non_manifold_edges, 0);
}

#[test]
fn a_curved_sheet_keeps_its_boundary_on_its_outline() {
    let mesh = sheet(32, wave);
    let out = simplified(&mesh, &SimplifyParams::faces(300));
    let topology = out.mesh.topology();
    assert_eq!((topology.components, topology.euler_characteristic), (1, 1));
    assert_eq!(topology.non_manifold_edges, 0);
    // Boundary vertices stay on the square's sides.
    // The constraint planes are a penalty: a corner may slip by a little.
    let on_side = |v: f32| v.abs() < 1e-3 || (v - 1.0).abs() < 1e-3;
    let inside = |v: f32| (-1e-3..=1.0 + 1e-3).contains(&v);
    for p in out.mesh.positions() {
        assert!(inside(p.x) && inside(p.y), "{p}");
    }
    let mut boundary = std::collections::HashMap::new();
    for t in out.mesh.triangles() {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            *boundary.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    for (&(a, b), _) in boundary.iter().filter(|(_, n)| **n == 1) {
        for v in [a, b] {
            let p = out.mesh.positions()[v as usize];
            assert!(
                on_side(p.x) || on_side(p.y),
                "boundary vertex {p} left the outline"
            );
        }
    }
    assert!((out.mesh.area() - mesh.area()).abs() < 0.01 * mesh.area());
    assert!(one_sided_distance(&mesh, &out.mesh) < 0.01);
}

/// A wavy height field over the unit square.
fn wave(x: f32, y: f32) -> f32 {
    0.1 * (6.0 * x).sin() * (5.0 * y).cos()
}

/// [`sheet`]`(24, ..)` split along x = 0.5 from y = 0 up to the row before `rows`: those
/// vertices doubled, the copy used by the faces on the right, as a mesh is split where its
/// texture coordinates jump (25 rows: split in two).
fn split_sheet(whole: &TriMesh, rows: u32) -> TriMesh {
    let (side, seam_x) = (25u32, 12);
    let positions = whole.positions();
    let mut split_positions = positions.to_vec();
    let mut copies = std::collections::HashMap::new();
    let faces: Vec<[u32; 3]> = whole
        .triangles()
        .iter()
        .map(|t| {
            let right = t.iter().any(|&v| v % side > seam_x);
            t.map(|v| {
                if right && v % side == seam_x && v / side < rows {
                    *copies.entry(v).or_insert_with(|| {
                        split_positions.push(positions[v as usize]);
                        split_positions.len() as u32 - 1
                    })
                } else {
                    v
                }
            })
        })
        .collect();
    TriMesh::new(PointSet::new(split_positions).unwrap(), faces).unwrap()
}

#[test]
fn seams_stay_joined() {
    // Two halves of a wavy sheet, split along x = 0.5 with the seam's vertices doubled.
    let split = split_sheet(&sheet(24, wave), 25);
    assert_eq!(split.topology().components, 2);
    let out = simplified(&split, &SimplifyParams::faces(200));
    assert_eq!(out.report.seam_edges, 24);
    assert!(out.mesh.face_count() <= 200, "{:?}", out.report);
    // The halves are still apart (no vertex of one is used by the other) ...
    assert_eq!(out.mesh.topology().components, 2);
    // ... but welded by position they make one sheet with one boundary loop, as before.
    let welded = out.mesh.welded().unwrap();
    let topology = welded.topology();
    assert_eq!((topology.components, topology.euler_characteristic), (1, 1));
    assert_eq!(topology.non_manifold_edges, 0);
    assert_eq!(topology.boundary_edges, welded.topology().boundary_edges);
    // The seam was simplified too, along its line.
    let seam: Vec<Vec3> = out
        .mesh
        .positions()
        .iter()
        .copied()
        .filter(|p| (p.x - 0.5).abs() < 1e-3)
        .collect();
    assert!(seam.len() < 50, "{}", seam.len());
    assert_eq!(seam.len() % 2, 0, "each seam point twice");
}

#[test]
fn vertices_on_a_non_manifold_edge_stay() {
    // A fin: a third sheet standing on the middle line of a flat sheet.
    let flat = sheet(8, |_, _| 0.0);
    let mut positions = flat.positions().to_vec();
    let mut faces = flat.triangles().to_vec();
    let base: Vec<u32> = (0..9).map(|x| 4 * 9 + x).collect();
    let top: Vec<u32> = (0..9)
        .map(|x| {
            positions.push(Vec3::new(x as f32 / 8.0, 0.5, 0.3));
            positions.len() as u32 - 1
        })
        .collect();
    for x in 0..8 {
        faces.push([base[x], base[x + 1], top[x + 1]]);
        faces.push([base[x], top[x + 1], top[x]]);
    }
    let mesh = TriMesh::new(PointSet::new(positions.clone()).unwrap(), faces).unwrap();
    assert!(mesh.topology().non_manifold_edges > 0);
    let out = simplified(&mesh, &SimplifyParams::faces(0));
    assert!(out.report.frozen_vertices >= 9, "{:?}", out.report);
    for &v in &base {
        let p = positions[v as usize];
        assert!(out.mesh.positions().contains(&p), "{p} moved");
    }
    assert!(out.mesh.face_count() < mesh.face_count());
    assert_eq!(
        out.mesh.topology().non_manifold_edges,
        mesh.topology().non_manifold_edges
    );
}

#[test]
fn colours_blend_and_labels_stay_labels() {
    let mesh = sheet(16, |x, y| 0.2 * (x * 3.0).sin() * y);
    let n = mesh.vertex_count();
    let xs: Vec<f32> = mesh.positions().iter().map(|p| p.x).collect();
    let vertices = mesh
        .vertices()
        .clone()
        .with_normals(vec![Vec3::Z; n])
        .unwrap()
        .with_attribute(
            Attribute::new("red", xs.iter().map(|x| (x * 255.0).round()).collect())
                .with_storage(ScalarType::U8),
        )
        .unwrap()
        .with_attribute(
            Attribute::new(
                "patch",
                xs.iter()
                    .map(|&x| if x < 0.5 { 3.0 } else { 7.0 })
                    .collect(),
            )
            .with_storage(ScalarType::I32),
        )
        .unwrap()
        .with_attribute(Attribute::new("weight", xs.clone()))
        .unwrap();
    let uvs = mesh.positions().iter().map(|p| p.truncate()).collect();
    let mesh = TriMesh::new(vertices, mesh.triangles().to_vec())
        .unwrap()
        .with_uvs(uvs)
        .unwrap();
    let out = simplified(&mesh, &SimplifyParams::faces(60));
    let v = out.mesh.vertices();
    let red = v.attribute("red").unwrap();
    assert_eq!(red.storage(), ScalarType::U8);
    let patch = v.attribute("patch").unwrap().values();
    assert!(patch.iter().all(|&l| l == 3.0 || l == 7.0));
    let weight = v.attribute("weight").unwrap().values();
    let uvs = out.mesh.uvs().unwrap();
    for (i, p) in out.mesh.positions().iter().enumerate() {
        // Each value followed its vertex: interpolated where it moved.
        assert!((weight[i] - p.x).abs() < 0.07, "{} at {p}", weight[i]);
        assert!((red.values()[i] - p.x * 255.0).abs() < 0.07 * 255.0 + 1.0);
        assert_eq!(red.values()[i], red.values()[i].round());
        assert!(uvs[i].distance(p.truncate()) < 0.1);
    }
    assert!(
        v.normals()
            .unwrap()
            .iter()
            .all(|n| (n.length() - 1.0).abs() < 1e-5)
    );
}

/// Each vertex's normal as the angle-weighted mean of the faces that have a corner at its
/// position, whichever vertex that corner uses (brute force over the faces).
fn normals_by_position(mesh: &TriMesh) -> Vec<Vec3> {
    let key = |p: Vec3| p.to_array().map(|c| (c + 0.0).to_bits());
    let mut sums = std::collections::HashMap::new();
    for t in mesh.triangles() {
        let p = t.map(|v| mesh.positions()[v as usize]);
        let unit = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        for k in 0..3 {
            let (e1, e2) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
            *sums.entry(key(p[k])).or_insert(Vec3::ZERO) += unit * e1.angle_between(e2);
        }
    }
    mesh.positions()
        .iter()
        .map(|&p| sums[&key(p)].normalize())
        .collect()
}

/// The largest angle, in degrees, between `mesh`'s stored normals and `reference`.
fn largest_turn(mesh: &TriMesh, reference: &[Vec3]) -> f32 {
    let normals = mesh.vertices().normals().unwrap();
    normals
        .iter()
        .zip(reference)
        .map(|(n, r)| n.angle_between(*r).to_degrees())
        .fold(0.0, f32::max)
}

#[test]
fn recomputed_normals_are_smooth_across_a_seam_that_ends_inside() {
    // A wavy sheet split along half of its middle line, from its edge to its centre, with
    // the same normals on both sides of the split: one smooth surface.
    let split = split_sheet(&sheet(24, wave), 12);
    let smooth = normals_by_position(&split);
    let split = TriMesh::new(
        split.vertices().clone().with_normals(smooth).unwrap(),
        split.triangles().to_vec(),
    )
    .unwrap();
    let recompute = SimplifyParams {
        normals: SimplifiedNormals::Recompute,
        ..SimplifyParams::faces(150)
    };
    let out = simplified(&split, &recompute);
    assert_eq!(out.report.seam_edges, 12);
    assert!(out.mesh.face_count() <= 150);
    // Both sides of what is left of the split, and the seam's end, are shaded as one.
    let reference = normals_by_position(&out.mesh);
    assert!(largest_turn(&out.mesh, &reference) < 0.01);
    assert_eq!(out.mesh.normals_against_faces(), 0);
    // Interpolated normals (the default) are not the faces' (the check can tell them
    // apart), and closer to the wave's own normals than the faces' are.
    let interpolated = simplified(&split, &SimplifyParams::faces(150)).mesh;
    assert!(largest_turn(&interpolated, &normals_by_position(&interpolated)) > 1.0);
    let from_wave = |mesh: &TriMesh| {
        let normals = mesh.vertices().normals().unwrap();
        let turns = mesh.positions().iter().zip(normals).map(|(p, n)| {
            let slope = (
                0.6 * (6.0 * p.x).cos() * (5.0 * p.y).cos(),
                -0.5 * (6.0 * p.x).sin() * (5.0 * p.y).sin(),
            );
            n.angle_between(Vec3::new(-slope.0, -slope.1, 1.0))
                .to_degrees()
        });
        turns.sum::<f32>() / mesh.vertex_count() as f32
    };
    let (kept, faceted) = (from_wave(&interpolated), from_wave(&out.mesh));
    assert!(kept < faceted, "{kept}° {faceted}°");
}

#[test]
fn an_interpolated_normal_never_faces_against_its_faces() {
    // Found by `bumpy_tori_stay_tori` with a thousand cases: simplified as far as it goes,
    // one vertex of this torus had an interpolated normal facing into the tube.
    let bumps: Vec<f32> = {
        let mut g = rng::stream(13854264220369092682, 0);
        (0..20 * 18).map(|_| g.random_range(-0.05..0.05)).collect()
    };
    let mut mesh = torus(20, 18, 1.0, 0.35, |i, j| bumps[(i * 18 + j) as usize]);
    mesh.compute_normals(NormalWeighting::Angle).unwrap();
    let out = simplified(&mesh, &SimplifyParams::faces(0));
    assert_eq!(out.mesh.normals_against_faces(), 0);
}

#[test]
fn hard_edges_stay_creased_with_either_normals() {
    // A cube of six 6 × 6 grids, flat shaded: each grid's vertices its own, with its
    // face's normal, so every edge of the cube is a crease.
    let (mut positions, mut normals, mut faces) = (Vec::new(), Vec::new(), Vec::new());
    let n = 6u32;
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let normal = Vec3::AXES[axis] * sign;
            let (u, v) = if sign > 0.0 {
                (Vec3::AXES[(axis + 1) % 3], Vec3::AXES[(axis + 2) % 3])
            } else {
                (Vec3::AXES[(axis + 2) % 3], Vec3::AXES[(axis + 1) % 3])
            };
            let first = positions.len() as u32;
            for j in 0..=n {
                for i in 0..=n {
                    let (s, t) = (
                        i as f32 / n as f32 * 2.0 - 1.0,
                        j as f32 / n as f32 * 2.0 - 1.0,
                    );
                    positions.push(normal + s * u + t * v);
                    normals.push(normal);
                }
            }
            for j in 0..n {
                for i in 0..n {
                    let a = first + j * (n + 1) + i;
                    faces.push([a, a + 1, a + n + 2]);
                    faces.push([a, a + n + 2, a + n + 1]);
                }
            }
        }
    }
    let cube = TriMesh::new(
        PointSet::new(positions)
            .unwrap()
            .with_normals(normals)
            .unwrap(),
        faces,
    )
    .unwrap();
    for normals in [SimplifiedNormals::Recompute, SimplifiedNormals::Interpolate] {
        let params = SimplifyParams {
            normals,
            ..SimplifyParams::faces(24)
        };
        let out = simplified(&cube, &params);
        assert!(out.mesh.face_count() <= 24, "{:?}", out.report);
        let welded = out.mesh.welded().unwrap().topology();
        assert!(welded.is_closed_manifold() && welded.euler_characteristic == 2);
        // Every corner still carries its own face's normal: no crease was smoothed over.
        let stored = out.mesh.vertices().normals().unwrap();
        for (t, face) in out.mesh.triangles().iter().zip(out.mesh.face_normals()) {
            for &v in t {
                assert!(
                    stored[v as usize].abs_diff_eq(face, 1e-6),
                    "{normals:?}: {face}"
                );
            }
        }
    }
}

#[test]
fn faces_with_a_repeated_corner_and_lone_vertices_are_left_out() {
    let mesh = torus(24, 12, 1.0, 0.35, |_, _| 0.0);
    let mut positions = mesh.positions().to_vec();
    positions.push(Vec3::splat(5.0));
    let mut faces = mesh.triangles().to_vec();
    faces.push([0, 0, 1]);
    let mesh = TriMesh::new(PointSet::new(positions).unwrap(), faces).unwrap();
    let out = simplified(&mesh, &SimplifyParams::faces(100));
    assert_eq!(out.report.faces_with_repeated_corners, 1);
    assert_eq!(out.report.vertices_without_faces, 1);
    assert!(out.mesh.topology().is_closed_manifold());
    assert_eq!(out.mesh.unreferenced_vertices(), 0);
}

#[test]
fn small_components_are_never_removed() {
    // A lone triangle and a tetrahedron beside a torus: neither can shrink further.
    let mesh = torus(24, 12, 1.0, 0.35, |_, _| 0.0);
    let mut positions = mesh.positions().to_vec();
    let mut faces = mesh.triangles().to_vec();
    let first = positions.len() as u32;
    positions.extend([
        Vec3::new(3.0, 0.0, 0.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(3.0, 1.0, 0.0),
        Vec3::new(6.0, 0.0, 0.0),
        Vec3::new(7.0, 0.0, 0.0),
        Vec3::new(6.0, 1.0, 0.0),
        Vec3::new(6.0, 0.0, 1.0),
    ]);
    faces.push([first, first + 1, first + 2]);
    let t = first + 3;
    faces.extend([
        [t, t + 2, t + 1],
        [t, t + 1, t + 3],
        [t + 1, t + 2, t + 3],
        [t, t + 3, t + 2],
    ]);
    let mesh = TriMesh::new(PointSet::new(positions).unwrap(), faces).unwrap();
    let out = simplified(&mesh, &SimplifyParams::faces(0));
    let topology = out.mesh.topology();
    assert_eq!(topology.components, 3, "{:?}", out.report);
    assert_eq!(topology.euler_characteristic, 1 + 2);
    assert!(out.report.refused_topology > 0);
}

#[test]
fn parameters_out_of_range_and_empty_meshes_are_refused() {
    let mesh = sheet(2, |_, _| 0.0);
    let cases = [
        (SimplifyParams::faces(1).max_error(-1.0), "max_error"),
        (SimplifyParams::faces(1).max_error(f64::NAN), "max_error"),
        (
            SimplifyParams {
                max_face_turn: 0.0,
                ..SimplifyParams::faces(1)
            },
            "max_face_turn",
        ),
        (
            SimplifyParams {
                max_face_turn: 181.0,
                ..SimplifyParams::faces(1)
            },
            "max_face_turn",
        ),
        (
            SimplifyParams {
                boundary_weight: -2.0,
                ..SimplifyParams::faces(1)
            },
            "boundary_weight",
        ),
        (
            SimplifyParams {
                boundary_weight: f64::INFINITY,
                ..SimplifyParams::faces(1)
            },
            "boundary_weight",
        ),
    ];
    for (params, expected) in cases {
        match simplify_mesh(&mesh, &params, &mut RunContext::new(0)) {
            Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, expected),
            other => panic!("{params:?}: {other:?}"),
        }
    }
    let empty = TriMesh::new(PointSet::new(vec![Vec3::ZERO]).unwrap(), vec![]).unwrap();
    assert!(matches!(
        simplify_mesh(&empty, &SimplifyParams::faces(0), &mut RunContext::new(0)),
        Err(Error::EmptyInput { .. })
    ));
}

#[test]
fn a_cancelled_run_stops() {
    let mesh = torus(128, 64, 1.0, 0.35, |_, _| 0.0);
    let cancel = CancelFlag::new();
    cancel.cancel();
    let mut ctx = RunContext::new(0).with_cancel_flag(cancel);
    assert!(matches!(
        simplify_mesh(&mesh, &SimplifyParams::faces(0), &mut ctx),
        Err(Error::Cancelled)
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Bumpy tori of any resolution, simplified to any target: closed, one piece, a
    /// torus, no face of zero area, no face turned inside out, and the same result twice.
    #[test]
    fn bumpy_tori_stay_tori(
        around in 12u32..40,
        tube in 6u32..20,
        seed in any::<u64>(),
        keep in 0.0f64..0.9,
    ) {
        let bumps: Vec<f32> = {
            let mut g = rng::stream(seed, 0);
            (0..around * tube).map(|_| g.random_range(-0.05..0.05)).collect()
        };
        let mut mesh = torus(around, tube, 1.0, 0.35, |i, j| bumps[(i * tube + j) as usize]);
        mesh.compute_normals(NormalWeighting::Angle).unwrap();
        let target = (mesh.face_count() as f64 * keep) as usize;
        let out = simplified(&mesh, &SimplifyParams::faces(target));
        let topology = out.mesh.topology();
        prop_assert!(topology.is_closed_manifold(), "{:?}", topology);
        prop_assert_eq!((topology.components, topology.euler_characteristic), (1, 0));
        prop_assert!(out.mesh.degenerate_faces().is_empty());
        prop_assert!(out.mesh.duplicate_faces().is_empty());
        prop_assert_eq!(out.mesh.normals_against_faces(), 0);
        prop_assert_eq!(&out, &simplified(&mesh, &SimplifyParams::faces(target)));
        let recompute = SimplifyParams {
            normals: SimplifiedNormals::Recompute,
            ..SimplifyParams::faces(target)
        };
        let faceted = simplified(&mesh, &recompute).mesh;
        prop_assert_eq!(faceted.normals_against_faces(), 0);
        prop_assert_eq!(faceted.positions(), out.mesh.positions());
    }
}

// ---------------------------------------------------------------- shared meshes

#[test]
fn shared_closed_meshes_keep_their_genus_and_shape() {
    for (rel, target, euler) in [
        ("meshes/bunny_watertight.obj", 7000, 2),
        ("meshes/fertility.off", 1500, -6),
    ] {
        let Some(loaded) = load("shared_closed_meshes_simplify", rel) else {
            return;
        };
        let mesh = loaded.geometry.mesh().unwrap().clone();
        let out = simplified(&mesh, &SimplifyParams::faces(target));
        let topology = out.mesh.topology();
        assert!(topology.is_closed_manifold(), "{rel}: {topology:?}");
        assert_eq!(topology.euler_characteristic, euler, "{rel}");
        assert!(out.mesh.face_count() <= target, "{rel}: {:?}", out.report);
        assert!(
            out.mesh.face_count() >= target * 98 / 100,
            "{rel}: {:?}",
            out.report
        );
        let diagonal = f64::from(mesh.bounding_box().unwrap().diagonal());
        let back = one_sided_distance(&out.mesh, &mesh) / diagonal;
        assert!(back < 0.005, "{rel}: {back}");
    }
}

#[test]
fn spot_keeps_its_seams_and_the_raw_scan_its_odd_edges() {
    // Spot's OBJ is 13 pieces split along its texture seams, one closed surface welded.
    let Some(loaded) = load("spot_simplify", "meshes/spot_triangulated.obj") else {
        return;
    };
    let mesh = loaded.geometry.mesh().unwrap().clone();
    let out = simplified(&mesh, &SimplifyParams::faces(600));
    assert!(out.report.seam_edges > 100, "{:?}", out.report);
    assert!(out.mesh.face_count() <= 600);
    assert_eq!(out.mesh.topology().components, mesh.topology().components);
    let welded = out.mesh.welded().unwrap().topology();
    assert!(welded.is_closed_manifold(), "{welded:?}");
    assert_eq!(welded.euler_characteristic, 2);
    // UVs are interpolated, never extrapolated: they stay within the input's range.
    let range = |uvs: &[glam::Vec2]| {
        uvs.iter()
            .fold((glam::Vec2::MAX, glam::Vec2::MIN), |(lo, hi), &uv| {
                (lo.min(uv), hi.max(uv))
            })
    };
    let ((lo, hi), (out_lo, out_hi)) = (range(mesh.uvs().unwrap()), range(out.mesh.uvs().unwrap()));
    assert!(
        out_lo.cmpge(lo).all() && out_hi.cmple(hi).all(),
        "{out_lo} {out_hi} {lo} {hi}"
    );
    let diagonal = f64::from(mesh.bounding_box().unwrap().diagonal());
    assert!(one_sided_distance(&out.mesh, &mesh) / diagonal < 0.01);

    // The raw Stanford scan: holes and edges of three faces.
    let Some(loaded) = load("raw_scan_simplify", "meshes/stanford_bunny_res2.ply") else {
        return;
    };
    let scan = loaded.geometry.mesh().unwrap().clone();
    let out = simplified(&scan, &SimplifyParams::faces(4000));
    assert!(out.report.frozen_vertices > 0);
    assert!(out.mesh.face_count() <= 4000, "{:?}", out.report);
    let (before, after) = (scan.topology(), out.mesh.topology());
    assert_eq!(after.non_manifold_edges, before.non_manifold_edges);
    assert_eq!(after.euler_characteristic, before.euler_characteristic);
    assert_eq!(after.components, before.components);
    // The scan's confidence and intensity values came along.
    for name in ["confidence", "intensity"] {
        assert!(out.mesh.vertices().attribute(name).is_some(), "{name}");
    }
}
