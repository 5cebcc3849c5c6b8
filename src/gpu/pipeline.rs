//! Descriptor sets and pipelines (compute and dynamic-rendering graphics), with RAII.

use super::context::Context;
use super::error::{GpuResult, VkContext};
use super::memory::Buffer;
use ash::vk;
use std::sync::Arc;

/// One binding of a descriptor set; the binding number is its position in the list.
pub enum Bind<'a> {
    Uniform(&'a Buffer),
    Storage(&'a Buffer),
    /// Combined image sampler.
    Sampled(vk::ImageView, vk::Sampler, vk::ImageLayout),
    /// Array of combined image samplers.
    SampledArray(Vec<vk::ImageView>, vk::Sampler, vk::ImageLayout),
    StorageImage(vk::ImageView),
    /// Array of storage images (GENERAL layout).
    StorageImageArray(Vec<vk::ImageView>),
    /// Array of sampled images without samplers (scene textures: they count against
    /// maxPerStageDescriptorSampledImages, not the far smaller sampler limit, 32 on lavapipe).
    ImageArray(Vec<vk::ImageView>, vk::ImageLayout),
    /// A sampler on its own, combined with images in the shader.
    Sampler(vk::Sampler),
    /// A top-level acceleration structure for ray queries.
    AccelerationStructure(vk::AccelerationStructureKHR),
}

impl Bind<'_> {
    fn ty(&self) -> vk::DescriptorType {
        match self {
            Bind::Uniform(_) => vk::DescriptorType::UNIFORM_BUFFER,
            Bind::Storage(_) => vk::DescriptorType::STORAGE_BUFFER,
            Bind::Sampled(..) | Bind::SampledArray(..) => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            Bind::StorageImage(_) | Bind::StorageImageArray(_) => vk::DescriptorType::STORAGE_IMAGE,
            Bind::ImageArray(..) => vk::DescriptorType::SAMPLED_IMAGE,
            Bind::Sampler(_) => vk::DescriptorType::SAMPLER,
            Bind::AccelerationStructure(_) => vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
        }
    }
    fn count(&self) -> u32 {
        match self {
            Bind::SampledArray(v, ..) => v.len() as u32,
            Bind::StorageImageArray(v) | Bind::ImageArray(v, _) => v.len() as u32,
            _ => 1,
        }
    }
}

/// A descriptor set with its own layout and pool, written once at creation.
pub struct DescriptorSet {
    ctx: Arc<Context>,
    pub layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    pub set: vk::DescriptorSet,
}

