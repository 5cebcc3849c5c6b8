//! What a frame of a scene needs, decided once from the scene and its settings: which work
//! exists, at what size, and which views need which targets. The frame builder
//! (`frame::FramePasses`), the voxel volumes, the memory estimate (`budget`) and `dvsgi info`
//! read this one plan, so they cannot disagree on what a frame holds.

use crate::render::lights;
use crate::render::passes::gbuffer::{ALBEDO_FORMAT, DEPTH_FORMAT, EMISSION_FORMAT, NORMAL_FORMAT, SPECULAR_FORMAT};
use crate::render::passes::gi_trace::{GI_FORMAT, SHADOW_VIS_FORMAT};
use crate::render::passes::readback::bytes_per_texel;
use crate::render::passes::rsm;
use crate::render::passes::tonemap::DISPLAY_FORMAT;
use crate::render::voxel::VoxelNeeds;
use crate::scene::{DirectShadows, GiMode, Scene, SpecularSource, View, VoxelOcclusion};
use ash::vk;

/// The frame's shaded radiance (and its supersampling resolve): RGBA32F, linear.
pub const RADIANCE_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
/// The shadow maps' depth.
pub const SHADOW_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// One 2D image (or image array) the frame creates, for the memory estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    pub name: &'static str,
    pub format: vk::Format,
    pub size: (u32, u32),
    pub layers: u32,
    /// A shadow map or reflective shadow map (the estimate counts those apart).
    pub shadow_map: bool,
}

impl Target {
    fn new(name: &'static str, format: vk::Format, size: (u32, u32)) -> Target {
        Target { name, format, size, layers: 1, shadow_map: false }
    }

    pub fn bytes(&self) -> u64 {
        u64::from(self.size.0) * u64::from(self.size.1) * u64::from(self.layers) * bytes_per_texel(self.format)
    }
}

/// The frame of one scene with its settings (nothing here depends on the device).
#[derive(Debug, Clone, PartialEq)]
pub struct FramePlan {
    /// The frame renders at this size (the output times `render.supersample`) ...
    pub internal: (u32, u32),
    /// ... and writes this one.
    pub output: (u32, u32),
    /// The image is lit (the final, indirect or AO view): the G-buffer is drawn, lit, and
    /// given indirect light. Otherwise a voxel view shades the pixels (the G-buffer's images
    /// exist but are not drawn; no indirect light).
    pub lit: bool,
    /// What the voxel volumes hold; None without voxels (no `vct`, no voxel view).
    pub voxels: Option<VoxelNeeds>,
    /// Cones traced per pixel from the G-buffer (`vct` in a lit view), at 1/`downsample`.
    pub cones: bool,
    /// The cones' specular target: some material is glossy and `gi.specular` is not off.
    pub specular: bool,
    /// Some material emits: the G-buffer has an emission target.
    pub emission: bool,
    /// Ray-traced reflections fill that target (`gi.specular = "rt"`).
    pub rt_reflections: bool,
    /// The first four lights' shadows are cone-traced (`gi.shadows = "cone"`).
    pub cone_shadows: bool,
    /// The first four lights' shadows are ray-traced (`gi.shadows = "rt"`, final view, one of
    /// them casts shadows).
    pub rt_shadows: bool,
    /// The direct light samples shadow maps (unless cones or rays shadow every light).
    pub direct_shadow_maps: bool,
    /// Shadow-map views the frame draws where something samples them, else 0 (a 1x1
    /// placeholder is bound).
    pub shadow_views: u32,
    /// Some object with geometry moves: its shadow is drawn over a cache of the static casters'.
    pub moving_casters: bool,
    /// Reflective shadow maps (and their gather or propagation volume), where the mode uses them
    /// in a lit view and some light casts shadows.
    pub rsm: Option<RsmPlan>,
    /// The indirect light's reduction (`gi.downsample`).
    pub downsample: u32,
    /// Texels per side of each shadow-map view (`render.shadow_map_size`).
    pub shadow_map_size: u32,
}

