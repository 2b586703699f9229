//! Poisson-disk candidates drawn tile by tile, so that the kept samples a candidate is
//! tested against were kept nearby and lately, and sit in the cache.
//!
//! The mesh's box is cut into cubic tiles of [`TILE_SPACINGS`] spacings. Each triangle is
//! clipped to each tile it crosses (in barycentric coordinates, so the pieces keep the
//! weights of their corners), and each piece gets its share of candidates: its area times
//! the candidates per area, rounded down or up at random in proportion (so the expected
//! count is exact), each uniform over the piece. A tile's candidates are shuffled, then
//! tested in that order. The tiles go in eight phases by the parity of their numbers
//! ([`Tiles::phases`]): the tiles of a phase are tested at once, each in a grid of its
//! own holding the samples its 26 neighbours kept in earlier phases; then their samples
//! join the rest in key order, so the result does not depend on the threads. Every order gives a sampling with no two
//! samples closer than the spacing; how this one compares with one random order over the
//! whole surface is measured in the module docs of [`super`].

use glam::{DVec3, Vec3};
use rand::RngExt;
use rand::seq::SliceRandom;

use super::Sample;
use super::disk_grid::NEIGHBOUR_STEPS;
use crate::TriMesh;
use crate::rng::{SeededRng, stream};
use crate::spatial::{CELL_BITS, PackedCells};

/// The side of a tile in spacings.
pub(super) const TILE_SPACINGS: f64 = 16.0;

/// A corner of a clipped triangle: its barycentric weights and its position.
#[derive(Debug, Clone, Copy)]
struct Corner {
    weights: DVec3,
    position: DVec3,
}

/// The tiles the triangles cross, and the triangles crossing each; or the tiles a point
/// set's points lie in, and the points in each.
pub(super) struct Tiles {
    cells: PackedCells,
    /// (tile key, triangle or point) pairs, sorted.
    crossings: Vec<(u64, u32)>,
}

impl Tiles {
    /// The tiles of side `side` from `low` crossed by `mesh`'s triangles of positive
    /// area; `None` when the mesh spans more than 2²¹ tiles along an axis.
    pub(super) fn new(mesh: &TriMesh, low: DVec3, side: f64) -> Option<Self> {
        let cells = PackedCells::new(low, side);
        let positions = mesh.positions();
        let mut crossings = Vec::new();
        for (face, triangle) in mesh.triangles().iter().enumerate() {
            let corners = triangle.map(|v| positions[v as usize]);
            let lowest = corners.iter().fold(Vec3::INFINITY, |m, p| m.min(*p));
            let highest = corners.iter().fold(Vec3::NEG_INFINITY, |m, p| m.max(*p));
            let (first, last) = (cells.key(lowest)?, cells.key(highest)?);
            let corners = corners.map(Vec3::as_dvec3);
            crossed_tiles(&corners, &cells, [unpack(first), unpack(last)], |key| {
                crossings.push((key, face as u32));
            });
        }
        crossings.sort_unstable();
        Some(Self { cells, crossings })
    }

    /// The tiles of side `side` from `low` that hold some of `positions` (each point in
    /// one: the tiles are half open); `None` when the points span more than 2²¹ tiles
    /// along an axis, or one lies below `low`.
    pub(super) fn of_points(positions: &[Vec3], low: DVec3, side: f64) -> Option<Self> {
        let cells = PackedCells::new(low, side);
        let mut crossings = positions
            .iter()
            .enumerate()
            .map(|(i, &p)| Some((cells.key(p)?, i as u32)))
            .collect::<Option<Vec<_>>>()?;
        crossings.sort_unstable();
        Some(Self { cells, crossings })
    }

    /// How many tiles the triangles cross (or the points lie in).
    pub(super) fn count(&self) -> usize {
        self.tiles().count()
    }

    /// Each tile's crossings, in key order.
    fn tiles(&self) -> impl Iterator<Item = &[(u64, u32)]> {
        self.crossings.chunk_by(|a, b| a.0 == b.0)
    }