impl DescriptorSet {
    pub fn new(ctx: &Arc<Context>, name: &str, stages: vk::ShaderStageFlags, binds: &[Bind]) -> GpuResult<Self> {
        let d = &ctx.device;
        let bindings: Vec<_> = binds
            .iter()
            .enumerate()
            .map(|(i, b)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(b.ty())
                    .descriptor_count(b.count())
                    .stage_flags(stages)
            })
            .collect();
        let layout = unsafe {
            d.create_descriptor_set_layout(&vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings), None)
        }
        .vk("vkCreateDescriptorSetLayout")?;
        ctx.name_object(layout, &format!("{name} layout"));
        let mut me = DescriptorSet {
            ctx: ctx.clone(),
            layout,
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
        };
        let sizes = pool_sizes(binds);
        me.pool = unsafe {
            d.create_descriptor_pool(&vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes), None)
        }
        .vk("vkCreateDescriptorPool")?;
        ctx.name_object(me.pool, &format!("{name} pool"));
        let layouts = [layout];
        me.set = unsafe {
            d.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default().descriptor_pool(me.pool).set_layouts(&layouts),
            )
        }
        .vk("vkAllocateDescriptorSets")?[0];
        ctx.name_object(me.set, name);
        me.write_resources(binds);
        me.write_acceleration_structures(binds);
        Ok(me)
    }

    /// Buffer and image descriptors, one write per binding.
    fn write_resources(&self, binds: &[Bind]) {
        // Keep the info arrays alive until the update call.
        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = binds
            .iter()
            .filter_map(|b| match b {
                Bind::Uniform(buf) | Bind::Storage(buf) => {
                    Some([vk::DescriptorBufferInfo { buffer: buf.raw, offset: 0, range: vk::WHOLE_SIZE }])
                }
                _ => None,
            })
            .collect();
        let image_infos: Vec<Vec<vk::DescriptorImageInfo>> = binds.iter().filter_map(image_infos).collect();
        let (mut bi, mut ii) = (0, 0);
        let writes: Vec<_> = binds
            .iter()
            .enumerate()
            .filter_map(|(i, b)| {
                let w =
                    vk::WriteDescriptorSet::default().dst_set(self.set).dst_binding(i as u32).descriptor_type(b.ty());
                match b {
                    Bind::Uniform(_) | Bind::Storage(_) => {
                        bi += 1;
                        Some(w.buffer_info(&buffer_infos[bi - 1]))
                    }
                    Bind::AccelerationStructure(_) => None,
                    _ => {
                        ii += 1;
                        Some(w.image_info(&image_infos[ii - 1]))
                    }
                }
            })
            .collect();
        unsafe { self.ctx.device.update_descriptor_sets(&writes, &[]) };
    }

    /// Acceleration-structure descriptors (their write chains a structure of its own).
    fn write_acceleration_structures(&self, binds: &[Bind]) {
        for (i, b) in binds.iter().enumerate() {
            if let Bind::AccelerationStructure(raw) = b {
                let structures = [*raw];
                let mut info =
                    vk::WriteDescriptorSetAccelerationStructureKHR::default().acceleration_structures(&structures);
                let write = vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(i as u32)
                    .descriptor_type(b.ty())
                    .descriptor_count(1)
                    .push_next(&mut info);
                unsafe { self.ctx.device.update_descriptor_sets(&[write], &[]) };
            }
        }
    }
}

/// One pool size per descriptor type the bindings use (at least one entry).
fn pool_sizes(binds: &[Bind]) -> Vec<vk::DescriptorPoolSize> {
    let mut sizes: Vec<vk::DescriptorPoolSize> = Vec::new();
    for b in binds {
        match sizes.iter_mut().find(|s| s.ty == b.ty()) {
            Some(s) => s.descriptor_count += b.count(),
            None => sizes.push(vk::DescriptorPoolSize { ty: b.ty(), descriptor_count: b.count() }),
        }
    }
    if sizes.is_empty() {
        sizes.push(vk::DescriptorPoolSize { ty: vk::DescriptorType::UNIFORM_BUFFER, descriptor_count: 1 });
    }
    sizes
}

/// The image infos of an image, image-array or sampler binding (None for the others).
fn image_infos(b: &Bind) -> Option<Vec<vk::DescriptorImageInfo>> {
    let info = |sampler, image_view, image_layout| vk::DescriptorImageInfo { sampler, image_view, image_layout };
    let none = vk::Sampler::null();
    let general = vk::ImageLayout::GENERAL;
    Some(match b {
        Bind::Sampled(view, sampler, layout) => vec![info(*sampler, *view, *layout)],
        Bind::SampledArray(views, sampler, layout) => views.iter().map(|v| info(*sampler, *v, *layout)).collect(),
        Bind::ImageArray(views, layout) => views.iter().map(|v| info(none, *v, *layout)).collect(),
        Bind::Sampler(sampler) => vec![info(*sampler, vk::ImageView::null(), vk::ImageLayout::UNDEFINED)],
        Bind::StorageImage(view) => vec![info(none, *view, general)],
        Bind::StorageImageArray(views) => views.iter().map(|v| info(none, *v, general)).collect(),
        Bind::Uniform(_) | Bind::Storage(_) | Bind::AccelerationStructure(_) => return None,
    })
}

impl Drop for DescriptorSet {
    fn drop(&mut self) {
        if self.ctx.has_failed() {
            return; // the GPU may still use it (Context::has_failed)
        }
        unsafe {
            self.ctx.device.destroy_descriptor_pool(self.pool, None);
            self.ctx.device.destroy_descriptor_set_layout(self.layout, None);
        }
    }
}

