//! The scene on the GPU: one vertex and index buffer for all meshes, a material table,
//! textures, and a per-draw instance table (model and normal matrix, material) rewritten
//! each frame for moving objects.

use crate::gpu::sync::{barrier, Access};
use crate::gpu::{Bind, Buffer, Context, GpuResult, Image, ImageDesc, Sampler};
use crate::render::binding::Binds;
use crate::render::relief::ReliefPlan;
use crate::scene::{Material, Relief, Scene, Texture, TextureUse};
use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub uv: [f32; 2],
}

/// Mirrors `Material` in glsl/include/scene.glsl (std430).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub struct GpuMaterial {
    /// rgb albedo, a unused
    pub albedo: [f32; 4],
    /// rgb Ks, a shininess exponent
    pub specular: [f32; 4],
    /// rgb emitted radiance; a for a `HEIGHT_MAP_UNITS` map the material's scene units per
    /// unit of UV (render::relief), otherwise 1
    pub emission: [f32; 4],
    /// texture indices or -1: x albedo, y alpha mask, z normal or height map; w what z is
    /// (`NORMAL_MAP`, `HEIGHT_MAP` or `HEIGHT_MAP_UNITS`, 0 without)
    pub texture: [i32; 4],
}

/// Mirrors `Instance` in glsl/include/scene.glsl (std430).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub struct GpuInstance {
    pub model: [[f32; 4]; 4],
    pub normal: [[f32; 4]; 4],
    /// x material index
    pub material: [u32; 4],
}

/// One indexed draw: a mesh of an object.
#[derive(Debug, Clone, Copy)]
pub struct Draw {
    pub first_index: u32,
    pub index_count: u32,
    pub vertex_offset: i32,
    /// Index into the instance table (passed as firstInstance).
    pub instance: u32,
    pub object: usize,
    pub material: u32,
    /// The object is dynamic (re-voxelized when it moves).
    pub dynamic: bool,
    /// The object has motion: its transform changes with scene time.
    pub moving: bool,
    /// The material is alpha-masked (passes that only write depth need a fragment shader).
    pub masked: bool,
    /// The largest index (before `vertex_offset`) of the mesh.
    pub max_index: u32,
}

pub struct SceneGpu {
    pub vertices: Buffer,
    pub indices: Buffer,
    pub materials: MaterialTable,
    /// The sky's maps (black stand-ins without one).
    pub sky: crate::render::sky::SkyGpu,
    /// Device-local; written each frame by the upload pass.
    pub instances: Arc<Buffer>,
    pub draws: Vec<Draw>,
}

/// The material table and the albedo textures it indexes: all a shader needs to shade a
/// surface (the rasterizer's passes and the reference path tracer share it).
pub struct MaterialTable {
    /// `GpuMaterial` per scene material.
    pub buffer: Buffer,
    pub textures: Vec<Image>,
    /// Bound when the scene has no textures (descriptor arrays cannot be empty).
    pub placeholder_texture: Option<Image>,
    /// Trilinear and anisotropic: for implicit-derivative and gradient lookups.
    pub sampler: Sampler,
    /// Bilinear without anisotropy: for explicit-level lookups (the path tracer's level 0).
    /// lavapipe applies anisotropy to explicit-level lookups in compute shaders and blurs them.
    pub lod_sampler: Sampler,
}

