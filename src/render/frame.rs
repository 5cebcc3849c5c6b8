//! The frame: which passes exist for this scene and the order they run in.
//! This is the one place to read to know what a frame does.

use super::graph::{Pass, QueueKind};
use super::lights::GpuShadowView;
use super::passes::exposure::ExposurePasses;
use super::passes::gbuffer::{GBuffer, GBufferPass};
use super::passes::gi_trace::{GiAddPass, GiPlaceholders, GiTargets, GiTracePass, GiUpsamplePass};
use super::passes::lighting::{GiInputs, LightingInputs, LightingOutput, LightingPass};
use super::passes::lpv::{LpvInjectPass, LpvLookupPass, LpvPropagatePass, LpvVolumes};
use super::passes::readback::ReadbackPasses;
use super::passes::resolve::ResolvePass;
use super::passes::rsm::{RsmGatherPass, RsmMaps, RsmPass};
use super::passes::rt_shadow::RtShadowPass;
use super::passes::shadow::{ShadowMaps, StaticCasterCache};
use super::passes::tonemap::{TonemapPass, DISPLAY_FORMAT};
use super::passes::upload::{UploadPass, Uploads};
use super::passes::voxel_backs::VoxelBacksPass;
use super::passes::voxel_bounce::{BounceComposePass, BounceTailPass, TailStep, VoxelBouncePass};
use super::passes::voxel_bricks::{BrickClearPass, BrickListPass};
use super::passes::voxel_clear::{DynamicClearPass, VoxelClearPass};
use super::passes::voxel_light::VoxelLightPass;
use super::passes::voxel_list::{ListKeeper, ListStep, VoxelListPass};
use super::passes::voxel_mips::{VoxelMipPass, VoxelMips};
use super::passes::voxel_resolve::{Scan, VoxelResolvePass};
use super::passes::voxel_view::{VoxelMipViewPass, VoxelViewPass};
use super::passes::voxelize::{VoxelizePass, Voxelizer};
use super::plan::{FramePlan, RsmPlan, RADIANCE_FORMAT, SHADOW_FORMAT};
use super::rays::{missing_ray_queries, RtReflectPass, SceneRays, TopLevelBuildPass};
use super::reuse::InputsSeen;
use super::scene_gpu::SceneGpu;
use super::voxel::{VoxelNeeds, VoxelVolumes};
use super::FrameBuffers;
use crate::gpu::{Buffer, Context, GpuResult, Image, ImageDesc};
use crate::scene::{DirectShadows, GiMode, RenderSettings, Scene, SpecularSource, View};
use ash::vk;
use std::cell::{Cell, RefCell};
use std::sync::Arc;

/// The voxel passes; they exist only with `gi.mode = "vct"` or a voxel view.
pub struct VoxelPasses {
    pub volumes: Arc<VoxelVolumes>,
    pub clear: VoxelClearPass,
    /// With bricked volumes: the bricks static geometry needs, made resident.
    pub bricks_static: Option<BrickPasses>,
    pub voxelize_static: VoxelizePass,
    /// The static voxels' sums made averages; builds the work list in grid order.
    pub resolve_static: VoxelResolvePass,
    /// Closes the work list of occupied voxels after static voxelization.
    pub list_static: VoxelListPass,
    /// With `gi.plane_backs = "closed"`: the static voxels' backs that close a solid.
    pub backs_static: Option<VoxelBacksPass>,
    /// Only with dynamic objects.
    pub dynamic: Option<DynamicPasses>,
    pub light: VoxelLightPass,
    /// Directional mips of the direct radiance; only when cones are traced.
    pub mips: Option<VoxelMipPass>,
    /// Only with bounces.
    pub bounces: Option<BouncePasses>,
}

impl VoxelPasses {
    /// Voxelization (static, dynamic, bricks), the voxels' light, their mips and bounces, over
    /// the `shared` volumes and reading this copy's `frame` data and shadow `atlas`.
    fn new(
        ctx: &Arc<Context>,
        scene: &Scene,
        scene_gpu: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        (atlas, shared): (&Arc<Image>, &VoxelShared),
    ) -> GpuResult<VoxelPasses> {
        let s = &scene.settings;
        let VoxelShared { volumes, keeper, scan, mips: shared_mips } = shared;
        let volumes = volumes.clone();
        let voxelizer = Voxelizer::new(ctx, scene_gpu, frame, &volumes)?;
        let dynamic = if volumes.needs.dynamic {
            Some(DynamicPasses {
                clear: DynamicClearPass::new(ctx, &volumes, keeper)?,
                bricks: BrickPasses::new(ctx, &voxelizer, &volumes, true, scan)?,
                voxelize: VoxelizePass::new(&voxelizer, true),
                list: VoxelListPass::new(keeper, ListStep::Dynamic),
                resolve: VoxelResolvePass::after_dynamic(ctx, &volumes)?,
                backs: VoxelBacksPass::new(ctx, &volumes, true)?,
            })
        } else {
            None
        };
        let (mips, bounces) = if let Some(shared) = shared_mips {
            let bounces = BouncePasses::new(ctx, frame, &volumes, shared, &scene_gpu.sky)?;
            (Some(VoxelMipPass::new(ctx, shared, &volumes, &volumes.radiance)?), bounces)
        } else {
            (None, None)
        };
        Ok(VoxelPasses {
            light: VoxelLightPass::new(ctx, frame, &volumes, atlas, &s.gi)?,
            clear: VoxelClearPass::new(&volumes),
            bricks_static: BrickPasses::new(ctx, &voxelizer, &volumes, false, scan)?,
            voxelize_static: VoxelizePass::new(&voxelizer, false),
            resolve_static: VoxelResolvePass::after_static(ctx, &volumes, scan)?,
            list_static: VoxelListPass::new(keeper, ListStep::Static),
            backs_static: VoxelBacksPass::new(ctx, &volumes, false)?,
            dynamic,
            mips,
            bounces,
            volumes,
        })
    }
}

/// What every copy of the voxel passes shares: the volumes and work lists (what a frame leaves
/// for the next), and the pipelines of the list steps, the scan and the mips.
pub struct VoxelShared {
    pub volumes: Arc<VoxelVolumes>,
    keeper: Arc<ListKeeper>,
    /// One scan (glsl/scan.comp) for the static work list and every brick allocation.
    scan: Arc<Scan>,
    /// Only when cones are traced.
    mips: Option<Arc<VoxelMips>>,
}