pub struct Pipeline {
    ctx: Arc<Context>,
    pub raw: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub bind_point: vk::PipelineBindPoint,
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        if self.ctx.has_failed() {
            return; // the GPU may still use it (Context::has_failed)
        }
        unsafe {
            self.ctx.device.destroy_pipeline(self.raw, None);
            self.ctx.device.destroy_pipeline_layout(self.layout, None);
        }
    }
}

fn shader_module(ctx: &Context, name: &str, spirv: &[u8]) -> GpuResult<vk::ShaderModule> {
    let words = ash::util::read_spv(&mut std::io::Cursor::new(spirv)).expect("build.rs produced valid SPIR-V");
    let m = unsafe { ctx.device.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None) }
        .vk("vkCreateShaderModule")?;
    ctx.name_object(m, name);
    Ok(m)
}

fn pipeline_layout(
    ctx: &Context,
    name: &str,
    set_layouts: &[vk::DescriptorSetLayout],
    push_size: u32,
) -> GpuResult<vk::PipelineLayout> {
    let ranges = [vk::PushConstantRange { stage_flags: vk::ShaderStageFlags::ALL, offset: 0, size: push_size }];
    let mut info = vk::PipelineLayoutCreateInfo::default().set_layouts(set_layouts);
    if push_size > 0 {
        info = info.push_constant_ranges(&ranges);
    }
    let l = unsafe { ctx.device.create_pipeline_layout(&info, None) }.vk("vkCreatePipelineLayout")?;
    ctx.name_object(l, &format!("{name} layout"));
    Ok(l)
}

/// Specialization constants: (constant_id, u32 value).
struct Spec {
    entries: Vec<vk::SpecializationMapEntry>,
    data: Vec<u8>,
}

impl Spec {
    fn new(constants: &[(u32, u32)]) -> Spec {
        let mut entries = Vec::new();
        let mut data = Vec::new();
        for (id, v) in constants {
            entries.push(vk::SpecializationMapEntry { constant_id: *id, offset: data.len() as u32, size: 4 });
            data.extend_from_slice(&v.to_ne_bytes());
        }
        Spec { entries, data }
    }
    fn info(&self) -> vk::SpecializationInfo<'_> {
        vk::SpecializationInfo::default().map_entries(&self.entries).data(&self.data)
    }
}

/// A shader module per stage of `desc`: vertex, then geometry and fragment when present.
fn graphics_modules(
    ctx: &Context,
    name: &str,
    desc: &GraphicsDesc,
) -> GpuResult<Vec<(vk::ShaderStageFlags, vk::ShaderModule)>> {
    let mut modules = vec![(vk::ShaderStageFlags::VERTEX, shader_module(ctx, name, desc.vert)?)];
    if let Some(g) = desc.geom {
        modules.push((vk::ShaderStageFlags::GEOMETRY, shader_module(ctx, name, g)?));
    }
    if let Some(f) = desc.frag {
        modules.push((vk::ShaderStageFlags::FRAGMENT, shader_module(ctx, name, f)?));
    }
    Ok(modules)
}

/// Destroy the shader modules (once the pipeline is created, or creating it failed).
fn destroy_modules(ctx: &Context, modules: &[(vk::ShaderStageFlags, vk::ShaderModule)]) {
    for (_, m) in modules {
        unsafe { ctx.device.destroy_shader_module(*m, None) };
    }
}

/// The pipeline layout; if creating it fails, the modules are destroyed before the error returns.
fn layout_or_destroy_modules(
    ctx: &Context,
    name: &str,
    set_layouts: &[vk::DescriptorSetLayout],
    push_size: u32,
    modules: &[(vk::ShaderStageFlags, vk::ShaderModule)],
) -> GpuResult<vk::PipelineLayout> {
    pipeline_layout(ctx, name, set_layouts, push_size).inspect_err(|_| destroy_modules(ctx, modules))
}

