//! What a frame will allocate, estimated from the scene and settings before anything is created,
//! so that settings beyond the device (GPU memory, the largest allocation) are refused up front
//! with the limit named instead of failing halfway or exhausting the machine. The GPU test
//! `memory_estimate_matches_what_is_allocated` keeps it within 10% of what is really allocated.

use crate::gpu::{Context, GpuError, GpuResult};
use crate::render::plan::FramePlan;
use crate::render::voxel::capacity::Capacity;
use crate::render::voxel::specs::{Alloc, VolumeSpecs};
use crate::render::voxel::{fitted_layout, VoxelGrid, VoxelNeeds};
use crate::scene::{Scene, VoxelLayout};

/// What a device offers (`DeviceInfo`'s memory figures).
pub struct Limits<'a> {
    pub device: &'a str,
    /// Largest device-local heap, bytes (0: unknown, not checked).
    pub heap: u64,
    /// Largest single allocation, bytes (0: unknown, not checked).
    pub max_allocation: u64,
}

impl Limits<'_> {
    pub fn of(ctx: &Context) -> Limits<'_> {
        let i = &ctx.info;
        Limits { device: &i.name, heap: i.device_local_heap, max_allocation: i.max_allocation }
    }
}

/// The large resources of a frame, by group, in bytes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Estimate {
    /// Voxel volumes (albedo, normal, emission, flags, radiance, bounces, directional mips)
    /// and the voxel work lists.
    pub volumes: u64,
    /// The largest single volume (one allocation).
    pub largest_volume: u64,
    /// G-buffer, radiance, display and cone-tracing targets.
    pub targets: u64,
    /// Shadow maps, and with `gi.mode = "rsm"` the reflective shadow maps (flux, normal,
    /// position and depth per light view).
    pub shadow_maps: u64,
    /// Vertex and index buffers and textures.
    pub scene: u64,
    /// One copy of what a frame has for itself: the targets, the shadow maps (not the static
    /// casters' cache, which the copies share) and the propagation volumes (not in the total:
    /// see `copies`).
    pub frame_copy: u64,
    /// The copies beyond the first that `async-pipelined` keeps, one per frame in flight
    /// ([`Estimate::with_copies`]; 0 otherwise).
    pub copies: u64,
}

impl Estimate {
    /// By texel counts: what any device needs at least (for advice and tables).
    pub fn of(scene: &Scene) -> Estimate {
        Estimate::of_layout(scene, scene.settings.gi.voxel_layout)
    }

    /// `of` with the voxel volumes in `layout` (without copying the scene).
    pub fn of_layout(scene: &Scene, layout: VoxelLayout) -> Estimate {
        Estimate::sized(scene, &FramePlan::of(scene), layout, &|a: &Alloc| a.bytes(None))
    }

    /// On `ctx`'s device: the voxel volumes by the device's own memory requirements (its
    /// padding and alignment included), the rest by texel counts.
    pub fn on(ctx: &Context, scene: &Scene) -> Estimate {
        Estimate::on_layout(ctx, scene, scene.settings.gi.voxel_layout)
    }

    /// `on` with the voxel volumes in `layout`.
    pub fn on_layout(ctx: &Context, scene: &Scene, layout: VoxelLayout) -> Estimate {
        Estimate::sized(scene, &FramePlan::of(scene), layout, &|a: &Alloc| a.bytes(Some(ctx)))
    }

    /// `on` for the frame `plan` of `scene` (the renderer's, made once).
    pub fn on_plan(ctx: &Context, scene: &Scene, plan: &FramePlan) -> Estimate {
        let layout = scene.settings.gi.voxel_layout;
        Estimate::sized(scene, plan, layout, &|a: &Alloc| a.bytes(Some(ctx)))
    }