impl VoxelShared {
    fn new(ctx: &Arc<Context>, scene: &Scene, needs: VoxelNeeds) -> GpuResult<VoxelShared> {
        let volumes = Arc::new(VoxelVolumes::new(ctx, scene, needs)?);
        Ok(VoxelShared {
            keeper: ListKeeper::new(ctx, &volumes)?,
            scan: Arc::new(Scan::new(ctx, &volumes)?),
            mips: volumes.needs.cones.then(|| VoxelMips::new(ctx, &volumes)).transpose()?,
            volumes,
        })
    }
}

/// What one frame leaves for the next, made once per renderer and shared by every copy of the
/// frame's passes (`async-pipelined` keeps one copy per frame in flight; its images equal
/// `sync`'s because everything that carries over from frame to frame lives here): the voxel
/// volumes and work lists, the scene's acceleration structures, the automatic exposure's state
/// and the ray-traced reflections' history.
pub struct Carried {
    /// Only with `gi.mode = "vct"` or a voxel view.
    pub voxels: Option<VoxelShared>,
    /// Only where rays are traced (`gi.specular` or `gi.shadows` = "rt").
    pub rays: Option<Arc<SceneRays>>,
    /// The EV the tone map adds with `render.exposure = "auto"`, eased from frame to frame.
    pub exposure: Arc<Buffer>,
    /// Only with ray-traced reflections: the reflections averaged over the frames the view and
    /// the scene stood still (at the traced resolution).
    pub reflection_history: Option<Arc<Image>>,
    /// Only with shadow maps and moving casters: the static casters' maps (graphics only).
    pub static_casters: Option<StaticCasterCache>,
}

impl Carried {
    /// What the frame of `plan` carries over, created (the acceleration structures built) now.
    pub fn new(ctx: &Arc<Context>, (scene, plan): (&Scene, &FramePlan), scene_gpu: &SceneGpu) -> GpuResult<Carried> {
        refuse_rays_without_queries(ctx, &scene.settings)?;
        let voxels = plan.voxels.map(|needs| VoxelShared::new(ctx, scene, needs)).transpose()?;
        let rays = match plan.rays() {
            true => Some(Arc::new(SceneRays::new(ctx, scene, scene_gpu, scene.settings.time)?)),
            false => None,
        };
        let reflection_history = match (plan.rt_reflections && plan.specular, plan.cones) {
            (true, true) => Some(RtReflectPass::history(ctx, plan.reduced())?),
            _ => None,
        };
        let s = &scene.settings;
        let static_casters = match plan.shadow_views {
            0 => None,
            views => StaticCasterCache::new(ctx, scene_gpu, shadow_atlas_desc(s.shadow_map_size, views))?,
        };
        Ok(Carried { voxels, rays, exposure: ExposurePasses::state(ctx)?, reflection_history, static_casters })
    }
}

/// Revoxelizing the dynamic objects: empty their voxels (the list's dynamic range), voxelize
/// them again, close the list, resolve their sums (and mark their closed backs).
pub struct DynamicPasses {
    pub clear: DynamicClearPass,
    /// With bricked volumes: bricks the objects reach anew, made resident.
    pub bricks: Option<BrickPasses>,
    pub voxelize: VoxelizePass,
    pub list: VoxelListPass,
    pub resolve: VoxelResolvePass,
    /// With `gi.plane_backs = "closed"`.
    pub backs: Option<VoxelBacksPass>,
}

/// Making bricks resident before a voxelization: the marking run over the same geometry, then
/// the allocation of the marked bricks. Before a dynamic one, the dynamic bricks of the last
/// update are released first, and after the allocation their slots are emptied.
pub struct BrickPasses {
    pub release: Option<BrickListPass>,
    pub mark: VoxelizePass,
    pub allocate: BrickListPass,
    pub clear: Option<BrickClearPass>,
}

impl BrickPasses {
    fn new(
        ctx: &Arc<Context>,
        voxelizer: &Arc<Voxelizer>,
        volumes: &Arc<VoxelVolumes>,
        dynamic: bool,
        scan: &Arc<Scan>,
    ) -> GpuResult<Option<Self>> {
        let (Some(mark), Some(allocate)) =
            (VoxelizePass::marking(voxelizer, dynamic), BrickListPass::allocate(ctx, volumes, dynamic, scan)?)
        else {
            return Ok(None);
        };
        let (release, clear) = match dynamic {
            true => (BrickListPass::release(ctx, volumes)?, BrickClearPass::new(ctx, volumes)?),
            false => (None, None),
        };
        Ok(Some(BrickPasses { release, mark, allocate, clear }))
    }

    fn push<'a>(this: &'a Option<Self>, passes: &mut Vec<&'a dyn Pass>) {
        if let Some(b) = this {
            if let Some(r) = &b.release {
                passes.push(r);
            }
            passes.push(&b.mark);
            passes.push(&b.allocate);
            if let Some(c) = &b.clear {
                passes.push(c);
            }
        }
    }
}

/// The passes of a bounce step: a bounce gathering indirect light into the scratch volume, the
/// bounced radiance composed from it and the direct light, and the directional mips of that.
pub struct BouncePasses {
    /// Gathers the direct light: the first bounce of an update that starts afresh.
    pub from_direct: VoxelBouncePass,
    /// Gathers the bounced radiance: every later bounce, and with `gi.bounce_feedback` the
    /// first bounce of every update after the first, so bounces accumulate over updates.
    pub from_bounced: VoxelBouncePass,
    pub compose: BounceComposePass,
    pub mips: VoxelMipPass,
    /// Only with `gi.bounce_tail` (and feedback, and 4 or more first-update bounces).
    pub tail: Option<TailPasses>,
}