    /// The tiles in eight phases by the parity of their numbers along x, y and z: two
    /// tiles of one phase have a whole tile between them, so their candidates are more
    /// than 16 spacings apart and can be tested at the same time. Each phase in key
    /// order.
    pub(super) fn phases(&self) -> [Vec<Tile<'_>>; 8] {
        let mut phases: [Vec<Tile<'_>>; 8] = Default::default();
        for crossings in self.tiles() {
            let key = crossings[0].0;
            let [x, y, z] = unpack(key).map(|n| (n % 2) as usize);
            phases[x | y << 1 | z << 2].push(Tile { key, crossings });
        }
        phases
    }

    /// The keys of the 26 tiles around `tile` (those inside the grid).
    pub(super) fn neighbours<'a>(&'a self, tile: &Tile<'_>) -> impl Iterator<Item = u64> + 'a {
        let key = tile.key;
        NEIGHBOUR_STEPS[1..]
            .iter()
            .filter_map(move |step| self.cells.moved(key, *step))
    }

    /// The box of `tile`: its low and high corners.
    pub(super) fn bounds(&self, tile: &Tile<'_>) -> [DVec3; 2] {
        tile_box(&self.cells, unpack(tile.key))
    }

    /// The candidates of `tile`, shuffled (module docs): `per_area` per unit of area,
    /// drawn from the stream of `seed` and the tile's key.
    pub(super) fn candidates(
        &self,
        mesh: &TriMesh,
        tile: &Tile<'_>,
        per_area: f64,
        seed: u64,
    ) -> Vec<Sample> {
        let positions = mesh.positions();
        let mut rng = stream(seed, tile.key);
        let bounds = tile_box(&self.cells, unpack(tile.key));
        let mut candidates = Vec::new();
        for face in tile.items() {
            let corners = mesh.triangles()[face as usize].map(|v| positions[v as usize].as_dvec3());
            let piece = clip(&corners, bounds);
            let area = clipped_area(&piece);
            let count = (per_area * area + rng.random::<f64>()).floor() as usize;
            for _ in 0..count {
                candidates.extend(point_in(&piece, area, &mut rng).map(|weights| {
                    let [a, b, c] = corners;
                    Sample {
                        position: (a + (b - a) * weights.y + (c - a) * weights.z).as_vec3(),
                        face,
                        weights: weights.to_array().map(|w| w as f32),
                    }
                }));
            }
        }
        candidates.shuffle(&mut rng);
        candidates
    }
}

/// One tile: its packed key and the triangles crossing it (or the points in it).
pub(super) struct Tile<'t> {
    key: u64,
    crossings: &'t [(u64, u32)],
}

impl Tile<'_> {
    /// The tile's packed key.
    pub(super) fn key(&self) -> u64 {
        self.key
    }

    /// The triangles crossing the tile, or the points in it, in increasing order.
    pub(super) fn items(&self) -> impl Iterator<Item = u32> + '_ {
        self.crossings.iter().map(|&(_, item)| item)
    }
}

/// The share of a triangle's area below which a piece of it in a tile counts as none:
/// the slivers rounding leaves where a triangle only touches a tile's side or corner.
const NEGLIGIBLE_SHARE: f64 = 1e-12;

/// Calls `crossed` with the key of each tile in the range `[first, last]` (tile numbers,
/// inclusive) where the triangle `corners` has area (more than [`NEGLIGIBLE_SHARE`] of
/// its own): the range is halved along its longest side while the triangle has area in
/// it, so a long sliver across a box of n³ tiles costs about n clippings a tile it
/// crosses, not n³.
fn crossed_tiles(
    corners: &[DVec3; 3],
    cells: &PackedCells,
    range: [[u64; 3]; 2],
    mut crossed: impl FnMut(u64),
) {
    let [a, b, c] = *corners;
    let negligible = NEGLIGIBLE_SHARE * (b - a).cross(c - a).length() * 0.5;
    let mut pending = vec![range];
    while let Some([first, last]) = pending.pop() {
        let [low, _] = tile_box(cells, first);
        let [_, high] = tile_box(cells, last);
        if clipped_area(&clip(corners, [low, high])) <= negligible {
            continue;
        }
        let widths = [0, 1, 2].map(|axis| last[axis] - first[axis]);
        let axis = (0..3).max_by_key(|&a| (widths[a], 3 - a)).unwrap_or(0);
        if widths[axis] == 0 {
            crossed(first[0] | first[1] << CELL_BITS | first[2] << (2 * CELL_BITS));
            continue;
        }
        let middle = first[axis] + widths[axis] / 2;
        let (mut upper_first, mut lower_last) = (first, last);
        lower_last[axis] = middle;
        upper_first[axis] = middle + 1;
        pending.push([upper_first, last]);
        pending.push([first, lower_last]);
    }
}

/// A tile's cell numbers from its packed key.
fn unpack(key: u64) -> [u64; 3] {
    let top = (1 << CELL_BITS) - 1;
    [key & top, (key >> CELL_BITS) & top, key >> (2 * CELL_BITS)]
}

/// The box of the tile with cell numbers `tile`: low and high corners.
/// Each side is computed from its own tile number, so that neighbouring tiles and ranges
/// of tiles share their sides bit for bit.
fn tile_box(cells: &PackedCells, tile: [u64; 3]) -> [DVec3; 2] {
    let side = |numbers: [u64; 3]| {
        cells.low() + DVec3::from_array(numbers.map(|n| n as f64)) * cells.side()
    };
    [side(tile), side(tile.map(|n| n + 1))]
}