    fn sized(scene: &Scene, plan: &FramePlan, layout: VoxelLayout, bytes: &dyn Fn(&Alloc) -> u64) -> Estimate {
        let s = &scene.settings;
        let mut e = Estimate::default();
        // The static casters' cache is one for every copy of the frame (`frame::Carried`).
        let mut shared = 0;
        for t in plan.targets() {
            *(if t.shadow_map { &mut e.shadow_maps } else { &mut e.targets }) += t.bytes();
            if t.name == "shadow map cache" {
                shared += t.bytes();
            }
        }
        let mut lpv_bytes = 0;
        if plan.rsm.as_ref().is_some_and(|r| r.lpv) {
            // Ten RGBA32F volumes (light ping-pong and sum, 3 colours each, geometry) and the
            // injection's sums (16 ints per cell).
            let lpv = 16 * (s.gi.lpv_resolution as u64).pow(3);
            lpv_bytes = 10 * lpv + 4 * lpv;
            e.volumes += lpv_bytes;
            e.largest_volume = e.largest_volume.max(lpv);
        }
        e.frame_copy = e.targets + e.shadow_maps - shared + lpv_bytes;
        if let Some(needs) = plan.voxels {
            let vols: Vec<u64> = voxel_allocations(scene, needs, layout, bytes).iter().map(bytes).collect();
            e.volumes = vols.iter().sum();
            e.largest_volume = vols.iter().copied().max().unwrap_or(0);
        }
        let vertices: u64 = scene.meshes.iter().map(|m| m.positions.len() as u64).sum();
        let indices: u64 = scene.meshes.iter().map(|m| m.indices.len() as u64).sum();
        // A height map used with two reliefs is uploaded twice (render::relief).
        let uploads = super::relief::ReliefPlan::of(scene).uploads;
        let texels: u64 =
            uploads.iter().map(|u| &scene.textures[u.texture as usize]).map(|t| t.width as u64 * t.height as u64).sum();
        // position + normal + uv (32 B) per vertex, 4 B per index, RGBA8 textures with mips (4/3),
        // the sky's maps and tables.
        e.scene = 32 * vertices + 4 * indices + texels * 16 / 3 + super::sky::sky_bytes(scene.sky.as_ref());
        e
    }

    pub fn total(&self) -> u64 {
        self.volumes + self.targets + self.shadow_maps + self.scene + self.copies
    }

    /// With `n` copies of the frame's own resources (`Renderer::copy_count`): n - 1 more.
    pub fn with_copies(self, n: u32) -> Estimate {
        Estimate { copies: u64::from(n.saturating_sub(1)) * self.frame_copy, ..self }
    }

    /// Refuse what cannot fit this device: more than its largest device-local heap in all, or a
    /// volume larger than its largest allocation. The message names the limit, the device and
    /// what to lower.
    pub fn check(&self, ctx: &Context, scene: &Scene) -> GpuResult<()> {
        self.check_limits(scene, &Limits::of(ctx))
    }

    /// `check` against given limits.
    pub fn check_limits(&self, scene: &Scene, info: &Limits) -> GpuResult<()> {
        let gi = &scene.settings.gi;
        let lpv = gi.uses_lpv() && scene.settings.view.is_lit();
        let res = if lpv { gi.lpv_resolution } else { gi.voxel_resolution };
        let volumes = match (lpv, gi.voxel_layout) {
            (true, _) => "propagation volumes",
            (false, VoxelLayout::Bricks) => "voxel volumes in bricks of 8^3",
            (false, VoxelLayout::Dense | VoxelLayout::Auto) => "voxel volumes, dense",
        };
        let rsm = if gi.uses_rsm() { format!(", gi.rsm_size ({} now)", gi.rsm_size) } else { String::new() };
        let lower = if lpv {
            format!("; lower gi.lpv_resolution ({res} now){rsm} or the image size")
        } else if self.volumes > 0 {
            let mut fits = res / 2;
            while fits > 8 && self.with_resolution(scene, fits) > info.heap {
                fits /= 2;
            }
            let bricks = self.bricks_instead(scene);
            format!("{bricks}; lower gi.voxel_resolution ({res} now, {fits} fits), gi.bounces or the image size")
        } else {
            format!("; lower the image size{rsm} or render.shadow_map_size")
        };
        if info.heap > 0 && self.total() > info.heap {
            return Err(GpuError::Limit(format!(
                "{}: the frame needs about {} of GPU memory ({volumes} {} at {res}^3, targets {}, shadow maps {}, \
                 scene {}), more than {}'s largest device-local memory heap ({}){lower}",
                scene.path.display(),
                mib(self.total()),
                mib(self.volumes),
                mib(self.targets),
                mib(self.shadow_maps),
                mib(self.scene),
                info.device,
                mib(info.heap),
            )));
        }
        if info.max_allocation > 0 && self.largest_volume > info.max_allocation {
            return Err(GpuError::Limit(format!(
                "{}: one of the {res}^3 {volumes} needs {} in one allocation, more than {}'s \
                 maxMemoryAllocationSize ({}){lower}",
                scene.path.display(),
                mib(self.largest_volume),
                info.device,
                mib(info.max_allocation),
            )));
        }
        Ok(())
    }