impl BouncePasses {
    /// The bounce steps over `volumes` (None without bounces), with the first update's tail
    /// where the volumes have its records.
    fn new(
        ctx: &Arc<Context>,
        frame: &FrameBuffers,
        volumes: &Arc<VoxelVolumes>,
        shared: &Arc<VoxelMips>,
        sky: &super::sky::SkyGpu,
    ) -> GpuResult<Option<BouncePasses>> {
        let (true, Some(buffer)) = (volumes.needs.bounces > 0, &volumes.bounce_tail) else { return Ok(None) };
        let bounced = &volumes.bounced[0];
        let compose = |step| BounceComposePass::new(ctx, volumes, buffer, step);
        let tail = if volumes.needs.bounce_tail {
            Some(TailPasses {
                record: [compose(TailStep::RecordFirst)?, compose(TailStep::RecordSecond)?],
                gain: BounceTailPass::new(ctx, volumes, buffer)?,
                extrapolate: compose(TailStep::Extrapolate)?,
            })
        } else {
            None
        };
        Ok(Some(BouncePasses {
            from_direct: VoxelBouncePass::new(ctx, frame, volumes, &volumes.radiance, sky)?,
            from_bounced: VoxelBouncePass::new(ctx, frame, volumes, bounced, sky)?,
            compose: compose(TailStep::None)?,
            mips: VoxelMipPass::new(ctx, shared, volumes, bounced)?,
            tail,
        }))
    }
}

/// The first update's bounce tail (`gi.bounce_tail`): the compose steps of its third- and
/// second-last bounces record what each added, the gain pass takes their ratio, and the last
/// bounce's compose adds the geometric tail of the bounces not run.
pub struct TailPasses {
    pub record: [BounceComposePass; 2],
    pub gain: BounceTailPass,
    pub extrapolate: BounceComposePass,
}

/// Per-pixel cone tracing (and the upsample when tracing at reduced resolution).
pub struct ConePasses {
    pub trace: GiTracePass,
    /// Only with `gi.specular = "rt"` and some glossy material: the reflections, traced into
    /// the specular target the cone would have written.
    pub reflect: Option<RtReflectPass>,
    /// Only with `gi.downsample` > 1.
    pub upsample: Option<GiUpsamplePass>,
    /// What the tracing writes at 1/k (`gi.downsample`): diffuse, specular, shadows.
    pub low: GiTargets,
}

/// The scene's acceleration structures, for ray-traced reflections or shadows.
pub struct RayPasses {
    pub scene: Arc<SceneRays>,
    /// Only when some object moves: the top level, rebuilt from the frame's instances.
    pub build: Option<TopLevelBuildPass>,
}

impl RayPasses {
    /// Where the frame traces rays (`FramePlan::rays`): the scene's structures (`Carried`).
    fn new(carried: &Carried) -> Option<RayPasses> {
        let rays = carried.rays.as_ref()?;
        Some(RayPasses { build: rays.dynamic.then(|| TopLevelBuildPass::new(rays)), scene: rays.clone() })
    }
}

impl ConePasses {
    /// The tracer and its targets; the reflections where `rays` exist for them.
    #[allow(clippy::too_many_arguments)]
    fn new(
        ctx: &Arc<Context>,
        (scene, plan): (&Scene, &FramePlan),
        scene_gpu: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        volumes: &Arc<VoxelVolumes>,
        placeholders: &Arc<GiPlaceholders>,
        carried: &Carried,
    ) -> GpuResult<ConePasses> {
        let s = &scene.settings;
        let (width, height) = plan.internal;
        let (specular, rt, cone_shadows) = (plan.specular, plan.rt_reflections, plan.cone_shadows);
        let k = plan.downsample;
        let (lw, lh) = plan.reduced();
        let label = if k > 1 { format!(" (1/{k})") } else { String::new() };
        let low = GiTargets::new(ctx, &label, lw, lh, specular, cone_shadows)?;
        let upsample = if k > 1 {
            let full = GiTargets::new(ctx, "", width, height, specular, cone_shadows)?;
            Some(GiUpsamplePass::new(ctx, frame, gbuffer, &volumes.gi_params, &low, full, placeholders)?)
        } else {
            None
        };
        // With rays the cone tracer leaves the specular target to the reflection pass.
        let traced = GiTargets { specular: if rt { None } else { low.specular.clone() }, ..low.clone() };
        let reflect = match (rt, &low.specular, &carried.rays, &carried.reflection_history) {
            (true, Some(target), Some(rays), Some(history)) => Some(RtReflectPass::new(
                ctx,
                frame,
                gbuffer,
                volumes,
                (scene_gpu, rays),
                (target, history),
                (s.gi.specular_rays, s.gi.rt_hit_indirect),
            )?),
            _ => None,
        };
        Ok(ConePasses {
            trace: GiTracePass::new(ctx, frame, gbuffer, volumes, traced, placeholders, &scene_gpu.sky)?,
            reflect,
            upsample,
            low,
        })
    }

    /// The targets the lighting pass reads: full resolution.
    fn output(&self) -> &GiTargets {
        self.upsample.as_ref().map(|u| &u.targets).unwrap_or(&self.low)
    }

    /// The passes after the G-buffer, in order.
    fn push<'a>(&'a self, passes: &mut Vec<&'a dyn Pass>) {
        passes.push(&self.trace);
        if let Some(r) = &self.reflect {
            passes.push(r);
        }
        if let Some(up) = &self.upsample {
            passes.push(up);
        }
    }
}

/// The light propagation volume's passes (`gi.mode = "lpv"` or `"rsm+lpv"`).
pub struct LpvPasses {
    pub volumes: Arc<LpvVolumes>,
    pub inject: LpvInjectPass,
    /// Only with `gi.lpv_steps` > 0.
    pub propagate: Option<LpvPropagatePass>,
    pub lookup: LpvLookupPass,
}

impl LpvPasses {
    /// The volume of `gi.mode = "lpv"`, or the far field of `"rsm+lpv"` (which sums only the
    /// light that has travelled `MIX_SPLIT_CELLS` cells, on the graphics queue beside the
    /// gather on compute, as in the async-compute study).
    fn new(
        ctx: &Arc<Context>,
        scene: &Scene,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        maps: &Arc<RsmMaps>,
        params: &Buffer,
        low: GiTargets,
    ) -> GpuResult<LpvPasses> {
        let gi = &scene.settings.gi;
        let mix = gi.mode == GiMode::RsmLpv;
        let skipped = if mix { crate::render::lpv::MIX_SPLIT_CELLS } else { 0 };
        let q = if mix { QueueKind::Graphics } else { QueueKind::Compute };
        let quanta = crate::render::lpv::quanta(scene, maps.views.len());
        let grid = crate::render::lpv::grid(scene);
        let volumes = Arc::new(LpvVolumes::new(ctx, grid, gi.lpv_occlusion, skipped, quanta)?);
        let propagate =
            (gi.lpv_steps > 0).then(|| LpvPropagatePass::new(ctx, &volumes, gi.lpv_steps, q)).transpose()?;
        Ok(LpvPasses {
            inject: LpvInjectPass::new(ctx, maps, &volumes, q)?,
            propagate,
            lookup: LpvLookupPass::new(ctx, frame, gbuffer, &volumes, params, low, q)?,
            volumes,
        })
    }
}