/// The reflective shadow maps of `gi.mode` "rsm", "lpv" or "rsm+lpv".
#[derive(Debug, Clone, PartialEq)]
pub struct RsmPlan {
    /// `[shadow view, light, 0, 0]` per map layer (`lights::rsm_views`).
    pub views: Vec<[u32; 4]>,
    /// The maps' texels gathered per pixel ("rsm", "rsm+lpv").
    pub gather: bool,
    /// A propagation volume ("lpv", "rsm+lpv").
    pub lpv: bool,
    /// Texels per side of each map (`gi.rsm_size`).
    pub size: u32,
}

impl FramePlan {
    pub fn of(scene: &Scene) -> FramePlan {
        let s = &scene.settings;
        let lit = s.view.is_lit();
        let cones = lit && s.gi.mode == GiMode::Vct;
        let voxels =
            (s.gi.mode == GiMode::Vct || !lit).then(|| VoxelNeeds::of(scene, s.view == View::VoxelMip || cones));
        let glossy = scene.materials.iter().any(|m| m.is_glossy());
        let specular = cones && glossy && s.gi.specular != SpecularSource::Off;
        let cone_shadows = cones && s.gi.shadows == DirectShadows::Cone;
        let shadowed = scene.lights.iter().take(4).any(|l| l.cast_shadows);
        let rt_shadows = s.view == View::Final && s.gi.shadows == DirectShadows::Rt && shadowed;
        let direct_shadow_maps = !(cone_shadows || rt_shadows) || scene.lights.len() > 4;
        let voxel_lighting = s.gi.mode == GiMode::Vct || matches!(s.view, View::VoxelRadiance | View::VoxelMip);
        let voxel_maps = voxel_lighting && s.gi.occlusion == VoxelOcclusion::ShadowMap;
        let shadow_views = if direct_shadow_maps || voxel_maps { lights::shadow_view_count(scene) } else { 0 };
        let rsm = (lit && s.gi.uses_rsm())
            .then(|| lights::rsm_views(scene))
            .filter(|views| !views.is_empty())
            .map(|views| RsmPlan { views, gather: s.gi.gathers_rsm(), lpv: s.gi.uses_lpv(), size: s.gi.rsm_size });
        FramePlan {
            internal: s.internal_size(),
            output: (s.width, s.height),
            lit,
            voxels,
            cones,
            specular,
            emission: scene.materials.iter().any(|m| m.emission.max_element() > 0.0),
            rt_reflections: specular && s.gi.specular == SpecularSource::Rt,
            cone_shadows,
            rt_shadows,
            direct_shadow_maps,
            shadow_views,
            moving_casters: scene.objects.iter().any(|o| !o.motion.is_static() && !o.meshes.is_empty()),
            rsm,
            downsample: s.gi.downsample,
            shadow_map_size: s.shadow_map_size,
        }
    }

    /// Rays are traced (reflections or shadows): the scene's acceleration structures exist.
    pub fn rays(&self) -> bool {
        self.rt_reflections || self.rt_shadows
    }

    /// The size the indirect light is computed at (1/k of the internal size, rounded up).
    pub fn reduced(&self) -> (u32, u32) {
        let k = self.downsample;
        (self.internal.0.div_ceil(k), self.internal.1.div_ceil(k))
    }

