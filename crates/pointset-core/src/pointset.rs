//! Point sets with optional normals and named attribute channels.

use glam::{Affine3A, Vec3};

use crate::error::check_finite_vec3;
use crate::{Aabb, Error, Result, ScalarType};

/// Vertex property names that hold positions and normals and so cannot be attributes.
pub const RESERVED_NAMES: [&str; 6] = ["x", "y", "z", "nx", "ny", "nz"];

/// Names of the colour channels. By convention (the PLY one) they hold values in `0..=255`.
pub const COLOR_CHANNELS: [&str; 3] = ["red", "green", "blue"];

/// A named per-point `f32` channel (colour, radius, confidence, group id, …).
#[derive(Debug, Clone, PartialEq)]
pub struct Attribute {
    name: String,
    values: Vec<f32>,
    storage: ScalarType,
}

impl Attribute {
    /// A channel stored as `f32` on disk.
    pub fn new(name: impl Into<String>, values: Vec<f32>) -> Self {
        Self {
            name: name.into(),
            values,
            storage: ScalarType::F32,
        }
    }

    /// The same channel with another on-disk storage type (e.g. `U8` for colours).
    pub fn with_storage(mut self, storage: ScalarType) -> Self {
        self.storage = storage;
        self
    }

    /// Channel name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// One value per point.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// The on-disk storage type.
    pub fn storage(&self) -> ScalarType {
        self.storage
    }
}

/// A set of points with optional normals and any number of named attribute channels.
///
/// Invariants, checked by every constructor and mutator: all channels have one entry per
/// point, every value is finite, attribute names are unique and not one of
/// [`RESERVED_NAMES`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointSet {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    attributes: Vec<Attribute>,
}

impl PointSet {
    /// A point set from positions; errors on NaN or infinite coordinates.
    pub fn new(positions: Vec<Vec3>) -> Result<Self> {
        check_finite_vec3(&positions, "position")?;
        Ok(Self {
            positions,
            normals: None,
            attributes: Vec::new(),
        })
    }

    /// Adds (or replaces) normals; they must be finite and one per point.
    pub fn with_normals(mut self, normals: Vec<Vec3>) -> Result<Self> {
        self.set_normals(Some(normals))?;
        Ok(self)
    }

    /// Adds an attribute channel; see [`PointSet::set_attribute`].
    pub fn with_attribute(mut self, attribute: Attribute) -> Result<Self> {
        self.set_attribute(attribute)?;
        Ok(self)
    }

    /// Replaces the normals (or removes them with `None`).
    pub fn set_normals(&mut self, normals: Option<Vec<Vec3>>) -> Result<()> {
        if let Some(n) = &normals {
            self.check_len("normals", n.len())?;
            check_finite_vec3(n, "normal")?;
        }
        self.normals = normals;
        Ok(())
    }