/// The part of the triangle `corners` in the half-open box `[low, high)`: a convex
/// polygon (Sutherland–Hodgman), empty when they do not meet.
fn clip(corners: &[DVec3; 3], [low, high]: [DVec3; 2]) -> Vec<Corner> {
    let mut polygon: Vec<Corner> = (0..3)
        .map(|i| Corner {
            weights: DVec3::AXES[i],
            position: corners[i],
        })
        .collect();
    for axis in 0..3 {
        // Inside: at or above the low side, and strictly below the high side, so a
        // triangle in the plane between two tiles belongs to one of them.
        polygon = clip_by(&polygon, |p| p[axis] - low[axis], false);
        polygon = clip_by(&polygon, |p| high[axis] - p[axis], true);
        if polygon.is_empty() {
            break;
        }
    }
    polygon
}

/// The part of `polygon` where `inside` is positive (or zero, unless `strict`).
fn clip_by(polygon: &[Corner], inside: impl Fn(DVec3) -> f64, strict: bool) -> Vec<Corner> {
    let is_in = |d: f64| if strict { d > 0.0 } else { d >= 0.0 };
    let mut clipped = Vec::with_capacity(polygon.len() + 1);
    for (i, p) in polygon.iter().enumerate() {
        let q = polygon[(i + 1) % polygon.len()];
        let (dp, dq) = (inside(p.position), inside(q.position));
        if is_in(dp) {
            clipped.push(*p);
        }
        if is_in(dp) != is_in(dq) {
            let t = dp / (dp - dq);
            clipped.push(Corner {
                weights: p.weights + (q.weights - p.weights) * t,
                position: p.position + (q.position - p.position) * t,
            });
        }
    }
    clipped
}

/// The area of a convex polygon (a fan of triangles from its first corner).
fn clipped_area(polygon: &[Corner]) -> f64 {
    fan(polygon).map(|(a, b, c)| triangle_area(a, b, c)).sum()
}

/// The triangles of a fan from the polygon's first corner.
fn fan(polygon: &[Corner]) -> impl Iterator<Item = (Corner, Corner, Corner)> + '_ {
    (2..polygon.len()).map(|i| (polygon[0], polygon[i - 1], polygon[i]))
}

fn triangle_area(a: Corner, b: Corner, c: Corner) -> f64 {
    (b.position - a.position)
        .cross(c.position - a.position)
        .length()
        * 0.5
}