    /// Every 2D target the frame creates, for the memory estimate (`budget`): a new target is
    /// listed here beside the condition that makes it, and the estimate follows.
    pub fn targets(&self) -> Vec<Target> {
        let (internal, reduced) = (self.internal, self.reduced());
        let mut t = vec![
            Target::new("gbuffer depth", DEPTH_FORMAT, internal),
            Target::new("gbuffer albedo", ALBEDO_FORMAT, internal),
            Target::new("gbuffer normal", NORMAL_FORMAT, internal),
            Target::new("gbuffer specular", SPECULAR_FORMAT, internal),
            Target::new("radiance", RADIANCE_FORMAT, internal),
            Target::new("display", DISPLAY_FORMAT, self.output),
        ];
        if self.emission {
            t.push(Target::new("gbuffer emission", EMISSION_FORMAT, internal));
        }
        if self.internal != self.output {
            t.push(Target::new("resolved radiance", RADIANCE_FORMAT, self.output));
        }
        if self.rt_shadows {
            t.push(Target::new("rt shadow visibility", SHADOW_VIS_FORMAT, internal));
        }
        // The indirect light at 1/k, and upsampled to full resolution when k > 1.
        let mut gi = |name, format| {
            t.push(Target::new(name, format, reduced));
            if self.downsample > 1 {
                t.push(Target::new(name, format, internal));
            }
        };
        if self.cones {
            gi("gi diffuse", GI_FORMAT);
            if self.specular {
                gi("gi specular", GI_FORMAT);
            }
            if self.cone_shadows {
                gi("gi shadow", SHADOW_VIS_FORMAT);
            }
        }
        if let Some(r) = &self.rsm {
            // The gather's or the lookup's light; the mix has both and their sum (at 1/k).
            gi("gi diffuse (rsm)", GI_FORMAT);
            if r.gather && r.lpv {
                t.extend([Target::new("gi diffuse (lpv)", GI_FORMAT, reduced); 2]);
            }
        }
        t.extend(self.shadow_map_targets());
        t
    }

    /// The shadow maps (with moving casters twice: the static casters' cache; a 1x1 placeholder
    /// without views) and the reflective shadow maps.
    fn shadow_map_targets(&self) -> Vec<Target> {
        let shadow =
            |name, format, size: u32, layers| Target { name, format, size: (size, size), layers, shadow_map: true };
        let mut t = vec![match self.shadow_views {
            0 => shadow("shadow map placeholder", SHADOW_FORMAT, 1, 1),
            n => shadow("shadow maps", SHADOW_FORMAT, self.shadow_map_size, n),
        }];
        if self.moving_casters && self.shadow_views > 0 {
            t.push(shadow("shadow map cache", SHADOW_FORMAT, self.shadow_map_size, self.shadow_views));
        }
        if let Some(r) = &self.rsm {
            let layers = r.views.len() as u32;
            t.extend([
                shadow("rsm flux", rsm::FLUX_FORMAT, r.size, layers),
                shadow("rsm normal", rsm::NORMAL_FORMAT, r.size, layers),
                shadow("rsm position", rsm::POSITION_FORMAT, r.size, layers),
                shadow("rsm depth", rsm::DEPTH_FORMAT, r.size, layers),
            ]);
        }
        t
    }

