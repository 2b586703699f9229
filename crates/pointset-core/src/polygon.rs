//! Splitting a file's polygon faces into triangles.
//!
//! OBJ, OFF and PLY faces may have any number of corners. A convex polygon is split as a
//! fan from its first corner, as every reader here did before. A fan of a concave polygon
//! (an L-shaped n-gon, a letter's outline) covers area outside it and folds over itself:
//! the L-shaped hexagon of area 3 becomes 4 triangles of total area 4, one of them facing
//! the other way. A concave polygon is therefore split by ear clipping in its own plane
//! (the plane of its Newell normal), which covers exactly its area with triangles that all
//! face the polygon's way.
//!
//! Fallbacks, each a fan of what is left: a polygon with no area (its Newell normal is
//! zero), a polygon that crosses itself so that no ear remains, and a concave polygon of
//! more than [`MAX_EAR_CLIPPED_CORNERS`] corners (ear clipping takes time that grows with
//! the cube of the corners in the worst case).

use glam::{DVec2, DVec3, Vec3};

/// Concave polygons with more corners than this are split as fans (see the module docs).
pub const MAX_EAR_CLIPPED_CORNERS: usize = 4096;

/// Appends the triangles of the polygon whose corners are `corners` (indices into
/// `positions`, in the file's order) to `out`: `corners.len() − 2` of them, each listed in
/// the polygon's own winding. A convex polygon gives the fan `[c0, ck, ck+1]`; a concave one
/// is ear-clipped (module docs). Indices must lie inside `positions` (the readers check
/// them first); a polygon of fewer than 3 corners gives nothing.
///
/// ```
/// use glam::Vec3;
/// use pointset_core::triangulate_polygon;
///
/// // An L-shaped hexagon whose first corner does not see the whole polygon.
/// let p = [(2, 1), (2, 2), (0, 2), (0, 0), (1, 0), (1, 1)]
///     .map(|(x, y)| Vec3::new(x as f32, y as f32, 0.0));
/// let mut triangles = Vec::new();
/// triangulate_polygon(&p, &[0, 1, 2, 3, 4, 5], &mut triangles);
/// // Signed areas along +z: all positive, summing to the L's area of 3.
/// let area = |t: &[u32; 3]| {
///     let [a, b, c] = t.map(|i| p[i as usize]);
///     0.5 * (b - a).cross(c - a).z
/// };
/// assert_eq!(triangles.len(), 4);
/// assert!(triangles.iter().all(|t| area(t) > 0.0));
/// assert!((triangles.iter().map(area).sum::<f32>() - 3.0).abs() < 1e-6);
/// ```
pub fn triangulate_polygon(positions: &[Vec3], corners: &[u32], out: &mut Vec<[u32; 3]>) {
    match corners.len() {
        0..=2 => {}
        3 => out.push([corners[0], corners[1], corners[2]]),
        n => match plane_coordinates(positions, corners) {
            Some(flat) if n <= MAX_EAR_CLIPPED_CORNERS && !is_convex(&flat) => {
                clip_ears(&flat, corners, out);
            }
            _ => fan(corners, out),
        },
    }
}

/// The fan `[c0, ck, ck+1]` of `corners`.
fn fan(corners: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..corners.len().saturating_sub(1) {
        out.push([corners[0], corners[k], corners[k + 1]]);
    }
}

/// The corners projected onto the coordinate plane most nearly parallel to the polygon
/// (its Newell normal's largest component dropped), mirrored where needed so that the
/// polygon runs counter-clockwise; `None` when the polygon has no area or a corner lies
/// outside `positions`.
fn plane_coordinates(positions: &[Vec3], corners: &[u32]) -> Option<Vec<DVec2>> {
    let points: Vec<DVec3> = corners
        .iter()
        .map(|&c| positions.get(c as usize).map(|p| p.as_dvec3()))
        .collect::<Option<_>>()?;
    let normal = points
        .iter()
        .zip(points.iter().cycle().skip(1))
        .fold(DVec3::ZERO, |n, (a, b)| n + a.cross(*b));
    let axis = normal.abs().max_position();
    if normal[axis] == 0.0 || !normal[axis].is_finite() {
        return None;
    }
    // Dropping axis a keeps (a+1, a+2) in cyclic order, which preserves orientation.
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let sign = normal[axis].signum();
    Some(
        points
            .iter()
            .map(|p| DVec2::new(p[u], sign * p[v]))
            .collect(),
    )
}