impl MaterialTable {
    pub fn new(ctx: &Arc<Context>, scene: &Scene) -> GpuResult<MaterialTable> {
        let plan = ReliefPlan::of(scene);
        let materials: Vec<GpuMaterial> = scene
            .materials
            .iter()
            .zip(&plan.normal_maps)
            .map(|(m, &normal_map)| GpuMaterial {
                albedo: Vec4::from((m.albedo, 1.0)).to_array(),
                specular: Vec4::from((m.specular, m.shininess)).to_array(),
                emission: Vec4::from((m.emission, normal_map.map_or(1.0, |(_, factor)| factor))).to_array(),
                texture: texture_slots(scene, m, normal_map),
            })
            .collect();
        let buffer = upload_buffer(
            ctx,
            "scene materials",
            bytemuck::cast_slice(&materials),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let mut textures = Vec::new();
        for (i, up) in plan.uploads.iter().enumerate() {
            let t = &scene.textures[up.texture as usize];
            let name = if i < scene.textures.len() {
                format!("texture {i} ({})", t.path.display())
            } else {
                format!("texture {i} ({}, relief {})", t.path.display(), up.relief)
            };
            textures.push(upload_texture(ctx, &name, t, up.relief)?);
        }
        let placeholder_texture = if textures.is_empty() {
            let white = Texture {
                path: "placeholder".into(),
                width: 1,
                height: 1,
                rgba8: vec![255; 4],
                usage: TextureUse::Color,
            };
            Some(upload_texture(ctx, "placeholder texture", &white, 0.0)?)
        } else {
            None
        };
        // Trilinear with repeat; the sampler for implicit and gradient lookups is anisotropic
        // where the device has it, the explicit-level one never is.
        let base = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::REPEAT)
            .address_mode_v(vk::SamplerAddressMode::REPEAT)
            .address_mode_w(vk::SamplerAddressMode::REPEAT)
            .max_lod(vk::LOD_CLAMP_NONE);
        let anisotropy = max_anisotropy(ctx);
        let sampler =
            Sampler::new(ctx, "texture sampler", &base.anisotropy_enable(anisotropy > 1.0).max_anisotropy(anisotropy))?;
        let lod_sampler = Sampler::new(ctx, "texture sampler (explicit level)", &base)?;
        Ok(MaterialTable { buffer, textures, placeholder_texture, sampler, lod_sampler })
    }

    /// GPU memory of the scene's textures with their mip chains (the placeholder excluded).
    pub fn texture_bytes(&self) -> u64 {
        self.textures.iter().map(|t| t.bytes).sum()
    }

    /// Views for the texture descriptor array (never empty).
    pub fn texture_views(&self) -> Vec<vk::ImageView> {
        if let Some(p) = &self.placeholder_texture {
            vec![p.view]
        } else {
            self.textures.iter().map(|t| t.view).collect()
        }
    }

    /// Length of the texture descriptor array (the shaders' TEXTURE_COUNT).
    pub fn texture_count(&self) -> u32 {
        self.textures.len().max(1) as u32
    }

    /// Two bindings a shading shader declares in a row: the material table, then the textures
    /// (sampled images), both written at load time. It declares their sampler,
    /// [`Self::sampler`], as its last binding.
    pub fn binds(&self) -> Binds<'_> {
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        Binds::new().loaded(Bind::Storage(&self.buffer)).loaded(Bind::ImageArray(self.texture_views(), ro))
    }
}

/// `GpuMaterial::texture.w` for a tangent-space normal map (glsl/include/material.glsl).
pub const NORMAL_MAP: i32 = 1;
/// `GpuMaterial::texture.w` for a height map whose relief is in texture space
/// (`Relief::Tile`): uploaded as the normal map of that relief (render::relief).
pub const HEIGHT_MAP: i32 = 2;
/// `GpuMaterial::texture.w` for a height map whose relief is in scene units (`Relief::Units`):
/// uploaded for the material's mean scene units per unit of UV, `emission.a`, which the
/// shader divides by the surface's own.
pub const HEIGHT_MAP_UNITS: i32 = 3;

/// Texture slots of a material: albedo, mask, the normal or height map's upload (`normal_map`,
/// render::relief), and what that map is.
fn texture_slots(scene: &Scene, m: &Material, normal_map: Option<(u32, f32)>) -> [i32; 4] {
    let index = |t: Option<u32>| t.map(|t| t as i32).unwrap_or(-1);
    let kind = match (m.normal_texture.map(|t| scene.textures[t as usize].usage), m.relief) {
        (Some(TextureUse::Normal), _) => NORMAL_MAP,
        (Some(TextureUse::Height), Relief::Tile(_)) => HEIGHT_MAP,
        (Some(TextureUse::Height), Relief::Units(_)) => HEIGHT_MAP_UNITS,
        _ => 0,
    };
    [index(m.albedo_texture), index(m.mask_texture), index(normal_map.map(|(slot, _)| slot)), kind]
}