/// The techniques built on reflective shadow maps (`gi.mode = "rsm"`, `"lpv"` or
/// `"rsm+lpv"`): the maps of every shadowed light, then the per-pixel RSM gather and/or the
/// light propagation volume (their sum for the mix), and the upsample when working at reduced
/// resolution.
pub struct RsmPasses {
    pub render: RsmPass,
    /// `gi.mode = "rsm"` or `"rsm+lpv"`.
    pub gather: Option<RsmGatherPass>,
    /// `gi.mode = "lpv"` or `"rsm+lpv"`.
    pub lpv: Option<LpvPasses>,
    /// `gi.mode = "rsm+lpv"`: the gather's near field plus the volume's far field.
    pub add: Option<GiAddPass>,
    /// Only with `gi.downsample` > 1.
    pub upsample: Option<GiUpsamplePass>,
    /// The downsampling factor for the gather, the lookup and the upsample (`GiParams`).
    params: Buffer,
    /// The views, lights and instances the maps were drawn from.
    seen: RefCell<InputsSeen>,
    /// The next frame draws the maps (and injects and propagates the volume): they changed.
    due: Cell<bool>,
}

impl RsmPasses {
    /// The maps of `rsm`'s views, their gather or volume, the sum and the upsample.
    fn new(
        ctx: &Arc<Context>,
        (scene, plan, rsm): (&Scene, &FramePlan, &RsmPlan),
        scene_gpu: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        gbuffer: &Arc<GBuffer>,
        placeholders: &Arc<GiPlaceholders>,
    ) -> GpuResult<RsmPasses> {
        let gi = &scene.settings.gi;
        let maps = Arc::new(RsmMaps::new(ctx, gi.rsm_size, rsm.views.clone())?);
        let params = Buffer::uniform(ctx, "rsm gi params", &crate::render::cones::GpuGiParams::new(gi, 1, 1.0, 1))?;
        let (width, height) = plan.internal;
        let k = plan.downsample;
        let (lw, lh) = plan.reduced();
        let low = |what: &str| {
            let label = if k > 1 { format!(" ({what}, 1/{k})") } else { format!(" ({what})") };
            GiTargets::new(ctx, &label, lw, lh, false, false)
        };
        let mix = gi.mode == GiMode::RsmLpv;
        let grid = crate::render::lpv::grid(scene);
        let split = crate::render::lpv::MIX_SPLIT_CELLS;
        let lpv = if rsm.lpv {
            let low = low("lpv")?;
            Some(LpvPasses::new(ctx, scene, frame, gbuffer, &maps, &params, low)?)
        } else {
            None
        };
        let gather = if rsm.gather {
            let near = if mix { split as f32 * grid.voxel_size } else { 0.0 };
            Some(RsmGatherPass::new(ctx, frame, gbuffer, &maps, &params, low("rsm")?, gi, near)?)
        } else {
            None
        };
        let add = match (&gather, &lpv) {
            (Some(g), Some(l)) => Some(GiAddPass::new(ctx, &g.targets, &l.lookup.targets, low("rsm+lpv")?)?),
            _ => None,
        };
        let what = match gi.mode {
            GiMode::Lpv => "lpv",
            GiMode::RsmLpv => "rsm+lpv",
            _ => "rsm",
        };
        let render = RsmPass::new(ctx, scene_gpu, frame, &maps)?;
        let (seen, due) = (RefCell::default(), Cell::new(true));
        let mut passes = RsmPasses { render, gather, lpv, add, upsample: None, params, seen, due };
        if k > 1 {
            let full = GiTargets::new(ctx, &format!(" ({what})"), width, height, false, false)?;
            let up = GiUpsamplePass::new(ctx, frame, gbuffer, &passes.params, passes.low(), full, placeholders)?;
            passes.upsample = Some(up);
        }
        Ok(passes)
    }

    /// Plan the next frame: the maps are drawn (and the volume injected and propagated) when
    /// the views they are drawn from, the lights or the instances changed.
    pub fn plan(&self, views: &[GpuShadowView], lights: &[u8], instances: &[u8]) {
        let own = self.render.maps.views.iter().map(|v| &views[v[0] as usize]);
        let mut inputs: Vec<u8> = own.flat_map(|v| bytemuck::bytes_of(v).to_vec()).collect();
        inputs.extend_from_slice(lights);
        inputs.extend_from_slice(instances);
        self.due.set(self.seen.borrow_mut().changed(&inputs));
    }

    /// After a frame is recorded: the next one draws the maps only if its plan says so.
    pub fn recorded(&self) {
        self.due.set(false);
    }

    /// The passes before the G-buffer: the maps, when they changed.
    fn before_gbuffer(&self) -> Vec<&dyn Pass> {
        if self.due.get() {
            vec![&self.render]
        } else {
            Vec::new()
        }
    }

    /// The indirect light at the traced resolution.
    fn low(&self) -> &GiTargets {
        match (&self.add, &self.gather, &self.lpv) {
            (Some(a), _, _) => &a.targets,
            (None, Some(g), _) => &g.targets,
            (None, None, Some(l)) => &l.lookup.targets,
            (None, None, None) => unreachable!("RsmPasses has a gather or a volume"),
        }
    }

    /// The indirect light at full resolution.
    pub fn targets(&self) -> &GiTargets {
        self.upsample.as_ref().map_or(self.low(), |u| &u.targets)
    }

    /// The passes after the G-buffer, in order.
    fn after_gbuffer(&self) -> Vec<&dyn Pass> {
        let mut out: Vec<&dyn Pass> = Vec::new();
        if let Some(g) = &self.gather {
            out.push(g);
        }
        if let Some(l) = &self.lpv {
            // The volume holds the light of the maps as they are.
            if self.due.get() {
                out.push(&l.inject);
                if let Some(p) = &l.propagate {
                    out.push(p);
                }
            }
            out.push(&l.lookup);
        }
        if let Some(a) = &self.add {
            out.push(a);
        }
        if let Some(up) = &self.upsample {
            out.push(up);
        }
        out
    }