/// Twice the signed area of the triangle `a b c` (positive counter-clockwise).
fn turn(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
}

/// Whether the counter-clockwise polygon turns left (or goes straight) at every corner.
fn is_convex(flat: &[DVec2]) -> bool {
    let n = flat.len();
    (0..n).all(|i| turn(flat[(i + n - 1) % n], flat[i], flat[(i + 1) % n]) >= 0.0)
}

/// Whether `p` lies inside the counter-clockwise triangle `a b c` or on its edges.
fn inside(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    turn(a, b, p) >= 0.0 && turn(b, c, p) >= 0.0 && turn(c, a, p) >= 0.0
}

/// Ear clipping of the counter-clockwise polygon `flat` (the corners' plane coordinates):
/// repeatedly cuts off a corner that turns left and whose triangle holds no other remaining
/// corner (corners at one of its own positions aside, as where a polygon's outline touches
/// itself). When no such corner is left (a polygon that crosses itself), a corner on a
/// straight stretch is cut off, and failing that the rest becomes a fan.
fn clip_ears(flat: &[DVec2], corners: &[u32], out: &mut Vec<[u32; 3]>) {
    let mut left: Vec<usize> = (0..flat.len()).collect();
    // The search for the next ear starts where the last was cut: ears are often neighbours.
    let mut cursor = 0;
    while left.len() > 3 {
        let n = left.len();
        let corner = |i: usize| (left[(i + n - 1) % n], left[i], left[(i + 1) % n]);
        let is_ear = |i: usize| {
            let (a, b, c) = corner(i);
            let (pa, pb, pc) = (flat[a], flat[b], flat[c]);
            turn(pa, pb, pc) > 0.0
                && left.iter().all(|&j| {
                    let p = flat[j];
                    p == pa || p == pb || p == pc || !inside(p, pa, pb, pc)
                })
        };
        let straight = |i: usize| {
            let (a, b, c) = corner(i);
            turn(flat[a], flat[b], flat[c]) == 0.0
        };
        let from_cursor = || (0..n).map(|k| (cursor + k) % n);
        let Some(i) = from_cursor()
            .find(|&i| is_ear(i))
            .or_else(|| from_cursor().find(|&i| straight(i)))
        else {
            break;
        };
        let (a, b, c) = corner(i);
        out.push([corners[a], corners[b], corners[c]]);
        left.remove(i);
        cursor = i.saturating_sub(1);
    }
    let rest: Vec<u32> = left.iter().map(|&i| corners[i]).collect();
    fan(&rest, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangles_of(points: &[Vec3]) -> Vec<[u32; 3]> {
        let corners: Vec<u32> = (0..points.len() as u32).collect();
        let mut out = Vec::new();
        triangulate_polygon(points, &corners, &mut out);
        out
    }

    #[test]
    fn a_convex_polygon_is_its_fan_and_small_ones_pass_through() {
        let square = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        assert_eq!(triangles_of(&square), [[0, 1, 2], [0, 2, 3]]);
        assert_eq!(triangles_of(&square[..3]), [[0, 1, 2]]);
        assert!(triangles_of(&square[..2]).is_empty());
        // Clockwise, and with a straight stretch: still the fan.
        let clockwise = [
            Vec3::ZERO,
            Vec3::Y,
            Vec3::new(0.5, 1.0, 0.0),
            Vec3::ONE,
            Vec3::X,
        ];
        assert_eq!(triangles_of(&clockwise), [[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    }

    #[test]
    fn degenerate_and_self_crossing_polygons_fall_back_to_fans() {
        // All corners on one line: no area.
        let line: Vec<Vec3> = (0..5).map(|i| Vec3::X * i as f32).collect();
        assert_eq!(triangles_of(&line).len(), 3);
        // A bow tie crosses itself; every corner still ends up in n - 2 triangles.
        let bow = [
            Vec3::ZERO,
            Vec3::ONE.with_z(0.0),
            Vec3::X,
            Vec3::Y,
            Vec3::new(-1.0, 0.5, 0.0),
        ];
        assert_eq!(triangles_of(&bow).len(), 3);
    }
}