    /// Inserts a channel, replacing one of the same name. The name must be non-empty, not
    /// reserved and contain no whitespace; values must be finite and one per point.
    pub fn set_attribute(&mut self, attribute: Attribute) -> Result<()> {
        let name = attribute.name.as_str();
        let bad_name = |reason: &str| Error::InvalidAttributeName {
            name: name.to_string(),
            reason: reason.to_string(),
        };
        if name.is_empty() || name.chars().any(char::is_whitespace) {
            return Err(bad_name(
                "names must be non-empty and contain no whitespace",
            ));
        }
        if RESERVED_NAMES.contains(&name) {
            return Err(bad_name("reserved for positions and normals"));
        }
        self.check_len(&format!("attribute `{name}`"), attribute.values.len())?;
        if let Some(index) = attribute.values.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                what: format!("attribute `{name}` value"),
                index,
            });
        }
        match self
            .attributes
            .iter_mut()
            .find(|a| a.name == attribute.name)
        {
            Some(slot) => *slot = attribute,
            None => self.attributes.push(attribute),
        }
        Ok(())
    }

    /// Removes a channel by name and returns it.
    pub fn remove_attribute(&mut self, name: &str) -> Option<Attribute> {
        let at = self.attributes.iter().position(|a| a.name == name)?;
        Some(self.attributes.remove(at))
    }

    fn check_len(&self, what: &str, found: usize) -> Result<()> {
        if found == self.positions.len() {
            Ok(())
        } else {
            Err(Error::LengthMismatch {
                what: what.to_string(),
                expected: self.positions.len(),
                found,
            })
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Point positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Point normals, if present.
    pub fn normals(&self) -> Option<&[Vec3]> {
        self.normals.as_deref()
    }

    /// How many normals have no direction: zero, or too short to normalize (a tool's `0 0
    /// 0` where it computed none). 0 when there are no normals at all.
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::PointSet;
    /// let points = PointSet::new(vec![Vec3::ZERO, Vec3::X])?
    ///     .with_normals(vec![Vec3::Z, Vec3::ZERO])?;
    /// assert_eq!(points.directionless_normals(), 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn directionless_normals(&self) -> usize {
        self.normals().map_or(0, |normals| {
            normals
                .iter()
                .filter(|n| n.try_normalize().is_none())
                .count()
        })
    }

    /// All attribute channels, in insertion (file) order.
    pub fn attributes(&self) -> &[Attribute] {
        &self.attributes
    }

    /// A channel by name.
    pub fn attribute(&self, name: &str) -> Option<&Attribute> {
        self.attributes.iter().find(|a| a.name == name)
    }

    /// Per-point RGB colours in `0..=1`, when `red`, `green` and `blue` channels exist
    /// (stored in `0..=255`, the PLY convention).
    pub fn colors(&self) -> Option<Vec<[f32; 3]>> {
        let [r, g, b] = COLOR_CHANNELS.map(|c| self.attribute(c).map(Attribute::values));
        let (r, g, b) = (r?, g?, b?);
        Some(
            (0..self.len())
                .map(|i| [r[i], g[i], b[i]].map(|c| (c / 255.0).clamp(0.0, 1.0)))
                .collect(),
        )
    }

    /// Sets `red`, `green`, `blue` channels (stored as `uchar`) from colours in `0..=1`.
    pub fn set_colors(&mut self, colors: &[[f32; 3]]) -> Result<()> {
        for (c, name) in COLOR_CHANNELS.iter().enumerate() {
            let values = colors
                .iter()
                .map(|rgb| (rgb[c] * 255.0).round().clamp(0.0, 255.0))
                .collect();
            self.set_attribute(Attribute::new(*name, values).with_storage(ScalarType::U8))?;
        }
        Ok(())
    }

    /// The bounding box, or `None` when empty.
    pub fn bounding_box(&self) -> Option<Aabb> {
        Aabb::from_points(&self.positions)
    }

    /// A new point set holding the points at `indices` (in that order, repeats allowed).
    pub fn subset(&self, indices: &[usize]) -> Result<Self> {
        if let Some(&bad) = indices.iter().find(|&&i| i >= self.len()) {
            return Err(Error::InvalidParameter {
                name: "indices",
                value: bad.to_string(),
                expected: format!("indices below {}", self.len()),
            });
        }
        let pick = |v: &[Vec3]| indices.iter().map(|&i| v[i]).collect::<Vec<_>>();
        Ok(Self {
            positions: pick(&self.positions),
            normals: self.normals.as_deref().map(pick),
            attributes: self
                .attributes
                .iter()
                .map(|a| Attribute {
                    name: a.name.clone(),
                    values: indices.iter().map(|&i| a.values[i]).collect(),
                    storage: a.storage,
                })
                .collect(),
        })
    }

    /// The points for which `keep(index, position)` is true.
    pub fn filter(&self, mut keep: impl FnMut(usize, Vec3) -> bool) -> Self {
        let indices: Vec<usize> = (0..self.len())
            .filter(|&i| keep(i, self.positions[i]))
            .collect();
        // Indices come from 0..len, so `subset` cannot fail; fall back to an empty copy anyway.
        self.subset(&indices).unwrap_or_else(|_| self.empty_like())
    }

    /// An empty point set with the same layout (normals yes/no, attribute names and types).
    pub fn empty_like(&self) -> Self {
        Self {
            positions: Vec::new(),
            normals: self.normals.as_ref().map(|_| Vec::new()),
            attributes: self
                .attributes
                .iter()
                .map(|a| Attribute {
                    name: a.name.clone(),
                    values: Vec::new(),
                    storage: a.storage,
                })
                .collect(),
        }
    }

    /// Appends `other`, which must have the same layout (both or neither with normals, the
    /// same attribute names). Attribute order follows `self`.
    pub fn append(&mut self, other: &PointSet) -> Result<()> {
        if self.normals.is_some() != other.normals.is_some() {
            return Err(Error::IncompatibleLayout {
                reason: "one point set has normals and the other does not".into(),
            });
        }
        if self.attributes.len() != other.attributes.len()
            || self
                .attributes
                .iter()
                .any(|a| other.attribute(&a.name).is_none())
        {
            return Err(Error::IncompatibleLayout {
                reason: "attribute names differ".into(),
            });
        }
        self.positions.extend_from_slice(&other.positions);
        if let (Some(n), Some(m)) = (&mut self.normals, &other.normals) {
            n.extend_from_slice(m);
        }
        for a in &mut self.attributes {
            if let Some(b) = other.attribute(&a.name) {
                a.values.extend_from_slice(&b.values);
            }
        }
        Ok(())
    }

    /// Applies an affine map: positions are transformed, normals by the inverse transpose
    /// and renormalized. Errors if the map is singular or produces non-finite values.
    pub fn transform(&mut self, map: &Affine3A) -> Result<()> {
        let det = map.matrix3.determinant();
        if !(det.is_finite() && det.abs() > f32::EPSILON * f32::EPSILON) {
            return Err(Error::InvalidParameter {
                name: "map",
                value: format!("determinant {det}"),
                expected: "an invertible affine map".into(),
            });
        }
        let positions: Vec<Vec3> = self
            .positions
            .iter()
            .map(|&p| map.transform_point3(p))
            .collect();
        check_finite_vec3(&positions, "transformed position")?;
        let normals = match &self.normals {
            Some(normals) => {
                let normal_map = map.matrix3.inverse().transpose();
                let n: Vec<Vec3> = normals
                    .iter()
                    .map(|&n| (normal_map * n).normalize_or_zero())
                    .collect();
                check_finite_vec3(&n, "transformed normal")?;
                Some(n)
            }
            None => None,
        };
        self.positions = positions;
        self.normals = normals;
        Ok(())
    }

    /// Consumes the set and returns positions, normals and attributes.
    pub fn into_parts(self) -> (Vec<Vec3>, Option<Vec<Vec3>>, Vec<Attribute>) {
        (self.positions, self.normals, self.attributes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> PointSet {
        PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y])
            .unwrap()
            .with_normals(vec![Vec3::Z; 3])
            .unwrap()
            .with_attribute(Attribute::new("radius", vec![1.0, 2.0, 3.0]))
            .unwrap()
    }

    #[test]
    fn validation_rejects_bad_channels() {
        assert!(matches!(
            PointSet::new(vec![Vec3::new(f32::NAN, 0.0, 0.0)]),
            Err(Error::NonFinite { index: 0, .. })
        ));
        let p = sample();
        assert!(matches!(
            p.clone().with_normals(vec![Vec3::Z; 2]),
            Err(Error::LengthMismatch { .. })
        ));
        assert!(matches!(
            p.clone().with_attribute(Attribute::new("x", vec![0.0; 3])),
            Err(Error::InvalidAttributeName { .. })
        ));
        assert!(matches!(
            p.with_attribute(Attribute::new("c", vec![0.0, f32::INFINITY, 0.0])),
            Err(Error::NonFinite { index: 1, .. })
        ));
    }

    #[test]
    fn subset_filter_append_keep_channels_aligned() {
        let p = sample();
        let s = p.subset(&[2, 0]).unwrap();
        assert_eq!(s.positions(), &[Vec3::Y, Vec3::ZERO]);
        assert_eq!(s.attribute("radius").unwrap().values(), &[3.0, 1.0]);
        assert!(p.subset(&[3]).is_err());
        let f = p.filter(|_, q| q.x > 0.5);
        assert_eq!(f.len(), 1);
        assert_eq!(f.attribute("radius").unwrap().values(), &[2.0]);
        let mut a = p.clone();
        a.append(&f).unwrap();
        assert_eq!(a.len(), 4);
        assert_eq!(a.normals().unwrap().len(), 4);
        let bare = PointSet::new(vec![Vec3::ONE]).unwrap();
        assert!(a.append(&bare).is_err());
    }

    #[test]
    fn transform_keeps_normals_orthogonal_to_surfaces() {
        // A plane z = 0 with normals +z, sheared in x by z: normals must stay unit and +z-ish.
        let mut p = sample();
        let map = Affine3A::from_scale(Vec3::new(2.0, 1.0, 0.5));
        p.transform(&map).unwrap();
        assert_eq!(p.positions()[1], Vec3::new(2.0, 0.0, 0.0));
        for n in p.normals().unwrap() {
            assert!((n.length() - 1.0).abs() < 1e-6);
            assert!((n.z - 1.0).abs() < 1e-6);
        }
        let singular = Affine3A::from_scale(Vec3::new(1.0, 1.0, 0.0));
        assert!(p.transform(&singular).is_err());
    }

    #[test]
    fn colors_use_the_ply_range() {
        let mut p = sample();
        assert!(p.colors().is_none());
        p.set_colors(&[[1.0, 0.0, 0.5]; 3]).unwrap();
        assert_eq!(p.attribute("red").unwrap().storage(), ScalarType::U8);
        let c = p.colors().unwrap();
        assert!((c[0][2] - 128.0 / 255.0).abs() < 1e-6);
    }
}