/// The anisotropy texture sampling uses: up to 16, as far as the device allows (1 = off,
/// without `samplerAnisotropy`).
pub fn max_anisotropy(ctx: &Context) -> f32 {
    if ctx.info.optional.sampler_anisotropy {
        ctx.info.limits.max_sampler_anisotropy.clamp(1.0, 16.0)
    } else {
        1.0
    }
}

/// Upload `data` into a new device-local buffer (load time only: waits for the copy).
pub fn upload_buffer(ctx: &Arc<Context>, name: &str, data: &[u8], usage: vk::BufferUsageFlags) -> GpuResult<Buffer> {
    let size = data.len().max(4) as u64;
    let staging = Buffer::new(
        ctx,
        &format!("{name} staging"),
        size,
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::CpuToGpu,
    )?;
    staging.write(0, data);
    let buffer = Buffer::new(ctx, name, size, usage | vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuOnly)?;
    ctx.one_shot(&format!("upload {name}"), |cmd| unsafe {
        if !data.is_empty() {
            ctx.device.cmd_copy_buffer(
                cmd,
                staging.raw,
                buffer.raw,
                &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size: data.len() as u64 }],
            );
        }
        // Make the copy visible to every later read of this immutable buffer.
        let b = vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .dst_access_mask(vk::AccessFlags2::MEMORY_READ);
        ctx.device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&[b]));
    })?;
    Ok(buffer)
}

/// Drops the mip levels larger than the device's maxImageDimension2D, so that a texture over
/// the limit is downscaled (by its own mip chain: colour filtered in linear light, masks keeping
/// their coverage) instead of refused, as engines do, with a warning naming it. Returns the
/// size of the level kept as level 0. A height map's gradient is per unit of UV, so its bumps
/// keep their strength.
fn fit_to_device(ctx: &Context, name: &str, levels: &mut Vec<super::texture::MipLevel>) -> (u32, u32) {
    let max = ctx.info.limits.max_image_dimension2_d;
    let fits = levels.iter().position(|l| l.width <= max && l.height <= max).unwrap_or(levels.len() - 1);
    if fits > 0 {
        let (w, h, w0, h0) = (levels[fits].width, levels[fits].height, levels[0].width, levels[0].height);
        eprintln!(
            "warning: {name} is {w0}x{h0}, over this device's maxImageDimension2D = {max}: downscaled to {w}x{h}"
        );
        levels.drain(..fits);
    }
    (levels[0].width, levels[0].height)
}

/// Upload an RGBA8 texture with its full mip chain (`render::texture`: colour filtered in linear
/// light, data maps as they are), left in SHADER_READ_ONLY_OPTIMAL for sampling anywhere.
/// A height map becomes the normal map of `relief` tiles per unit height (render::relief).
pub fn upload_texture(ctx: &Arc<Context>, name: &str, texture: &Texture, relief: f32) -> GpuResult<Image> {
    let usage = texture.usage;
    let mut levels = super::texture::mip_chain_for(usage, texture.width, texture.height, &texture.rgba8, relief);
    fit_to_device(ctx, name, &mut levels);
    // One format for every texture: lavapipe (Mesa 22.3, LLVM 15) crashes compiling the path
    // tracer when textures of two formats are bound to it. Data in red, green and blue is
    // stored sRGB-encoded, so the sampler's decode returns the data value (steps of at most
    // 0.9% of full scale, at the top of the range: normal maps store 1 - z, scene::maps). Masks
    // are read from alpha, which no sampler decodes, so they filter linearly at full 8-bit
    // precision. Height maps arrive here as heights and are uploaded as normal maps.
    if usage != TextureUse::Color {
        srgb_encode_data(&mut levels);
    }
    let levels: Vec<(u32, u32, Vec<u8>)> = levels.into_iter().map(|l| (l.width, l.height, l.rgba8)).collect();
    upload_levels(ctx, name, vk::Format::R8G8B8A8_SRGB, &levels)
}

