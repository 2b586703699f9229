//! What a simplified mesh's vertices carry besides their positions: normals, texture
//! coordinates and named attributes, merged as edges collapse.

use glam::{Vec2, Vec3};

use super::SimplifiedNormals;
use super::smooth_groups::SmoothGroups;
use crate::{Attribute, COLOR_CHANNELS, PointSet, Result, ScalarType, TriMesh};

/// One named attribute's values, and how two of them merge.
#[derive(Debug)]
struct Channel {
    name: String,
    storage: ScalarType,
    values: Vec<f32>,
    /// Interpolated (floats and colour channels) rather than taken from the nearer vertex
    /// (integer labels, such as a quilt's `patch`).
    blends: bool,
}

/// The input mesh's per-vertex data, updated in place as vertices merge.
#[derive(Debug)]
pub(super) struct VertexData {
    normals: Option<Vec<Vec3>>,
    /// The vertices' smooth groups, when they have normals.
    smooth_groups: Option<SmoothGroups>,
    /// Where the output's normals come from.
    normals_from: SimplifiedNormals,
    uvs: Option<Vec<Vec2>>,
    channels: Vec<Channel>,
}

impl VertexData {
    /// The data of `mesh`'s vertices, welded as `welded` says (each vertex's welded
    /// vertex), whose normals will be as `normals` says.
    pub(super) fn of(mesh: &TriMesh, welded: &[u32], normals: SimplifiedNormals) -> Self {
        let vertices = mesh.vertices();
        let channels = vertices
            .attributes()
            .iter()
            .map(|attribute| Channel {
                name: attribute.name().to_owned(),
                storage: attribute.storage(),
                values: attribute.values().to_vec(),
                blends: !attribute.storage().is_integer()
                    || COLOR_CHANNELS.contains(&attribute.name())
                    || attribute.name() == "alpha",
            })
            .collect();
        Self {
            normals: vertices.normals().map(<[Vec3]>::to_vec),
            smooth_groups: vertices
                .normals()
                .map(|normals| SmoothGroups::of(welded, normals)),
            normals_from: normals,
            uvs: mesh.uvs().map(<[Vec2]>::to_vec),
            channels,
        }
    }

    /// `gone` merges into `keep`, which moved to `t` of the way from where it was toward
    /// `gone` (0: stayed, 1: took `gone`'s place). Normals, UVs, floats and colours are
    /// interpolated by `t` (normals renormalized, kept as they were where the two cancel),
    /// each attribute stored in its type; integer labels come from the nearer vertex. Their
    /// smooth groups join.
    pub(super) fn merge(&mut self, keep: usize, gone: usize, t: f32) {
        if let Some(groups) = &mut self.smooth_groups {
            groups.merge(keep, gone);
        }
        if let Some(normals) = &mut self.normals {
            let mixed = normals[keep].lerp(normals[gone], t);
            if let Some(unit) = mixed.try_normalize() {
                normals[keep] = unit;
            }
        }
        if let Some(uvs) = &mut self.uvs {
            uvs[keep] = uvs[keep].lerp(uvs[gone], t);
        }
        for channel in &mut self.channels {
            let (k, g) = (channel.values[keep], channel.values[gone]);
            channel.values[keep] = if channel.blends {
                channel
                    .storage
                    .quantize(f64::from(k) + f64::from(t) * (f64::from(g) - f64::from(k)))
                    as f32
            } else if t > 0.5 {
                g
            } else {
                k
            };
        }
    }

    /// The mesh of `triangles` over the input's vertices, at `positions` (one per input
    /// vertex), carrying their data. Each normal becomes its vertex's mean face normal (in
    /// its smooth group) when recomputed, or when interpolated and facing against it;
    /// normals of vertices whose faces have no area stay.
    pub(super) fn into_mesh(
        mut self,
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<TriMesh> {
        if let (Some(groups), Some(normals)) = (self.smooth_groups, &mut self.normals) {
            let means = groups.mean_face_normals(&positions, &triangles);
            for (normal, mean) in normals.iter_mut().zip(means) {
                let replace = match self.normals_from {
                    SimplifiedNormals::Recompute => mean != Vec3::ZERO,
                    SimplifiedNormals::Interpolate => normal.dot(mean) < 0.0,
                };
                if replace {
                    *normal = mean;
                }
            }
        }
        let mut vertices = PointSet::new(positions)?;
        vertices.set_normals(self.normals)?;
        for channel in self.channels {
            vertices.set_attribute(
                Attribute::new(channel.name, channel.values).with_storage(channel.storage),
            )?;
        }
        let mesh = TriMesh::new(vertices, triangles)?;
        match self.uvs {
            Some(uvs) => mesh.with_uvs(uvs),
            None => Ok(mesh),
        }
    }
}