    /// Every image, for memory reports.
    fn images(&self) -> Vec<&Arc<Image>> {
        let mut out = self.render.maps.all();
        out.extend(self.gather.iter().flat_map(|g| g.targets.all()));
        out.extend(self.lpv.iter().flat_map(|l| l.lookup.targets.all()));
        out.extend(self.add.iter().flat_map(|a| a.targets.all()));
        out.extend(self.lpv.iter().flat_map(|l| l.volumes.all()));
        out.extend(self.upsample.iter().flat_map(|u| u.targets.all()));
        out
    }
}

/// How the frame shades pixels.
pub enum Shading {
    Lighting(LightingPass),
    VoxelView(VoxelViewPass),
    MipView(VoxelMipViewPass),
}

impl Shading {
    /// A voxel view where `render.view` asks for one, else the lighting pass over `lit`.
    fn new(
        ctx: &Arc<Context>,
        scene: &Scene,
        frame: &FrameBuffers,
        voxels: Option<&VoxelPasses>,
        lit: LightingInputs,
    ) -> GpuResult<Shading> {
        let s = &scene.settings;
        let radiance = lit.radiance;
        Ok(match (voxels, s.view) {
            (Some(v), View::VoxelMip) => {
                Shading::MipView(VoxelMipViewPass::new(ctx, frame, &v.volumes, s.view_lod, s.view_direction, radiance)?)
            }
            (Some(v), view) if !view.is_lit() => {
                Shading::VoxelView(VoxelViewPass::new(ctx, frame, &v.volumes, view, radiance)?)
            }
            _ => Shading::Lighting(LightingPass::new(ctx, frame, lit, LightingOutput::of(s.view))?),
        })
    }
}

/// Every pass the scene needs, created once.
pub struct FramePasses {
    /// Writes the frame's host data (uniforms, lights, shadow views, instances).
    pub upload: UploadPass,
    pub voxels: Option<VoxelPasses>,
    /// Only when some light casts shadows that are resolved with shadow maps.
    pub shadow: Option<ShadowMaps>,
    /// The direct light samples the shadow maps (every frame); else only voxel lighting does.
    pub direct_shadow_maps: bool,
    pub gbuffer: GBufferPass,
    /// `render.depth_prepass` (resolved for the device): the opaque draws' depth, which the
    /// G-buffer is drawn over.
    pub depth_prepass: Option<GBufferPass>,
    /// Only where rays are traced (`gi.specular` or `gi.shadows` = "rt").
    pub rays: Option<RayPasses>,
    /// Only with `gi.shadows = "rt"`: the direct light's shadow rays.
    pub rt_shadow: Option<RtShadowPass>,
    /// Only when the shading uses cone-traced light.
    pub cones: Option<ConePasses>,
    /// Only with `gi.mode = "rsm"` and some light that casts shadows.
    pub rsm: Option<RsmPasses>,
    pub shading: Shading,
    /// Only with `render.supersample` > 1: radiance samples to output pixels.
    pub resolve: Option<ResolvePass>,
    /// Only run with `render.exposure = "auto"`: the EV the tone map adds.
    pub exposure: ExposurePasses,
    pub tonemap: TonemapPass,
    /// Created on the first frame whose output is read back (not for benchmarks).
    pub readback: Option<ReadbackPasses>,
    /// What the frame needs, which these passes are made of.
    pub plan: FramePlan,
    /// The frame's 2D targets.
    pub targets: FrameTargets,
}

/// The frame's 2D targets, by name (for memory reports: `Renderer::all_images`).
pub struct FrameTargets {
    pub gbuffer: Arc<GBuffer>,
    /// The shadow maps (or their 1x1 placeholder).
    pub shadow_atlas: Arc<Image>,
    /// The shaded radiance, at the internal size.
    pub radiance: Arc<Image>,
    /// The tone-mapped image, at the output size.
    pub display: Arc<Image>,
    /// With supersampling: the radiance resolved to the output size.
    pub resolved: Option<Arc<Image>>,
    /// With moving casters: the static casters' shadow maps.
    pub shadow_cache: Option<Arc<Image>>,
    /// With `gi.shadows = "rt"`: the shadow rays' visibility.
    pub rt_visibility: Option<Arc<Image>>,
}

impl FrameTargets {
    /// The targets of a frame whose passes write them.
    fn of(
        (gbuffer, atlas): (&Arc<GBuffer>, &Arc<Image>),
        (radiance, display, resolve): (&Arc<Image>, &Arc<Image>, Option<&ResolvePass>),
        shadow: Option<&ShadowMaps>,
        rt_shadow: Option<&RtShadowPass>,
    ) -> FrameTargets {
        FrameTargets {
            gbuffer: gbuffer.clone(),
            shadow_atlas: atlas.clone(),
            radiance: radiance.clone(),
            display: display.clone(),
            resolved: resolve.map(|r| r.resolved.clone()),
            shadow_cache: shadow.and_then(|s| s.cached.as_ref()).map(|c| c.cache.clone()),
            rt_visibility: rt_shadow.map(|r| r.visibility.clone()),
        }
    }

    /// Every target that exists: the G-buffer, the shadow atlas, radiance and display, the
    /// shadow cache, the resolved radiance and the rays' visibility.
    pub fn all(&self) -> Vec<&Arc<Image>> {
        let g = &self.gbuffer;
        [&g.depth, &g.albedo, &g.normal, &g.specular, &self.shadow_atlas, &self.radiance, &self.display]
            .into_iter()
            .chain(&g.emission)
            .chain(&self.shadow_cache)
            .chain(&self.resolved)
            .chain(&self.rt_visibility)
            .collect()
    }
}

/// What differs from frame to frame.
#[derive(Debug, Clone, Copy)]
pub struct FrameState {
    /// Static geometry is already voxelized.
    pub static_voxelized: bool,
    /// Revoxelize dynamic objects this frame (the update policy says so).
    pub revoxelize: bool,
    /// Relight the voxels (and rebuild mips and bounces) this frame.
    pub relight: bool,
    /// Copy the outputs for the host.
    pub readback: bool,
    /// `render.exposure = "auto"`: the exposure passes run before the tone map.
    pub auto_exposure: bool,
    /// `async-lagged`: trace cones through the voxel radiance of the previous update and
    /// relight the voxels after the trace (only once a previous update exists).
    pub lagged: bool,
    /// Bounce steps this update runs (when it relights and the scene has bounces).
    pub bounces: u32,
    /// The first bounce gathers the bounced radiance of the previous update (feedback) rather
    /// than this update's direct light.
    pub feed_back: bool,
    /// The update adds the geometric tail of the bounces it does not run (`gi.bounce_tail`:
    /// the first update, with feedback).
    pub tail: bool,
    /// `async-pipelined`: the maps and the G-buffer are recorded before the voxel updates
    /// ([`FramePasses::list`]).
    pub raster_first: bool,
}