/// sRGB-encodes red, green and blue of every level (alpha stays as it is), so that the sRGB
/// format's decode gives back a data texture's values.
fn srgb_encode_data(levels: &mut [super::texture::MipLevel]) {
    let code: [u8; 256] = std::array::from_fn(|c| super::texture::encode_srgb(c as f32 / 255.0));
    for level in levels {
        for p in level.rgba8.chunks_exact_mut(4) {
            p[..3].iter_mut().for_each(|c| *c = code[*c as usize]);
        }
    }
}

/// One buffer-to-image copy per mip level, the levels (width, height, bytes) packed one after
/// another in the staging buffer.
fn mip_copy_regions(image: &Image, levels: &[(u32, u32, usize)]) -> Vec<vk::BufferImageCopy> {
    let mut offset = 0u64;
    levels
        .iter()
        .enumerate()
        .map(|(i, &(width, height, bytes))| {
            let base = image.copy_region();
            let region = vk::BufferImageCopy {
                buffer_offset: offset,
                image_subresource: vk::ImageSubresourceLayers { mip_level: i as u32, ..base.image_subresource },
                image_extent: vk::Extent3D { width, height, depth: 1 },
                ..base
            };
            offset += bytes as u64;
            region
        })
        .collect()
}

/// A sampled 2D image of `format` whose mip levels are `levels` (width, height, texel bytes),
/// uploaded and ready for the shaders.
pub fn upload_levels(
    ctx: &Arc<Context>,
    name: &str,
    format: vk::Format,
    levels: &[(u32, u32, Vec<u8>)],
) -> GpuResult<Image> {
    let (width, height) = (levels[0].0, levels[0].1);
    let mut desc =
        ImageDesc::d2(format, width, height, vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST);
    desc.mip_levels = levels.len() as u32;
    let image = Image::new(ctx, name, desc)?;
    let bytes: Vec<u8> = levels.iter().flat_map(|l| l.2.iter().copied()).collect();
    let staging = Buffer::new(
        ctx,
        &format!("{name} staging"),
        bytes.len() as u64,
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::CpuToGpu,
    )?;
    staging.write(0, &bytes);
    let sizes: Vec<(u32, u32, usize)> = levels.iter().map(|l| (l.0, l.1, l.2.len())).collect();
    record_texture_upload(ctx, name, &image, &staging, &mip_copy_regions(&image, &sizes))?;
    Ok(image)
}

/// Records and runs the upload: to TRANSFER_DST, copy every level from `staging`, then to
/// shader-read for the fragment and compute shaders.
fn record_texture_upload(
    ctx: &Arc<Context>,
    name: &str,
    image: &Image,
    staging: &Buffer,
    regions: &[vk::BufferImageCopy],
) -> GpuResult<()> {
    let range = image.desc.full_range();
    ctx.one_shot(&format!("upload {name}"), |cmd| unsafe {
        let to_dst = barrier(&[Access::Nothing], &[Access::TransferWrite], true, true).unwrap();
        ctx.device.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().image_memory_barriers(&[to_dst.image(image.raw, range)]),
        );
        ctx.device.cmd_copy_buffer_to_image(
            cmd,
            staging.raw,
            image.raw,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            regions,
        );
        let to_read = barrier(
            &[Access::TransferWrite],
            &[Access::FragmentShaderReadSampled, Access::ComputeShaderReadSampled],
            true,
            false,
        )
        .unwrap();
        ctx.device.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().image_memory_barriers(&[to_read.image(image.raw, range)]),
        );
    })
}

fn mat_cols(m: Mat4) -> [[f32; 4]; 4] {
    m.to_cols_array_2d()
}