/// The stage info of `module` (entry point `main`, with the specialization constants).
fn shader_stage<'a>(
    stage: vk::ShaderStageFlags,
    module: vk::ShaderModule,
    spec_info: &'a vk::SpecializationInfo<'a>,
) -> vk::PipelineShaderStageCreateInfo<'a> {
    vk::PipelineShaderStageCreateInfo::default()
        .stage(stage)
        .module(module)
        .name(c"main")
        .specialization_info(spec_info)
}

/// Fill the graphics pipeline's state from `desc` and create it (one `vkCreateGraphicsPipelines`).
fn create_graphics_pipeline(
    ctx: &Context,
    desc: &GraphicsDesc,
    modules: &[(vk::ShaderStageFlags, vk::ShaderModule)],
    layout: vk::PipelineLayout,
) -> Result<Vec<vk::Pipeline>, (Vec<vk::Pipeline>, vk::Result)> {
    let spec = Spec::new(desc.spec);
    let spec_info = spec.info();
    let stages: Vec<_> = modules.iter().map(|(s, m)| shader_stage(*s, *m, &spec_info)).collect();
    let vertex = VertexInput::of(desc.vertex_attributes);
    let vertex_input = vertex.info();
    let input_assembly =
        vk::PipelineInputAssemblyStateCreateInfo::default().topology(vk::PrimitiveTopology::TRIANGLE_LIST);
    let viewport = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
    let mut conservative = conservative_overestimate();
    let raster = rasterization_state(ctx, desc, &mut conservative);
    let multisample =
        vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(vk::SampleCountFlags::TYPE_1);
    let depth = depth_stencil_state(desc);
    let blend_attachments = opaque_blend_attachments(desc.color_formats);
    let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
    let dynamic_states = dynamic_states(desc);
    let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
    let mut rendering = vk::PipelineRenderingCreateInfo::default()
        .color_attachment_formats(desc.color_formats)
        .depth_attachment_format(desc.depth_format.unwrap_or(vk::Format::UNDEFINED));
    let info = vk::GraphicsPipelineCreateInfo::default()
        .stages(&stages)
        .vertex_input_state(&vertex_input)
        .input_assembly_state(&input_assembly)
        .viewport_state(&viewport)
        .rasterization_state(&raster)
        .multisample_state(&multisample)
        .depth_stencil_state(&depth)
        .color_blend_state(&blend)
        .dynamic_state(&dynamic)
        .layout(layout)
        .push_next(&mut rendering);
    unsafe { ctx.device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) }
}

/// The vertex buffer layout (one binding of interleaved `scene_gpu::Vertex`) and the attributes
/// the vertex shader reads, owned until the create call.
struct VertexInput {
    bindings: [vk::VertexInputBindingDescription; 1],
    attributes: Vec<vk::VertexInputAttributeDescription>,
}

impl VertexInput {
    /// Binding 0 with the attributes at `locations` (0 position, 1 normal, 2 uv).
    fn of(locations: &[u32]) -> VertexInput {
        let bindings = [vk::VertexInputBindingDescription {
            binding: 0,
            stride: std::mem::size_of::<crate::render::scene_gpu::Vertex>() as u32,
            input_rate: vk::VertexInputRate::VERTEX,
        }];
        let attribute =
            |location, format, offset| vk::VertexInputAttributeDescription { location, binding: 0, format, offset };
        let all = [
            attribute(0, vk::Format::R32G32B32_SFLOAT, 0),
            attribute(1, vk::Format::R32G32B32_SFLOAT, 12),
            attribute(2, vk::Format::R32G32_SFLOAT, 24),
        ];
        let attributes = all.into_iter().filter(|a| locations.contains(&a.location)).collect();
        VertexInput { bindings, attributes }
    }
    fn info(&self) -> vk::PipelineVertexInputStateCreateInfo<'_> {
        vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&self.bindings)
            .vertex_attribute_descriptions(&self.attributes)
    }
}

/// Overestimating conservative rasterization, chained to the rasterization state when asked for.
fn conservative_overestimate() -> vk::PipelineRasterizationConservativeStateCreateInfoEXT<'static> {
    vk::PipelineRasterizationConservativeStateCreateInfoEXT::default()
        .conservative_rasterization_mode(vk::ConservativeRasterizationModeEXT::OVERESTIMATE)
        .extra_primitive_overestimation_size(0.0)
}

