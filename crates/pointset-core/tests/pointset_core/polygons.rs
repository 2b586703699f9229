//! Polygon faces split into triangles: property tests on random simple polygons in random
//! planes, against the shoelace area and the fan for convex ones.

use glam::{Quat, Vec2, Vec3};
use pointset_core::triangulate_polygon;
use proptest::prelude::*;

/// A star-shaped polygon: corners at increasing angles around the origin, at the given
/// radii (simple, and concave wherever a radius dips between its neighbours).
fn star(radii: &[f32]) -> Vec<Vec2> {
    let n = radii.len() as f32;
    radii
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let a = std::f32::consts::TAU * i as f32 / n;
            Vec2::new(r * a.cos(), r * a.sin())
        })
        .collect()
}

/// Twice the shoelace area of a counter-clockwise polygon.
fn shoelace(p: &[Vec2]) -> f64 {
    (0..p.len())
        .map(|i| f64::from(p[i].perp_dot(p[(i + 1) % p.len()])))
        .sum()
}

proptest! {
    #[test]
    fn simple_polygons_split_into_their_own_area_facing_their_way(
        radii in proptest::collection::vec(0.2f32..2.0, 3..40),
        axis in prop::array::uniform3(-1.0f32..1.0),
        angle in 0.0f32..6.3,
        offset in prop::array::uniform3(-50.0f32..50.0),
        clockwise in any::<bool>(),
    ) {
        let mut flat = star(&radii);
        if clockwise {
            flat.reverse();
        }
        // Placed in a random plane: rotated and moved.
        let turn = Quat::from_axis_angle(Vec3::from(axis).try_normalize().unwrap_or(Vec3::Z), angle);
        let to_3d = |p: Vec2| turn * p.extend(0.0) + Vec3::from(offset);
        let points: Vec<Vec3> = flat.iter().map(|&p| to_3d(p)).collect();
        let corners: Vec<u32> = (0..points.len() as u32).collect();
        let mut triangles = Vec::new();
        triangulate_polygon(&points, &corners, &mut triangles);
        prop_assert_eq!(triangles.len(), points.len() - 2);
        // In the polygon's plane, every triangle turns the polygon's way, and together
        // they cover its area exactly (no overlap, no fold, nothing outside).
        let sign = if clockwise { -1.0 } else { 1.0 };
        let mut total = 0.0;
        for t in &triangles {
            let [a, b, c] = t.map(|i| flat[i as usize]);
            let twice = sign * f64::from((b - a).perp_dot(c - a));
            prop_assert!(twice > -1e-4, "{t:?} turns the other way: {twice}");
            total += twice;
        }
        let expected = sign * shoelace(&flat);
        prop_assert!((total - expected).abs() < 1e-3 * expected, "{total} vs {expected}");
        // Convex polygons keep the fan every reader made before.
        let n = flat.len();
        let convex = (0..n).all(|i| {
            let (a, b, c) = (flat[(i + n - 1) % n], flat[i], flat[(i + 1) % n]);
            sign * f64::from((b - a).perp_dot(c - b)) >= 0.0
        });
        if convex {
            let fan: Vec<[u32; 3]> = (1..n as u32 - 1).map(|k| [0, k, k + 1]).collect();
            prop_assert_eq!(triangles, fan);
        }
    }
}

#[test]
fn a_concave_polygon_is_not_its_fan() {
    // A comb: five teeth along x, first corner at a tooth's tip.
    let mut flat = vec![Vec2::new(0.0, 0.0), Vec2::new(10.0, 0.0)];
    for k in (0..5).rev() {
        let x = 2.0 * k as f32;
        flat.extend([
            Vec2::new(x + 2.0, 3.0),
            Vec2::new(x + 1.0, 3.0),
            Vec2::new(x + 1.0, 1.0),
        ]);
        flat.push(Vec2::new(x, 1.0));
    }
    flat.pop();
    let points: Vec<Vec3> = flat.iter().map(|p| p.extend(0.0)).collect();
    let corners: Vec<u32> = (0..points.len() as u32).collect();
    let mut triangles = Vec::new();
    triangulate_polygon(&points, &corners, &mut triangles);
    let area: f32 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| flat[i as usize]);
            0.5 * (b - a).perp_dot(c - a)
        })
        .sum();
    // The fan from the first corner folds: some of its triangles turn the other way.
    let fan_folds =
        (1..flat.len() - 1).any(|k| (flat[k] - flat[0]).perp_dot(flat[k + 1] - flat[0]) < 0.0);
    assert!(fan_folds);
    let expected = 0.5 * shoelace(&flat) as f32;
    assert!((area - expected).abs() < 1e-4, "{area} vs {expected}");
    assert!(triangles.iter().all(|t| {
        let [a, b, c] = t.map(|i| flat[i as usize]);
        (b - a).perp_dot(c - a) >= 0.0
    }));
}

#[test]
fn every_reader_splits_a_concave_face_within_its_outline() {
    // The L-shaped hexagon of area 3 (its first corner does not see the whole L), in the
    // plane z = 1, as one face of each text format with polygons.
    let corners = "2 1 1\n2 2 1\n0 2 1\n0 0 1\n1 0 1\n1 1 1\n";
    let obj = format!(
        "{}f 1 2 3 4 5 6\n",
        corners
            .lines()
            .map(|l| format!("v {l}\n"))
            .collect::<String>()
    );
    let off = format!("OFF\n6 1 0\n{corners}6 0 1 2 3 4 5\n");
    let ply = format!(
        "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         {corners}6 0 1 2 3 4 5\n"
    );
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [("l.obj", obj), ("l.off", off), ("l.ply", ply)] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let mesh = pointset_core::io::read_geometry(&path).unwrap().geometry;
        let mesh = mesh.mesh().unwrap();
        let p = mesh.positions();
        assert_eq!(mesh.face_count(), 4, "{name}");
        let mut area = 0.0;
        for t in mesh.triangles() {
            let [a, b, c] = t.map(|i| p[i as usize]);
            let up = 0.5 * (b - a).cross(c - a).z;
            assert!(up > 0.0, "{name}: {t:?} faces down");
            area += up;
        }
        assert!((area - 3.0).abs() < 1e-6, "{name}: {area}");
    }
}

#[test]
fn a_fractional_vertex_index_is_refused_not_rounded() {
    // PLY allows float-typed index lists; 1.5 names no vertex.
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar float vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.ply");
    std::fs::write(&path, ply).unwrap();
    let err = pointset_core::io::read_geometry(&path).unwrap_err();
    assert!(
        matches!(err, pointset_core::Error::InvalidFace { face: 0, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("1.5"), "{err}");
    // Whole numbers in a float list are indices like any other.
    std::fs::write(&path, ply.replace("1.5", "1.0")).unwrap();
    let mesh = pointset_core::io::read_geometry(&path).unwrap().geometry;
    assert_eq!(mesh.mesh().unwrap().triangles(), [[0, 1, 2]]);
}