/// The barycentric weights of a point uniform over the convex polygon `piece` of area
/// `area`: a triangle of its fan chosen by area, then a point uniform over it. `None` for
/// a piece without a triangle.
fn point_in(piece: &[Corner], area: f64, rng: &mut SeededRng) -> Option<DVec3> {
    let mut at = rng.random::<f64>() * area;
    let mut chosen = None;
    for (a, b, c) in fan(piece) {
        chosen = Some((a, b, c));
        at -= triangle_area(a, b, c);
        if at < 0.0 {
            break;
        }
    }
    let (a, b, c) = chosen?;
    let root = rng.random::<f64>().sqrt();
    let along = rng.random::<f64>();
    Some(a.weights * (1.0 - root) + b.weights * (root * (1.0 - along)) + c.weights * (root * along))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::rng_from_seed;

    fn random_point(g: &mut SeededRng) -> DVec3 {
        DVec3::new(g.random(), g.random(), g.random()) * 3.0 - 1.0
    }

    /// The tiles of side 0.4 from `(-1.2, -1.2, -1.2)` that the box of `corners` spans.
    fn pieces(corners: &[DVec3; 3]) -> Vec<(Vec<Corner>, [DVec3; 2])> {
        let cells = PackedCells::new(DVec3::splat(-1.2), 0.4);
        let mut found = Vec::new();
        for x in 0..12 {
            for y in 0..12 {
                for z in 0..12 {
                    let tile = tile_box(&cells, [x, y, z]);
                    found.push((clip(corners, tile), tile));
                }
            }
        }
        found
    }

    #[test]
    fn a_triangle_cut_by_the_tiles_is_the_sum_of_its_pieces() {
        let mut g = rng_from_seed(8);
        for _ in 0..50 {
            let corners = [0; 3].map(|_| random_point(&mut g));
            let area = (corners[1] - corners[0])
                .cross(corners[2] - corners[0])
                .length()
                * 0.5;
            let mut total = 0.0;
            for (piece, [low, high]) in pieces(&corners) {
                total += clipped_area(&piece);
                for corner in piece {
                    // Each corner is where its weights put it, and inside its tile.
                    let [a, b, c] = corners;
                    let w = corner.weights;
                    assert!((a * w.x + b * w.y + c * w.z - corner.position).length() < 1e-12);
                    assert!((w.element_sum() - 1.0).abs() < 1e-12 && w.min_element() > -1e-12);
                    let p = corner.position;
                    assert!(p.cmpge(low - 1e-12).all() && p.cmple(high + 1e-12).all());
                }
            }
            assert!(
                (total - area).abs() < 1e-12 * area.max(1.0),
                "{total} for {area}"
            );
        }
    }

    #[test]
    fn the_tiles_a_triangle_crosses_are_those_a_search_of_every_tile_finds() {
        let mut g = rng_from_seed(3);
        let cells = PackedCells::new(DVec3::splat(-1.2), 0.1);
        let mut in_box = || DVec3::new(g.random(), g.random(), g.random()) * 2.0 - 1.0;
        for case in 0..60 {
            // Random triangles, and slivers from corner to corner of the box.
            let corners = if case % 3 == 0 {
                let end = in_box();
                [-end, end, end * 0.99 + in_box() * 0.01]
            } else {
                [in_box(), in_box(), in_box()]
            };
            let area = (corners[1] - corners[0])
                .cross(corners[2] - corners[0])
                .length()
                * 0.5;
            let tile_of = |p: DVec3| cells.key(p.as_vec3()).map(unpack);
            let lowest = corners.iter().fold(DVec3::INFINITY, |m, p| m.min(*p));
            let highest = corners.iter().fold(DVec3::NEG_INFINITY, |m, p| m.max(*p));
            let (Some(first), Some(last)) = (tile_of(lowest), tile_of(highest)) else {
                panic!("case {case} leaves the grid");
            };
            let mut searched = Vec::new();
            for z in first[2]..=last[2] {
                for y in first[1]..=last[1] {
                    for x in first[0]..=last[0] {
                        let piece = clipped_area(&clip(&corners, tile_box(&cells, [x, y, z])));
                        if piece > NEGLIGIBLE_SHARE * area {
                            searched.push(x | y << CELL_BITS | z << (2 * CELL_BITS));
                        }
                    }
                }
            }
            let mut found = Vec::new();
            crossed_tiles(&corners, &cells, [first, last], |key| found.push(key));
            found.sort_unstable();
            searched.sort_unstable();
            assert!(!found.is_empty());
            assert_eq!(found, searched, "case {case}");
        }
    }

    #[test]
    fn a_triangle_between_two_tiles_belongs_to_one() {
        // In the plane z = 0.4, the side between two tiles.
        let corners = [
            DVec3::new(0.1, 0.1, 0.4),
            DVec3::new(0.3, 0.1, 0.4),
            DVec3::new(0.1, 0.3, 0.4),
        ];
        let holding: Vec<[DVec3; 2]> = pieces(&corners)
            .into_iter()
            .filter(|(piece, _)| clipped_area(piece) > 0.0)
            .map(|(_, tile)| tile)
            .collect();
        // (Which one depends on how −1.2 + 4 · 0.4 rounds.)
        assert_eq!(holding.len(), 1);
        assert!(
            holding[0][0].z <= 0.4 && 0.4 < holding[0][1].z,
            "{holding:?}"
        );
    }

    #[test]
    fn points_in_a_piece_are_uniform_over_it() {
        // A square cut from two triangles: the points' mean is its centre.
        let mut g = rng_from_seed(2);
        let corners = [
            DVec3::new(-1.0, -1.0, 0.1),
            DVec3::new(2.0, -1.0, 0.1),
            DVec3::new(-1.0, 2.0, 0.1),
        ];
        let piece = clip(&corners, [DVec3::ZERO, DVec3::splat(0.4)]);
        assert_eq!(piece.len(), 4);
        let area = clipped_area(&piece);
        assert!((area - 0.16).abs() < 1e-12);
        let n = 40_000;
        let mut mean = DVec3::ZERO;
        for _ in 0..n {
            let Some(w) = point_in(&piece, area, &mut g) else {
                panic!("a piece with area gave no point");
            };
            let [a, b, c] = corners;
            let p = a * w.x + b * w.y + c * w.z;
            assert!(p.x >= -1e-12 && p.x <= 0.4 + 1e-12 && p.y >= -1e-12 && p.y <= 0.4 + 1e-12);
            mean += p / n as f64;
        }
        // Each coordinate uniform over 0.4: standard deviation 0.4/√12 per point.
        let tolerance = 4.0 * 0.4 / (12.0 * n as f64).sqrt();
        assert!(
            (mean.x - 0.2).abs() < tolerance && (mean.y - 0.2).abs() < tolerance,
            "{mean}"
        );
    }
}