/// Filled triangles, counter-clockwise front faces; culling, depth bias and depth clamp from
/// `desc` (clamp only where the device has it); `conservative` chained when asked for and supported.
fn rasterization_state<'a>(
    ctx: &Context,
    desc: &GraphicsDesc,
    conservative: &'a mut vk::PipelineRasterizationConservativeStateCreateInfoEXT<'static>,
) -> vk::PipelineRasterizationStateCreateInfo<'a> {
    let raster = vk::PipelineRasterizationStateCreateInfo::default()
        .polygon_mode(vk::PolygonMode::FILL)
        .cull_mode(desc.cull)
        .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
        .depth_bias_enable(desc.depth_bias)
        .depth_clamp_enable(desc.depth_clamp && ctx.info.optional.depth_clamp)
        .line_width(1.0);
    if desc.conservative && ctx.info.optional.conservative_rasterization {
        raster.push_next(conservative)
    } else {
        raster
    }
}

/// Depth test and write as `desc` asks (never without a depth attachment), LESS_OR_EQUAL.
fn depth_stencil_state(desc: &GraphicsDesc) -> vk::PipelineDepthStencilStateCreateInfo<'static> {
    vk::PipelineDepthStencilStateCreateInfo::default()
        .depth_test_enable(desc.depth_format.is_some() && desc.depth_test)
        .depth_write_enable(desc.depth_format.is_some() && desc.depth_write)
        .depth_compare_op(vk::CompareOp::LESS_OR_EQUAL)
}

/// One blend state per color attachment: blending off, all channels written.
fn opaque_blend_attachments(color_formats: &[vk::Format]) -> Vec<vk::PipelineColorBlendAttachmentState> {
    color_formats
        .iter()
        .map(|_| {
            vk::PipelineColorBlendAttachmentState::default()
                .blend_enable(false)
                .color_write_mask(vk::ColorComponentFlags::RGBA)
        })
        .collect()
}