    /// With dense voxel volumes, what the bricked layout would need instead (for the advice in
    /// `check`; empty otherwise).
    fn bricks_instead(&self, scene: &Scene) -> String {
        if scene.settings.gi.voxel_layout == VoxelLayout::Bricks {
            return String::new();
        }
        let volumes = Estimate::of_layout(scene, VoxelLayout::Bricks).volumes;
        format!(
            "; set gi.voxel_layout = \"bricks\" (volumes {} instead of {}, about {} in all)",
            mib(volumes),
            mib(self.volumes),
            mib(self.total() - self.volumes + volumes)
        )
    }

    /// The total with another voxel resolution (for the advice in `check`).
    fn with_resolution(&self, scene: &Scene, res: u32) -> u64 {
        let mut s = scene.clone();
        s.settings.gi.voxel_resolution = res;
        let e = Estimate::of(&s);
        e.volumes + self.targets + self.shadow_maps + self.scene
    }
}

/// `gi.voxel_layout = "auto"` on a device with `limits`: dense when the dense layout's whole
/// frame takes at most half of the device-local heap and its largest volume fits one
/// allocation, bricks otherwise. The two render the same image (tests/voxel.rs); dense is the
/// faster (1.2-1.7x the frame on an H200 for bricks on Sponza at 128^3-512^3, 1.3-1.5x per voxel
/// pass on lavapipe: docs/SPARSE.md), bricks the smaller (0.15 of dense at 512^3 before the
/// voxelization's sums, which weigh more on dense). Half the heap
/// leaves the rest of the device's memory to everything else running on it. Other values are
/// returned as they are.
pub fn resolve_layout(scene: &Scene, limits: &Limits) -> VoxelLayout {
    if scene.settings.gi.voxel_layout != VoxelLayout::Auto {
        return scene.settings.gi.voxel_layout;
    }
    let e = Estimate::of_layout(scene, VoxelLayout::Dense);
    let fits_heap = limits.heap == 0 || e.total() <= limits.heap / 2;
    let fits_allocation = limits.max_allocation == 0 || e.largest_volume <= limits.max_allocation;
    if fits_heap && fits_allocation {
        VoxelLayout::Dense
    } else {
        VoxelLayout::Bricks
    }
}

fn mib(bytes: u64) -> String {
    let m = bytes as f64 / (1024.0 * 1024.0);
    if m < 10.0 {
        format!("{m:.1} MiB")
    } else {
        format!("{m:.0} MiB")
    }
}