impl FramePasses {
    /// Every pass of `plan`, the frame of `scene`: one copy, with its own targets and maps,
    /// reading its own `frame` data, over what every copy shares (`carried`).
    pub fn new(
        ctx: &Arc<Context>,
        (scene, plan): (&Scene, &FramePlan),
        scene_gpu: &Arc<SceneGpu>,
        frame: &FrameBuffers,
        carried: &Carried,
    ) -> GpuResult<FramePasses> {
        let s = &scene.settings;
        let (width, height) = plan.internal;
        let gbuffer = Arc::new(GBuffer::new(ctx, width, height, plan.emission)?);
        let atlas = shadow_atlas(ctx, s.shadow_map_size, plan.shadow_views)?;
        let (radiance, display, resolve) = output_images(ctx, s)?;
        let shown = resolve.as_ref().map_or(&radiance, |r| &r.resolved).clone();
        let voxels = match &carried.voxels {
            Some(shared) => Some(VoxelPasses::new(ctx, scene, scene_gpu, frame, (&atlas, shared))?),
            None => None,
        };
        let placeholders = Arc::new(GiPlaceholders::new(ctx)?);
        let rays = RayPasses::new(carried);
        let cones = match (&voxels, plan.cones) {
            (Some(v), true) => Some(ConePasses::new(
                ctx,
                (scene, plan),
                scene_gpu,
                frame,
                &gbuffer,
                &v.volumes,
                &placeholders,
                carried,
            )?),
            _ => None,
        };
        let rt_shadow = match (&rays, plan.rt_shadows) {
            (Some(r), true) => Some(RtShadowPass::new(ctx, frame, &gbuffer, scene_gpu, &r.scene)?),
            _ => None,
        };
        let rsm = match &plan.rsm {
            Some(r) => Some(RsmPasses::new(ctx, (scene, plan, r), scene_gpu, frame, &gbuffer, &placeholders)?),
            None => None,
        };
        let lit = LightingInputs {
            gbuffer: &gbuffer,
            shadow_atlas: &atlas,
            radiance: &radiance,
            gi: gi_inputs(cones.as_ref(), rsm.as_ref()),
            shadow_visibility: shadow_visibility(rt_shadow.as_ref(), cones.as_ref()),
            placeholders: &placeholders,
            sky: &scene_gpu.sky,
        };
        let shading = Shading::new(ctx, scene, frame, voxels.as_ref(), lit)?;
        let views = plan.shadow_views;
        let cache = carried.static_casters.as_ref();
        let shadow = (views > 0).then(|| ShadowMaps::new(ctx, (scene_gpu, frame), &atlas, views, cache)).transpose()?;
        let exposure = ExposurePasses::new(ctx, frame, &shown, &carried.exposure)?;
        let images = (&radiance, &display, resolve.as_ref());
        let targets = FrameTargets::of((&gbuffer, &atlas), images, shadow.as_ref(), rt_shadow.as_ref());
        let prepass = plan.lit && s.depth_prepass.resolve(ctx.info.is_cpu());
        let (gbuffer, depth_prepass) = GBufferPass::for_frame(ctx, scene_gpu, frame, &gbuffer, prepass)?;
        Ok(FramePasses {
            upload: frame_upload(frame, scene_gpu, rays.as_ref()),
            voxels,
            shadow,
            direct_shadow_maps: plan.direct_shadow_maps,
            gbuffer,
            depth_prepass,
            targets,
            rays,
            rt_shadow,
            cones,
            rsm,
            shading,
            tonemap: TonemapPass::new(ctx, frame, &shown, &display, &exposure.state)?,
            exposure,
            resolve,
            readback: None,
            plan: plan.clone(),
        })
    }

    /// Forget what the maps hold: the next frame that needs them draws them all.
    pub fn forget_reuse(&self) {
        if let Some(s) = &self.shadow {
            s.forget();
        }
        if let Some(r) = &self.rsm {
            *r.seen.borrow_mut() = InputsSeen::default();
        }
    }

    /// The voxel volumes and the cone tracer's (or the RSM's) targets that exist.
    pub fn gi_images(&self) -> Vec<&Arc<Image>> {
        let mut out = Vec::new();
        if let Some(v) = &self.voxels {
            out.extend(v.volumes.all());
        }
        out.extend(self.gi_targets());
        out
    }

    /// The cone tracer's targets (at 1/k and full resolution), or the RSM's maps, targets
    /// and propagation volume.
    fn gi_targets(&self) -> Vec<&Arc<Image>> {
        let mut out = Vec::new();
        if let Some(c) = &self.cones {
            out.extend(c.low.all());
            out.extend(c.upsample.iter().flat_map(|u| u.targets.all()));
        }
        if let Some(r) = &self.rsm {
            out.extend(r.images());
        }
        out
    }

    /// The images this copy of the frame has for itself (every copy has its own): the 2D
    /// targets, the cone tracer's or the RSM's targets, the reflective shadow maps and the
    /// propagation volume; not the voxel volumes or the static casters' cache, which every
    /// copy shares (`Carried`).
    pub fn own_images(&self) -> Vec<&Arc<Image>> {
        let shared = self.targets.shadow_cache.as_ref();
        let mut out: Vec<&Arc<Image>> =
            self.targets.all().into_iter().filter(|i| !shared.is_some_and(|s| Arc::ptr_eq(i, s))).collect();
        out.extend(self.gi_targets());
        out
    }

    /// GPU memory of [`FramePasses::own_images`], bytes.
    pub fn own_bytes(&self) -> u64 {
        self.own_images().iter().map(|i| i.bytes).sum()
    }