/// Viewport and scissor are always dynamic; depth bias too when `desc` uses it.
fn dynamic_states(desc: &GraphicsDesc) -> Vec<vk::DynamicState> {
    let mut states = vec![vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
    if desc.depth_bias {
        states.push(vk::DynamicState::DEPTH_BIAS);
    }
    states
}

impl Pipeline {
    pub fn compute(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u8],
        set_layouts: &[vk::DescriptorSetLayout],
        push_size: u32,
        spec: &[(u32, u32)],
    ) -> GpuResult<Pipeline> {
        let modules = [(vk::ShaderStageFlags::COMPUTE, shader_module(ctx, name, spirv)?)];
        let layout = layout_or_destroy_modules(ctx, name, set_layouts, push_size, &modules)?;
        let spec = Spec::new(spec);
        let spec_info = spec.info();
        let stage = shader_stage(modules[0].0, modules[0].1, &spec_info);
        let info = vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout);
        let result = unsafe { ctx.device.create_compute_pipelines(vk::PipelineCache::null(), &[info], None) };
        destroy_modules(ctx, &modules);
        Pipeline::from_result(ctx, name, result, layout, vk::PipelineBindPoint::COMPUTE, "vkCreateComputePipelines")
    }

    pub fn graphics(
        ctx: &Arc<Context>,
        name: &str,
        desc: &GraphicsDesc,
        set_layouts: &[vk::DescriptorSetLayout],
        push_size: u32,
    ) -> GpuResult<Pipeline> {
        let modules = graphics_modules(ctx, name, desc)?;
        let layout = layout_or_destroy_modules(ctx, name, set_layouts, push_size, &modules)?;
        let result = create_graphics_pipeline(ctx, desc, &modules, layout);
        destroy_modules(ctx, &modules);
        Pipeline::from_result(ctx, name, result, layout, vk::PipelineBindPoint::GRAPHICS, "vkCreateGraphicsPipelines")
    }

    /// The pipeline from the result of `call` (a `vkCreate*Pipelines`), named; on failure the
    /// layout is destroyed.
    fn from_result(
        ctx: &Arc<Context>,
        name: &str,
        result: Result<Vec<vk::Pipeline>, (Vec<vk::Pipeline>, vk::Result)>,
        layout: vk::PipelineLayout,
        bind_point: vk::PipelineBindPoint,
        call: &'static str,
    ) -> GpuResult<Pipeline> {
        let raw = match result {
            Ok(p) => p[0],
            Err((_, e)) => {
                unsafe { ctx.device.destroy_pipeline_layout(layout, None) };
                return Err(crate::gpu::GpuError::Vk { call, result: e });
            }
        };
        ctx.name_object(raw, name);
        Ok(Pipeline { ctx: ctx.clone(), raw, layout, bind_point })
    }

    pub fn bind(&self, cmd: vk::CommandBuffer, sets: &[vk::DescriptorSet]) {
        unsafe {
            self.ctx.device.cmd_bind_pipeline(cmd, self.bind_point, self.raw);
            if !sets.is_empty() {
                self.ctx.device.cmd_bind_descriptor_sets(cmd, self.bind_point, self.layout, 0, sets, &[]);
            }
        }
    }

    /// One invocation per pixel of `image` in 8x8 groups: the per-pixel compute passes.
    pub fn dispatch_pixels(&self, cmd: vk::CommandBuffer, image: &crate::gpu::Image) {
        let e = image.extent2d();
        self.dispatch(cmd, [e.width, e.height, 1], [8, 8, 1]);
    }

    /// Dispatch enough workgroups of `local_size` (the shader's local_size_x/y/z) to cover
    /// `items` invocations in each dimension, rounding up.
    pub fn dispatch(&self, cmd: vk::CommandBuffer, items: [u32; 3], local_size: [u32; 3]) {
        let g = |i: usize| group_count(items[i], local_size[i]);
        unsafe { self.ctx.device.cmd_dispatch(cmd, g(0), g(1), g(2)) };
    }

    /// Dispatch with the group counts at `offset` in `args` (a `VkDispatchIndirectCommand`).
    pub fn dispatch_indirect(&self, cmd: vk::CommandBuffer, args: &Buffer, offset: u64) {
        unsafe { self.ctx.device.cmd_dispatch_indirect(cmd, args.raw, offset) };
    }

    pub fn push<T: bytemuck::Pod>(&self, cmd: vk::CommandBuffer, data: &T) {
        unsafe {
            self.ctx.device.cmd_push_constants(cmd, self.layout, vk::ShaderStageFlags::ALL, 0, bytemuck::bytes_of(data))
        };
    }
}

pub struct GraphicsDesc<'a> {
    /// Locations of the vertex attributes the vertex shader reads: 0 position, 1 normal, 2 uv.
    pub vertex_attributes: &'a [u32],
    pub vert: &'a [u8],
    pub geom: Option<&'a [u8]>,
    pub frag: Option<&'a [u8]>,
    pub color_formats: &'a [vk::Format],
    pub depth_format: Option<vk::Format>,
    pub depth_test: bool,
    pub depth_write: bool,
    pub cull: vk::CullModeFlags,
    /// Depth bias set dynamically with `vkCmdSetDepthBias`.
    pub depth_bias: bool,
    /// Clamp depth instead of clipping (shadow casters behind a directional light's near plane).
    pub depth_clamp: bool,
    /// Overestimating conservative rasterization (VK_EXT_conservative_rasterization; only
    /// when the device has it).
    pub conservative: bool,
    pub spec: &'a [(u32, u32)],
}

/// Workgroup count covering `n` items with groups of `group` (never zero for n > 0:
/// rounds up, unlike the seed's integer-division bug).
pub fn group_count(n: u32, group: u32) -> u32 {
    n.div_ceil(group)
}

#[cfg(test)]
mod tests {
    #[test]
    fn group_count_rounds_up() {
        assert_eq!(super::group_count(1, 8), 1);
        assert_eq!(super::group_count(8, 8), 1);
        assert_eq!(super::group_count(9, 8), 2);
        assert_eq!(super::group_count(4, 8), 1);
    }
}
