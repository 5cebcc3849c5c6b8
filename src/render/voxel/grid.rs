//! The voxel grid's placement in world space and the format of its radiance volumes: what
//! every other voxel module builds on (this one uses none of them).

use crate::scene::{Aabb, Scene};
use ash::vk;
use glam::Vec3;

/// The radiance volumes' format (RGBA16F: radiance times `lights::radiance_scale`, alpha the
/// occupancy).
pub const RADIANCE_VOLUME_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;

/// Placement of the cubic grid in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelGrid {
    /// World position of the grid's min corner.
    pub origin: Vec3,
    /// Edge length of one voxel (world units).
    pub voxel_size: f32,
    pub resolution: u32,
}

impl VoxelGrid {
    /// The cube around `bounds` (padded by `pad` of its size on every side).
    pub fn around(bounds: Aabb, resolution: u32, pad: f32) -> VoxelGrid {
        let (center, extent) =
            if bounds.is_empty() { (Vec3::ZERO, 1.0) } else { (bounds.center(), bounds.extent().max_element()) };
        // A flat or empty scene still gets a grid of non-zero size.
        let extent = if extent > 0.0 && extent.is_finite() { extent } else { 1.0 } * (1.0 + 2.0 * pad);
        VoxelGrid { origin: center - Vec3::splat(extent * 0.5), voxel_size: extent / resolution as f32, resolution }
    }

    pub fn for_scene(scene: &Scene) -> VoxelGrid {
        VoxelGrid::for_scene_at(scene, scene.settings.gi.voxel_resolution)
    }

    /// The same placement with `res` cells per side (the light propagation volume's grid).
    pub fn for_scene_at(scene: &Scene, res: u32) -> VoxelGrid {
        match scene.bounds {
            Some(b) => VoxelGrid::around(b, res, 0.0),
            None => VoxelGrid::around(scene.world_bounds(scene.settings.time), res, 0.05),
        }
    }
}