impl SceneGpu {
    pub fn new(ctx: &Arc<Context>, scene: &Scene) -> GpuResult<SceneGpu> {
        let mut vertices: Vec<Vertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut draws = Vec::new();
        for (oi, object) in scene.objects.iter().enumerate() {
            for &mi in &object.meshes {
                let mesh = &scene.meshes[mi as usize];
                if mesh.indices.is_empty() {
                    continue;
                }
                let base = vertices.len() as i32;
                for i in 0..mesh.positions.len() {
                    vertices.push(Vertex {
                        position: mesh.positions[i].to_array(),
                        normal: mesh.normals.get(i).copied().unwrap_or(glam::Vec3::Y).to_array(),
                        uv: mesh.uvs.get(i).copied().unwrap_or(glam::Vec2::ZERO).to_array(),
                    });
                }
                draws.push(Draw {
                    first_index: indices.len() as u32,
                    index_count: mesh.indices.len() as u32,
                    vertex_offset: base,
                    instance: draws.len() as u32,
                    object: oi,
                    material: mesh.material,
                    dynamic: object.dynamic,
                    moving: !object.motion.is_static(),
                    masked: scene.materials.get(mesh.material as usize).is_some_and(|m| m.mask_texture.is_some()),
                    max_index: mesh.indices.iter().copied().max().unwrap_or(0),
                });
                indices.extend_from_slice(&mesh.indices);
            }
        }
        // Where the device has ray queries, acceleration structures are built from them too.
        let geometry = vk::BufferUsageFlags::STORAGE_BUFFER
            | if ctx.info.optional.ray_query {
                vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
                    | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            } else {
                vk::BufferUsageFlags::empty()
            };
        let vertex_buffer = upload_buffer(
            ctx,
            "scene vertices",
            bytemuck::cast_slice(&vertices),
            vk::BufferUsageFlags::VERTEX_BUFFER | geometry,
        )?;
        let index_buffer = upload_buffer(
            ctx,
            "scene indices",
            bytemuck::cast_slice(&indices),
            vk::BufferUsageFlags::INDEX_BUFFER | geometry,
        )?;
        let instances = Arc::new(Buffer::new(
            ctx,
            "scene instances",
            (draws.len().max(1) * std::mem::size_of::<GpuInstance>()) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?);
        Ok(SceneGpu {
            vertices: vertex_buffer,
            indices: index_buffer,
            materials: MaterialTable::new(ctx, scene)?,
            sky: crate::render::sky::SkyGpu::new(ctx, scene.sky.as_ref())?,
            instances,
            draws,
        })
    }

    /// The instance table for time `t` (uploaded by the frame's upload pass).
    pub fn instance_bytes(&self, scene: &Scene, t: f32) -> Vec<u8> {
        let data: Vec<GpuInstance> = self
            .draws
            .iter()
            .map(|d| {
                let object = &scene.objects[d.object];
                let model = object.model_matrix(t);
                let normal = Mat4::from_mat3(glam::Mat3::from_mat4(model).inverse().transpose());
                GpuInstance { model: mat_cols(model), normal: mat_cols(normal), material: [d.material, 0, 0, 0] }
            })
            .collect();
        bytemuck::cast_slice(&data).to_vec()
    }

    /// Bind the vertex and index buffers and issue every draw.
    pub fn draw_all(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        self.draw_where(ctx, cmd, |_| true);
    }

    /// Bind the vertex and index buffers and issue the draws `keep` selects.
    pub fn draw_where(&self, ctx: &Context, cmd: vk::CommandBuffer, keep: impl Fn(&Draw) -> bool) {
        unsafe {
            ctx.device.cmd_bind_vertex_buffers(cmd, 0, &[self.vertices.raw], &[0]);
            ctx.device.cmd_bind_index_buffer(cmd, self.indices.raw, 0, vk::IndexType::UINT32);
            for d in self.draws.iter().filter(|d| keep(d)) {
                ctx.device.cmd_draw_indexed(cmd, d.index_count, 1, d.first_index, d.vertex_offset, d.instance);
            }
        }
    }
}