/// Each allocation of the voxel volumes in `layout`, as `VoxelVolumes::new` makes them
/// (`voxel::specs`), the pools' slots arranged by the same `bytes`.
fn voxel_allocations(
    scene: &Scene,
    needs: VoxelNeeds,
    layout: VoxelLayout,
    bytes: &dyn Fn(&Alloc) -> u64,
) -> Vec<Alloc> {
    let grid = VoxelGrid::for_scene(scene);
    let res = grid.resolution;
    let capacity = Capacity::of(scene, &grid, needs.pooled_levels(layout, res));
    let image_bytes = |format, extent, sampled| bytes(&Alloc::Volume { format, extent, mips: 1, sampled });
    let bricks = fitted_layout(res, &needs, &capacity, &image_bytes);
    VolumeSpecs::new(res, &needs, capacity.list, bricks.as_ref()).all()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::GiMode;

    #[test]
    fn voxel_volume_bytes_follow_the_needs() {
        let mut scene = crate::render::test_scene(vec![]);
        scene.settings.width = 10;
        scene.settings.height = 10;
        scene.settings.gi.voxel_resolution = 8;
        scene.settings.gi.bounces = 1;
        scene.settings.gi.voxel_layout = VoxelLayout::Dense;
        scene.settings.gi.plane_backs = crate::scene::PlaneBacks::Lit;
        let e = Estimate::of(&scene);
        // albedo + normal 2 x 2048, radiance 4096, bounced radiance and the bounce's scratch
        // volume 2 x 4096, six directional chains of (64 + 8 + 1) texels x 8 bytes, and the
        // work list's 64-byte header (no triangles: no entries), the seven 1^3 placeholders
        // (R32_UINT for the brick maps' writers and readers and for the side factors, RGBA16F,
        // R32G32B32A32_UINT for the side normals, R8_UINT for the static flags and for the
        // closed backs), the voxelization's eight sums (a
        // count, albedo, normal and the surface's offset) 8 x 2048, the scan buffer (a 16-word
        // header and one 8^3 brick) and the first update's bounce tail (its gain and ratio, and
        // two records of the one workgroup an empty list dispatches).
        assert_eq!(
            e.volumes,
            2 * 2048 + 4096 + 2 * 4096 + 6 * 73 * 8 + 64 + 3 * 4 + 8 + 16 + 2 + 8 * 2048 + 4 * 17 + 64
        );
        assert_eq!(e.largest_volume, 4096);
        // gi.attenuation = "per-side": one R32_UINT volume of side factors and one
        // R32G32B32A32_UINT of side normals in place of their placeholders, and twenty-four
        // more sums.
        scene.settings.gi.attenuation = crate::scene::VoxelAttenuation::PerSide;
        assert_eq!(Estimate::of(&scene).volumes, e.volumes + 2048 - 4 + 8192 - 16 + 24 * 2048);
        scene.settings.gi.attenuation = crate::scene::VoxelAttenuation::NDotL;
        // gi.plane_backs = "closed" (the default): an R8_UINT volume of closed backs in place of
        // its placeholder.
        scene.settings.gi.plane_backs = crate::scene::PlaneBacks::Closed;
        assert_eq!(Estimate::of(&scene).volumes, e.volumes + 512 - 1);
        scene.settings.gi.plane_backs = crate::scene::PlaneBacks::Lit;
        assert_eq!(e.targets, 100 * 40 + 100 * 8, "G-buffer (no emission), radiance, display, diffuse cones");
        scene.settings.gi.mode = GiMode::None;
        assert_eq!(Estimate::of(&scene).volumes, 0);
        // 512^3 with one bounce: albedo, normal 0.5 GiB each, radiance, bounced and scratch
        // 1 GiB each, directional 6 x 146.3 MiB: 4.86 GiB; and the eight sums the
        // voxelization adds to, 0.5 GiB each (and a 1 MiB scan): 8.86 GiB.
        scene.settings.gi.mode = GiMode::Vct;
        scene.settings.gi.voxel_resolution = 512;
        let v = Estimate::of(&scene).volumes as f64 / (1u64 << 30) as f64;
        assert!((v - 8.858).abs() < 0.01, "{v} GiB");
        // Bricked, an empty scene holds one slot per pool (the pools' minimum), the maps
        // (65^3 + 33^3 + 17^3 entries at 512^3: each pool's aprons need a brick past its last
        // texel), the dense directional levels of at most 64^3 (six RGBA16F chains), and under
        // 2 MiB of lists, slots and the scan buffer.
        scene.settings.gi.voxel_layout = VoxelLayout::Bricks;
        let bricked = Estimate::of(&scene).volumes;
        let maps = 4 * (65u64.pow(3) + 33u64.pow(3) + 17u64.pow(3));
        let dense_levels = 6 * 8 * (0..7).map(|l| (64u64 >> l).pow(3)).sum::<u64>();
        assert!(bricked > maps + dense_levels && bricked < maps + dense_levels + (2 << 20), "{bricked} bytes");
    }

    #[test]
    fn settings_beyond_the_heap_or_the_largest_allocation_are_refused_naming_the_limit() {
        let mut scene = crate::render::test_scene(vec![]);
        scene.settings.width = 64;
        scene.settings.height = 64;
        scene.settings.gi.voxel_resolution = 512;
        scene.settings.gi.voxel_layout = VoxelLayout::Dense;
        scene.settings.gi.plane_backs = crate::scene::PlaneBacks::Lit;
        let lim = |heap, max_allocation| Limits { device: "llvmpipe", heap, max_allocation };
        let e = Estimate::of(&scene);
        let err = e.check_limits(&scene, &lim(2 << 30, 2 << 30)).unwrap_err().to_string();
        for part in [
            "test:",
            "about 9071 MiB",
            "voxel volumes, dense",
            "512^3",
            "llvmpipe's largest device-local memory heap (2048 MiB)",
            "set gi.voxel_layout = \"bricks\"",
            "256 fits",
        ] {
            assert!(err.contains(part), "{part:?} missing from: {err}");
        }
        let err = e.check_limits(&scene, &lim(64 << 30, 512 << 20)).unwrap_err().to_string();
        assert!(
            err.contains("1024 MiB in one allocation") && err.contains("maxMemoryAllocationSize (512 MiB)"),
            "{err}"
        );
        assert!(e.check_limits(&scene, &lim(64 << 30, 2 << 30)).is_ok());
        assert!(e.check_limits(&scene, &lim(0, 0)).is_ok(), "unknown limits are not checked");
        scene.settings.gi.voxel_resolution = 256;
        assert!(Estimate::of(&scene).check_limits(&scene, &lim(2 << 30, 2 << 30)).is_ok());
    }

    /// "auto" is dense where the dense frame takes at most half of the heap and its largest
    /// volume fits one allocation, bricks elsewhere; a layout named in the scene stays.
    #[test]
    fn auto_layout_is_dense_where_it_fits_half_the_heap() {
        let mut scene = crate::render::test_scene(vec![]);
        scene.settings.width = 64;
        scene.settings.height = 64;
        scene.settings.gi.voxel_resolution = 512;
        assert_eq!(scene.settings.gi.voxel_layout, VoxelLayout::Auto, "the default");
        let mut dense = scene.clone();
        dense.settings.gi.voxel_layout = VoxelLayout::Dense;
        let e = Estimate::of(&dense);
        let lim = |heap, max_allocation| Limits { device: "test", heap, max_allocation };
        assert_eq!(resolve_layout(&scene, &lim(2 * e.total(), 0)), VoxelLayout::Dense);
        assert_eq!(resolve_layout(&scene, &lim(2 * e.total() - 1, 0)), VoxelLayout::Bricks);
        assert_eq!(resolve_layout(&scene, &lim(0, e.largest_volume)), VoxelLayout::Dense);
        assert_eq!(resolve_layout(&scene, &lim(0, e.largest_volume - 1)), VoxelLayout::Bricks);
        assert_eq!(resolve_layout(&scene, &lim(0, 0)), VoxelLayout::Dense, "unknown limits");
        scene.settings.gi.voxel_layout = VoxelLayout::Bricks;
        assert_eq!(resolve_layout(&scene, &lim(u64::MAX, 0)), VoxelLayout::Bricks);
        scene.settings.gi.voxel_layout = VoxelLayout::Dense;
        assert_eq!(resolve_layout(&scene, &lim(1, 1)), VoxelLayout::Dense);
    }

    /// Reflective shadow maps and propagation volumes count, and a refusal names their keys.
    #[test]
    fn rsm_maps_and_propagation_volumes_are_counted_and_named() {
        let point = crate::scene::LightKind::Point { position: glam::Vec3::ONE, intensity: glam::Vec3::ONE };
        let mut scene = crate::render::test_scene(vec![point]);
        scene.lights[0].cast_shadows = true;
        scene.settings.gi.mode = GiMode::Lpv;
        scene.settings.gi.lpv_resolution = 128;
        scene.settings.gi.rsm_size = 2048;
        let e = Estimate::of(&scene);
        // Ten RGBA32F volumes and the injection's 16 ints per cell, each 32 MiB at 128^3.
        assert_eq!(e.volumes, 14 * 16 * 128u64.pow(3));
        assert_eq!(e.largest_volume, 16 * 128u64.pow(3));
        // Six cube faces of 2048^2 flux, normal, position and depth texels (44 bytes).
        assert!(e.shadow_maps >= 6 * 44 * 2048u64.pow(2), "{}", e.shadow_maps);
        let lim = Limits { device: "small", heap: 1 << 30, max_allocation: 0 };
        let err = e.check_limits(&scene, &lim).unwrap_err().to_string();
        for part in ["propagation volumes", "128^3", "lower gi.lpv_resolution (128 now)", "gi.rsm_size (2048 now)"] {
            assert!(err.contains(part), "{part:?} missing from: {err}");
        }
        scene.settings.gi.mode = GiMode::Rsm;
        let err = Estimate::of(&scene).check_limits(&scene, &lim).unwrap_err().to_string();
        assert!(err.contains("gi.rsm_size (2048 now)") && !err.contains("lpv"), "{err}");
    }
}