    /// One line per part of the frame, for `dvsgi info`.
    pub fn summary(&self) -> Vec<String> {
        let yes = |b: bool, what: &str| b.then(|| what.to_string());
        let (iw, ih) = self.internal;
        let mut parts = vec![format!("{iw}x{ih} internal, {}x{} output", self.output.0, self.output.1)];
        parts.push(if self.lit { "lit image (G-buffer, lighting)".into() } else { "voxel view".into() });
        if let Some(v) = &self.voxels {
            let mut held = vec!["albedo", "normal", "radiance"];
            held.extend(v.emission.then_some("emission"));
            held.extend(v.dynamic.then_some("static flags"));
            held.extend(v.cones.then_some("directional mips"));
            parts.push(format!("voxels: {} ({} bounces)", held.join(", "), v.bounces));
        }
        let (rw, rh) = self.reduced();
        parts.extend(yes(self.cones, &format!("cones traced at {rw}x{rh}")));
        parts.extend(yes(self.specular, "specular target"));
        parts.extend(yes(self.rt_reflections, "ray-traced reflections"));
        parts.extend(yes(self.cone_shadows, "cone-traced shadows"));
        parts.extend(yes(self.rt_shadows, "ray-traced shadows"));
        let cached = if self.moving_casters { " (static casters cached)" } else { "" };
        parts.push(match (self.shadow_views, self.lit && self.direct_shadow_maps) {
            (0, _) => "no shadow maps".into(),
            (n, true) => format!("shadow maps: {n} views{cached}, sampled by the direct light"),
            (n, false) => format!("shadow maps: {n} views{cached}"),
        });
        if let Some(r) = &self.rsm {
            let what = [r.gather.then_some("gather"), r.lpv.then_some("propagation volume")];
            let what: Vec<&str> = what.into_iter().flatten().collect();
            parts.push(format!("reflective shadow maps: {} views, {}", r.views.len(), what.join(" and ")));
        }
        parts
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{LightKind, Material, Motion, Object, ViewDirection};
    use glam::Vec3;

    /// A box lit by a point light that casts shadows (six cube-map views), one material.
    fn lit_scene(mode: GiMode) -> Scene {
        let point = LightKind::Point { position: Vec3::ONE, intensity: Vec3::ONE };
        let mut scene = crate::render::test_scene(vec![point]);
        scene.lights[0].cast_shadows = true;
        scene.materials.push(Material::diffuse("white", Vec3::splat(0.8)));
        scene.settings.gi.mode = mode;
        scene
    }

    #[test]
    fn cone_tracing_in_the_final_view_needs_voxels_with_mips_cones_and_shadow_maps() {
        let mut scene = lit_scene(GiMode::Vct);
        scene.settings.gi.downsample = 2;
        scene.settings.width = 101;
        let plan = FramePlan::of(&scene);
        assert!(plan.lit && plan.cones && !plan.specular && !plan.rays());
        let v = plan.voxels.expect("voxels");
        assert!(v.cones && v.bounces == scene.settings.gi.bounces);
        assert_eq!(plan.shadow_views, 6);
        assert!(plan.direct_shadow_maps);
        assert_eq!(plan.reduced().0, 51, "1/k rounded up");
        assert_eq!(plan.rsm, None);
    }

    #[test]
    fn glossy_materials_get_a_specular_target_and_rays_only_where_asked() {
        let mut scene = lit_scene(GiMode::Vct);
        scene.materials[0].specular = Vec3::splat(0.5);
        assert!(FramePlan::of(&scene).specular);
        scene.settings.gi.specular = SpecularSource::Rt;
        let plan = FramePlan::of(&scene);
        assert!(plan.rt_reflections && plan.rays());
        scene.settings.gi.mode = GiMode::None;
        let plan = FramePlan::of(&scene);
        assert!(!plan.specular && !plan.rays() && plan.voxels.is_none(), "no cones: no target, no rays");
    }

    #[test]
    fn traced_shadows_replace_the_direct_lights_maps_but_not_the_voxels() {
        let mut scene = lit_scene(GiMode::Vct);
        scene.settings.gi.shadows = DirectShadows::Cone;
        let plan = FramePlan::of(&scene);
        assert!(plan.cone_shadows && !plan.direct_shadow_maps);
        assert_eq!(plan.shadow_views, 6, "the voxels' light still samples the maps");
        scene.settings.gi.occlusion = VoxelOcclusion::Raymarch;
        assert_eq!(FramePlan::of(&scene).shadow_views, 0, "nothing samples them");
        scene.settings.gi.shadows = DirectShadows::Rt;
        scene.settings.view = View::Ao;
        let plan = FramePlan::of(&scene);
        assert!(!plan.rt_shadows && plan.direct_shadow_maps, "rays shadow only the final image");
        scene.settings.view = View::Final;
        scene.lights[0].cast_shadows = false;
        assert!(!FramePlan::of(&scene).rt_shadows, "no shadowed light among the first four");
    }

    #[test]
    fn voxel_views_have_voxels_but_no_lit_image() {
        let mut scene = lit_scene(GiMode::Rsm);
        scene.settings.view = View::VoxelAlbedo;
        let plan = FramePlan::of(&scene);
        assert!(!plan.lit && !plan.cones && plan.rsm.is_none());
        assert!(!plan.voxels.expect("voxels").cones);
        scene.settings.view = View::VoxelMip;
        scene.settings.view_direction = ViewDirection::PosX;
        assert!(FramePlan::of(&scene).voxels.expect("voxels").cones, "the mip view samples the directional mips");
    }

    #[test]
    fn reflective_shadow_maps_need_a_shadowed_light_and_say_what_they_feed() {
        let mut scene = lit_scene(GiMode::RsmLpv);
        let rsm = FramePlan::of(&scene).rsm.expect("maps");
        assert!(rsm.gather && rsm.lpv && !rsm.views.is_empty());
        scene.settings.gi.mode = GiMode::Lpv;
        let rsm = FramePlan::of(&scene).rsm.expect("maps");
        assert!(!rsm.gather && rsm.lpv);
        scene.lights[0].cast_shadows = false;
        assert_eq!(FramePlan::of(&scene).rsm, None, "no shadowed light: no maps, no indirect light");
    }

    #[test]
    fn the_targets_follow_the_plan_sizes_and_conditions() {
        let mut scene = lit_scene(GiMode::Vct);
        scene.materials[0].specular = Vec3::splat(0.5);
        (scene.settings.width, scene.settings.height) = (40, 30);
        scene.settings.supersample = 2;
        scene.settings.gi.downsample = 4;
        scene.settings.gi.shadows = DirectShadows::Cone;
        let plan = FramePlan::of(&scene);
        let targets = plan.targets();
        let sizes =
            |name: &str| -> Vec<(u32, u32)> { targets.iter().filter(|t| t.name == name).map(|t| t.size).collect() };
        assert_eq!(sizes("gbuffer normal"), [(80, 60)], "the internal (supersampled) size");
        assert_eq!(sizes("display"), [(40, 30)]);
        assert_eq!(sizes("resolved radiance"), [(40, 30)]);
        assert_eq!(sizes("gi specular"), [(20, 15), (80, 60)], "1/4 and upsampled");
        assert_eq!(sizes("gi shadow"), [(20, 15), (80, 60)]);
        assert!(sizes("rt shadow visibility").is_empty());
        let maps: u64 = targets.iter().filter(|t| t.shadow_map).map(Target::bytes).sum();
        let side = u64::from(scene.settings.shadow_map_size);
        assert_eq!(maps, 6 * 4 * side * side, "six cube faces of 32-bit depth");
        let gbuffer = |targets: &[Target]| -> u64 {
            targets.iter().filter(|t| t.name.starts_with("gbuffer")).map(Target::bytes).sum()
        };
        assert_eq!(gbuffer(&targets), 80 * 60 * (4 + 4 + 8 + 4), "no material emits: no emission target");
        scene.materials[0].emission = Vec3::splat(2.0);
        let plan = FramePlan::of(&scene);
        assert!(plan.emission);
        assert_eq!(gbuffer(&plan.targets()), 80 * 60 * (4 + 4 + 8 + 4 + 8), "and with the emission target");
    }

    #[test]
    fn moving_objects_with_geometry_cache_the_static_casters() {
        let mut scene = lit_scene(GiMode::None);
        assert!(!FramePlan::of(&scene).moving_casters);
        let spin = Motion::Parametric {
            axis: Vec3::Y,
            pivot: Vec3::ZERO,
            degrees_per_second: 10.0,
            velocity: Vec3::ZERO,
            amplitude: Vec3::ZERO,
            period: 1.0,
        };
        let transform = glam::Mat4::IDENTITY;
        scene.objects.push(Object { name: "o".into(), meshes: vec![], transform, dynamic: true, motion: spin });
        assert!(!FramePlan::of(&scene).moving_casters, "an object without meshes casts nothing");
        scene.objects[0].meshes.push(0);
        assert!(FramePlan::of(&scene).moving_casters);
    }
}