    /// Create the readback passes if they do not exist yet.
    pub fn ensure_readback(&mut self, ctx: &Arc<Context>) -> GpuResult<()> {
        if self.readback.is_none() {
            let radiance = match (&self.resolve, &self.shading) {
                (Some(r), _) => r.resolved.clone(),
                (None, Shading::Lighting(l)) => l.radiance.clone(),
                (None, Shading::VoxelView(v)) => v.radiance.clone(),
                (None, Shading::MipView(v)) => v.radiance.clone(),
            };
            let mut readback = ReadbackPasses::new(ctx, &radiance, &self.tonemap.display)?;
            readback.host.buffers.push(self.exposure.state.clone());
            self.readback = Some(readback);
        }
        Ok(())
    }

    /// The scene's acceleration structures, where rays are traced.
    pub fn rays(&self) -> Option<&RayPasses> {
        self.rays.as_ref()
    }

    /// The top level's rebuild, where objects move and rays are traced.
    fn top_level_build(&self) -> Option<&TopLevelBuildPass> {
        self.rays().and_then(|r| r.build.as_ref())
    }

    /// The voxels' light for this update: direct light, mips, then each bounce and its mips.
    fn voxel_lighting(&self, state: FrameState) -> Vec<&dyn Pass> {
        let mut voxel_lighting: Vec<&dyn Pass> = Vec::new();
        let Some(v) = &self.voxels else { return voxel_lighting };
        voxel_lighting.push(&v.light);
        let feed_back = state.feed_back && v.bounces.is_some();
        // Feedback gathers through the mips of the previous bounced radiance, still in
        // the directional volumes.
        if let (false, Some(mips)) = (feed_back, &v.mips) {
            voxel_lighting.push(mips);
        }
        if let Some(b) = &v.bounces {
            let n = state.bounces;
            // The tail needs two records after a first bounce (whose increment is all of it);
            // `state.tail` implies it, the bound keeps the indices below from wrapping.
            let tail = b.tail.as_ref().filter(|_| state.tail && n >= 4);
            for i in 0..n {
                voxel_lighting.push(if i == 0 && !feed_back { &b.from_direct } else { &b.from_bounced });
                match tail {
                    Some(t) if i == n - 3 => voxel_lighting.push(&t.record[0]),
                    Some(t) if i == n - 2 => voxel_lighting.push(&t.record[1]),
                    Some(t) if i == n - 1 => voxel_lighting.extend([&t.gain as &dyn Pass, &t.extrapolate]),
                    _ => voxel_lighting.push(&b.compose),
                }
                voxel_lighting.push(&b.mips);
            }
        }
        voxel_lighting
    }

    /// The frame lights the voxels (and rebuilds mips and bounces).
    fn relights(&self, state: FrameState) -> bool {
        let lit_voxels = match &self.shading {
            Shading::Lighting(_) | Shading::MipView(_) => true,
            Shading::VoxelView(view) => view.shows_radiance(),
        };
        lit_voxels && (state.relight || !state.static_voxelized)
    }

    /// Something in the frame samples the shadow maps: the voxel light when it relights, the
    /// direct light unless cones or rays shadow every light. The maps are then brought up to
    /// date (`ShadowMaps::plan`), which draws only the views whose inputs changed.
    pub fn samples_shadow_maps(&self, state: FrameState) -> bool {
        let direct = self.direct_shadow_maps && matches!(&self.shading, Shading::Lighting(_));
        self.shadow.is_some() && (self.relights(state) || direct)
    }

    /// The frame, in dependency order. Every schedule mode runs these passes; the scheduler
    /// only decides which queue each goes to. With `state.raster_first` (async-pipelined) the
    /// maps and the G-buffer come before the voxel updates, so the graphics queue draws them
    /// while it would otherwise wait for the previous frame's voxel light (whose reads of the
    /// voxels the revoxelization must follow).
    pub fn list(&self, state: FrameState) -> Vec<&dyn Pass> {
        self.list_split(state).0
    }

    /// [`FramePasses::list`], and with `state.raster_first` where the voxel updates end: the
    /// scheduler ends their submit there, so that the next frame's revoxelization, which waits
    /// for them, does not also wait for this frame's cone trace where both would otherwise
    /// share a submit (one queue family, no transfer to split them).
    pub fn list_split(&self, state: FrameState) -> (Vec<&dyn Pass>, Option<usize>) {
        let voxelization = self.voxelization(state);
        let mut maps: Vec<&dyn Pass> = Vec::new();
        if let (true, Some(shadow)) = (self.samples_shadow_maps(state), &self.shadow) {
            shadow.push(&mut maps);
        }
        if let Some(r) = &self.rsm {
            maps.extend(r.before_gbuffer());
        }
        // The voxel illumination chain: direct light, mips, bounces (each with its mips).
        let mut voxel_lighting = if self.relights(state) { self.voxel_lighting(state) } else { Vec::new() };
        // Lagged: this frame's cones read the radiance of the previous update, and the new
        // radiance is computed after them (overlapping the rest of the frame's graphics work).
        let lagged = state.lagged && state.static_voxelized && self.cones.is_some();
        let (mut raster, shading) = self.shading();
        let mut passes: Vec<&dyn Pass> = vec![&self.upload];
        if state.raster_first {
            passes.extend(maps.into_iter().chain(raster.drain(..)).chain(voxelization));
        } else {
            passes.extend(voxelization.into_iter().chain(maps));
        }
        if !lagged {
            passes.append(&mut voxel_lighting);
        }
        let split = state.raster_first.then_some(passes.len());
        passes.append(&mut raster);
        passes.extend(shading);
        self.push_tail(state, &mut passes);
        passes.append(&mut voxel_lighting);
        (passes, split)
    }

    /// Voxelizing the static geometry (the first frame) and the dynamic objects (when the
    /// update policy says so).
    fn voxelization(&self, state: FrameState) -> Vec<&dyn Pass> {
        let mut passes: Vec<&dyn Pass> = Vec::new();
        let Some(v) = &self.voxels else { return passes };
        if !state.static_voxelized {
            passes.push(&v.clear);
            BrickPasses::push(&v.bricks_static, &mut passes);
            passes.push(&v.voxelize_static);
            passes.push(&v.resolve_static);
            passes.push(&v.list_static);
            passes.extend(v.backs_static.as_ref().map(|b| b as &dyn Pass));
        }
        if let (true, Some(d)) = (state.revoxelize || !state.static_voxelized, &v.dynamic) {
            passes.push(&d.clear);
            BrickPasses::push(&d.bricks, &mut passes);
            passes.push(&d.voxelize);
            passes.push(&d.list);
            passes.push(&d.resolve);
            passes.extend(d.backs.as_ref().map(|b| b as &dyn Pass));
        }
        passes
    }

    /// The shading: the rasterized part (the top level's rebuild and the G-buffer; none for a
    /// voxel view), then what shades its pixels (shadow rays, cones, the RSM's gather and
    /// volume, the deferred lighting; or the voxel view).
    fn shading(&self) -> (Vec<&dyn Pass>, Vec<&dyn Pass>) {
        let lighting = match &self.shading {
            Shading::Lighting(lighting) => lighting,
            // A voxel view needs no G-buffer.
            Shading::VoxelView(view) => return (Vec::new(), vec![view]),
            Shading::MipView(view) => return (Vec::new(), vec![view]),
        };
        let mut raster: Vec<&dyn Pass> = Vec::new();
        if let Some(build) = self.top_level_build() {
            raster.push(build);
        }
        if let Some(p) = &self.depth_prepass {
            raster.push(p);
        }
        raster.push(&self.gbuffer);
        let mut shading: Vec<&dyn Pass> = Vec::new();
        if let Some(r) = &self.rt_shadow {
            shading.push(r);
        }
        if let Some(c) = &self.cones {
            c.push(&mut shading);
        }
        if let Some(r) = &self.rsm {
            shading.extend(r.after_gbuffer());
        }
        shading.push(lighting);
        (raster, shading)
    }

    /// After the shading: the resolve, the exposure, the tone map and the read-back copies.
    fn push_tail<'a>(&'a self, state: FrameState, passes: &mut Vec<&'a dyn Pass>) {
        if let Some(r) = &self.resolve {
            passes.push(r);
        }
        if state.auto_exposure {
            passes.push(&self.exposure.tiles);
            passes.push(&self.exposure.resolve);
        }
        passes.push(&self.tonemap);
        if let (true, Some(r)) = (state.readback, &self.readback) {
            passes.push(&r.radiance);
            passes.push(&r.display);
            passes.push(&r.host);
        }
    }
}

/// The radiance the frame shades (at the internal size), the display image, and with
/// supersampling the pass that resolves the one into the output size.
fn output_images(ctx: &Arc<Context>, s: &RenderSettings) -> GpuResult<(Arc<Image>, Arc<Image>, Option<ResolvePass>)> {
    let sized = |name: &str, format, (width, height)| {
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        Image::new(ctx, name, ImageDesc::d2(format, width, height, usage)).map(Arc::new)
    };
    let radiance = sized("radiance", RADIANCE_FORMAT, s.internal_size())?;
    let display = sized("display", DISPLAY_FORMAT, (s.width, s.height))?;
    let resolve = if s.supersample > 1 {
        let resolved = sized("resolved radiance", RADIANCE_FORMAT, (s.width, s.height))?;
        Some(ResolvePass::new(ctx, &radiance, &resolved, s.supersample)?)
    } else {
        None
    };
    Ok((radiance, display, resolve))
}

/// The frame's host data: uniforms, lights, shadow views, instances, and the top level's
/// instances where rays are traced among moving objects.
fn frame_upload(frame: &FrameBuffers, scene_gpu: &SceneGpu, rays: Option<&RayPasses>) -> UploadPass {
    UploadPass::new(Uploads {
        uniforms: frame.uniforms.clone(),
        lights: frame.lights.clone(),
        shadow_views: frame.shadow_views.clone(),
        instances: scene_gpu.instances.clone(),
        top_instances: rays.filter(|r| r.build.is_some()).map(|r| r.scene.top.instances.clone()),
    })
}

/// The shadow maps of `views` views of `size`² texels, one layer each (copied to and from: the
/// static casters' cache goes into the maps, and tests read them back). Without shadowed
/// lights the lighting pass still binds a 1x1 placeholder map. Shared by both families at once
/// (`ImageDesc::concurrent`): drawn in part on graphics (the views whose inputs changed) and
/// read on compute (voxel light, deferred lighting), a map would otherwise come back to
/// graphics by a release recorded after all the compute work submitted since.
fn shadow_atlas(ctx: &Arc<Context>, size: u32, views: u32) -> GpuResult<Arc<Image>> {
    let name = if views > 0 { "shadow maps" } else { "shadow map placeholder" };
    Image::new(ctx, name, shadow_atlas_desc(size, views)).map(Arc::new)
}

/// The shadow maps' image ([`shadow_atlas`]; the static casters' cache is one like it).
fn shadow_atlas_desc(size: u32, views: u32) -> ImageDesc {
    let (size, layers) = if views > 0 { (size, views) } else { (1, 1) };
    let usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
        | vk::ImageUsageFlags::SAMPLED
        | vk::ImageUsageFlags::TRANSFER_SRC
        | vk::ImageUsageFlags::TRANSFER_DST;
    ImageDesc { concurrent: true, ..ImageDesc::d2_array(SHADOW_FORMAT, size, size, layers, usage) }
}

/// The indirect light the lighting pass composes: the traced cones (and rays), else the RSM
/// gather, else none.
fn gi_inputs<'a>(cones: Option<&'a ConePasses>, rsm: Option<&'a RsmPasses>) -> Option<GiInputs<'a>> {
    let cone_inputs = cones.map(|c| GiInputs { targets: c.output(), rt_specular: c.reflect.is_some() });
    cone_inputs.or(rsm.map(|r| GiInputs { targets: r.targets(), rt_specular: false }))
}

/// The per-pixel visibility of the first four lights that replaces their shadow maps in the
/// direct light: the shadow rays', else the shadow cones' (at full resolution), else none.
fn shadow_visibility<'a>(rt: Option<&'a RtShadowPass>, cones: Option<&'a ConePasses>) -> Option<&'a Arc<Image>> {
    rt.map(|r| &r.visibility).or_else(|| cones.and_then(|c| c.output().shadow.as_ref()))
}

/// `gi.specular = "rt"` or `gi.shadows = "rt"` on a device without ray queries: refused.
fn refuse_rays_without_queries(ctx: &Context, s: &RenderSettings) -> GpuResult<()> {
    if ctx.info.optional.ray_query {
        return Ok(());
    }
    if s.gi.specular == SpecularSource::Rt {
        return Err(missing_ray_queries(ctx, "gi.specular", "cone"));
    }
    if s.gi.shadows == DirectShadows::Rt {
        return Err(missing_ray_queries(ctx, "gi.shadows", "shadow-map"));
    }
    Ok(())
}
