//! Acceleration structures for ray queries (VK_KHR_acceleration_structure): bottom levels of
//! indexed triangles built once, and a top level of instances whose build a frame can record
//! again when the instances move. Each structure lives in a buffer of its own, which is what
//! passes declare their uses of (render::graph).

use super::context::Context;
use super::error::{GpuError, GpuResult, VkContext};
use super::memory::Buffer;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// An acceleration structure and the buffer that holds it.
pub struct AccelerationStructure {
    ctx: Arc<Context>,
    pub raw: vk::AccelerationStructureKHR,
    pub buffer: Arc<Buffer>,
    /// For instances that reference it.
    pub address: vk::DeviceAddress,
}

impl AccelerationStructure {
    fn new(ctx: &Arc<Context>, name: &str, ty: vk::AccelerationStructureTypeKHR, size: u64) -> GpuResult<Self> {
        let ext = functions(ctx)?;
        let usage =
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let buffer = Buffer::new(ctx, name, size, usage, MemoryLocation::GpuOnly)?;
        let info = vk::AccelerationStructureCreateInfoKHR::default().buffer(buffer.raw).size(size).ty(ty);
        let raw = unsafe { ext.create_acceleration_structure(&info, None) }.vk("vkCreateAccelerationStructureKHR")?;
        ctx.name_object(raw, name);
        let address = unsafe {
            ext.get_acceleration_structure_device_address(
                &vk::AccelerationStructureDeviceAddressInfoKHR::default().acceleration_structure(raw),
            )
        };
        Ok(AccelerationStructure { ctx: ctx.clone(), raw, buffer: Arc::new(buffer), address })
    }
}

impl Drop for AccelerationStructure {
    fn drop(&mut self) {
        if let Some(ext) = &self.ctx.acceleration_structure {
            unsafe { ext.destroy_acceleration_structure(self.raw, None) };
        }
    }
}

fn functions(ctx: &Context) -> GpuResult<&ash::khr::acceleration_structure::Device> {
    ctx.acceleration_structure.as_ref().ok_or_else(|| {
        GpuError::Limit(format!(
            "{} has no ray queries (VK_KHR_ray_query with VK_KHR_acceleration_structure)",
            ctx.info.name
        ))
    })
}

/// The device address of a buffer (created with SHADER_DEVICE_ADDRESS).
pub fn buffer_address(ctx: &Context, buffer: &Buffer) -> vk::DeviceAddress {
    unsafe { ctx.device.get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(buffer.raw)) }
}

/// One mesh of indexed triangles in shared vertex and index buffers.
#[derive(Debug, Clone, Copy)]
pub struct TriangleMesh {
    /// First index (into the index buffer of u32) and index count.
    pub first_index: u32,
    pub index_count: u32,
    /// Added to every index.
    pub vertex_offset: u32,
    /// Largest index (before the offset) any triangle uses.
    pub max_index: u32,
    /// Rays may skip the any-hit test: off where an alpha mask cuts the surface.
    pub opaque: bool,
}

/// Where the meshes' data is: positions are the first three floats of each vertex.
#[derive(Debug, Clone, Copy)]
pub struct TriangleSource {
    pub vertices: vk::DeviceAddress,
    pub vertex_stride: u64,
    pub indices: vk::DeviceAddress,
}

/// Builds a bottom-level structure per mesh, all in one command buffer (load time).
pub fn build_bottom_levels(
    ctx: &Arc<Context>,
    source: TriangleSource,
    meshes: &[TriangleMesh],
) -> GpuResult<Vec<AccelerationStructure>> {
    let ext = functions(ctx)?;
    let geometries: Vec<vk::AccelerationStructureGeometryKHR> = meshes.iter().map(|m| triangles(source, m)).collect();
    let flags = vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE;
    let mut structures = Vec::with_capacity(meshes.len());
    let mut scratch_offsets = Vec::with_capacity(meshes.len());
    let mut scratch_total = 0u64;
    let align = scratch_alignment(ctx);
    for (i, (m, g)) in meshes.iter().zip(&geometries).enumerate() {
        let info = build_info(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, flags, std::slice::from_ref(g));
        let sizes = build_sizes(ext, &info, m.index_count / 3);
        let name = format!("bottom-level structure {i}");
        structures.push(AccelerationStructure::new(
            ctx,
            &name,
            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            sizes.acceleration_structure_size,
        )?);
        scratch_offsets.push(scratch_total);
        scratch_total += sizes.build_scratch_size.next_multiple_of(align);
    }
    if meshes.is_empty() {
        return Ok(structures);
    }
    let scratch = Scratch::new(ctx, "bottom-level build scratch", scratch_total)?;
    let infos: Vec<_> = geometries
        .iter()
        .zip(&structures)
        .zip(&scratch_offsets)
        .map(|((g, s), &offset)| {
            build_info(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, flags, std::slice::from_ref(g))
                .dst_acceleration_structure(s.raw)
                .scratch_data(vk::DeviceOrHostAddressKHR { device_address: scratch.address + offset })
        })
        .collect();
    let ranges: Vec<[vk::AccelerationStructureBuildRangeInfoKHR; 1]> = meshes
        .iter()
        // The mesh's place in the shared buffers is in the geometry's addresses: with a primitive
        // offset and first vertex instead, Mesa 25.0's lavapipe hit only the first mesh.
        .map(|m| [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(m.index_count / 3)])
        .collect();
    let range_refs: Vec<&[vk::AccelerationStructureBuildRangeInfoKHR]> = ranges.iter().map(|r| &r[..]).collect();
    ctx.one_shot("build bottom-level structures", |cmd| unsafe {
        ext.cmd_build_acceleration_structures(cmd, &infos, &range_refs);
    })?;
    Ok(structures)
}

fn triangles(source: TriangleSource, m: &TriangleMesh) -> vk::AccelerationStructureGeometryKHR<'static> {
    let data = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
        .vertex_format(vk::Format::R32G32B32_SFLOAT)
        .vertex_data(vk::DeviceOrHostAddressConstKHR {
            device_address: source.vertices + u64::from(m.vertex_offset) * source.vertex_stride,
        })
        .vertex_stride(source.vertex_stride)
        .max_vertex(m.max_index)
        .index_type(vk::IndexType::UINT32)
        .index_data(vk::DeviceOrHostAddressConstKHR { device_address: source.indices + u64::from(m.first_index) * 4 });
    let flags = if m.opaque { vk::GeometryFlagsKHR::OPAQUE } else { vk::GeometryFlagsKHR::empty() };
    vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
        .geometry(vk::AccelerationStructureGeometryDataKHR { triangles: data })
        .flags(flags)
}

fn build_info<'a>(
    ty: vk::AccelerationStructureTypeKHR,
    flags: vk::BuildAccelerationStructureFlagsKHR,
    geometries: &'a [vk::AccelerationStructureGeometryKHR<'a>],
) -> vk::AccelerationStructureBuildGeometryInfoKHR<'a> {
    vk::AccelerationStructureBuildGeometryInfoKHR::default()
        .ty(ty)
        .flags(flags)
        .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
        .geometries(geometries)
}

fn build_sizes(
    ext: &ash::khr::acceleration_structure::Device,
    info: &vk::AccelerationStructureBuildGeometryInfoKHR,
    primitives: u32,
) -> vk::AccelerationStructureBuildSizesInfoKHR<'static> {
    let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
    unsafe {
        ext.get_acceleration_structure_build_sizes(
            vk::AccelerationStructureBuildTypeKHR::DEVICE,
            info,
            &[primitives],
            &mut sizes,
        )
    };
    sizes
}

fn scratch_alignment(ctx: &Context) -> u64 {
    let mut accel = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
    let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut accel);
    unsafe { ctx.instance.get_physical_device_properties2(ctx.physical_device, &mut p2) };
    u64::from(accel.min_acceleration_structure_scratch_offset_alignment.max(1))
}

/// Build scratch: a buffer with its device address rounded up to the device's alignment.
pub struct Scratch {
    pub buffer: Arc<Buffer>,
    pub address: vk::DeviceAddress,
}

impl Scratch {
    fn new(ctx: &Arc<Context>, name: &str, size: u64) -> GpuResult<Scratch> {
        let align = scratch_alignment(ctx);
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let buffer = Buffer::new(ctx, name, size + align, usage, MemoryLocation::GpuOnly)?;
        let address = buffer_address(ctx, &buffer).next_multiple_of(align);
        Ok(Scratch { buffer: Arc::new(buffer), address })
    }
}

/// A top level over instances that a device-local buffer holds (`capacity` at most), built by
/// [`TopLevel::record_build`] whenever a command buffer needs it current.
pub struct TopLevel {
    pub structure: AccelerationStructure,
    pub scratch: Scratch,
    /// `vk::AccelerationStructureInstanceKHR` records, written by the frame's upload.
    pub instances: Arc<Buffer>,
    pub count: u32,
}

impl TopLevel {
    pub fn new(ctx: &Arc<Context>, name: &str, count: u32) -> GpuResult<TopLevel> {
        let ext = functions(ctx)?;
        let usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
            | vk::BufferUsageFlags::TRANSFER_DST;
        let size = (count.max(1) as usize * std::mem::size_of::<vk::AccelerationStructureInstanceKHR>()) as u64;
        let instances = Arc::new(Buffer::new(ctx, &format!("{name} instances"), size, usage, MemoryLocation::GpuOnly)?);
        let geometry = instance_geometry(buffer_address(ctx, &instances));
        let info =
            build_info(vk::AccelerationStructureTypeKHR::TOP_LEVEL, top_flags(), std::slice::from_ref(&geometry));
        let sizes = build_sizes(ext, &info, count);
        let structure = AccelerationStructure::new(
            ctx,
            name,
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            sizes.acceleration_structure_size,
        )?;
        let scratch = Scratch::new(ctx, &format!("{name} build scratch"), sizes.build_scratch_size)?;
        Ok(TopLevel { structure, scratch, instances, count })
    }

    /// Builds the structure from the instance buffer's current contents.
    pub fn record_build(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let Some(ext) = &ctx.acceleration_structure else { return };
        let geometry = instance_geometry(buffer_address(ctx, &self.instances));
        let info =
            build_info(vk::AccelerationStructureTypeKHR::TOP_LEVEL, top_flags(), std::slice::from_ref(&geometry))
                .dst_acceleration_structure(self.structure.raw)
                .scratch_data(vk::DeviceOrHostAddressKHR { device_address: self.scratch.address });
        let range = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(self.count)];
        unsafe { ext.cmd_build_acceleration_structures(cmd, &[info], &[&range[..]]) };
    }
}

fn top_flags() -> vk::BuildAccelerationStructureFlagsKHR {
    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_BUILD
}

fn instance_geometry(address: vk::DeviceAddress) -> vk::AccelerationStructureGeometryKHR<'static> {
    let data = vk::AccelerationStructureGeometryInstancesDataKHR::default()
        .array_of_pointers(false)
        .data(vk::DeviceOrHostAddressConstKHR { device_address: address });
    vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::INSTANCES)
        .geometry(vk::AccelerationStructureGeometryDataKHR { instances: data })
}

/// One instance record: `model` (column-major 4x4) places bottom level `blas`; rays report
/// `custom_index` for its hits.
pub fn instance_record(
    model: [[f32; 4]; 4],
    custom_index: u32,
    blas: vk::DeviceAddress,
) -> vk::AccelerationStructureInstanceKHR {
    let m = model;
    // Row-major 3x4: row r is (m[0][r], m[1][r], m[2][r], m[3][r]).
    let matrix = std::array::from_fn(|i| m[i % 4][i / 4]);
    vk::AccelerationStructureInstanceKHR {
        transform: vk::TransformMatrixKHR { matrix },
        instance_custom_index_and_mask: vk::Packed24_8::new(custom_index, 0xff),
        instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
            0,
            vk::GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE.as_raw() as u8,
        ),
        acceleration_structure_reference: vk::AccelerationStructureReferenceKHR { device_handle: blas },
    }
}

/// The bytes of instance records, for an upload.
pub fn instance_bytes(records: &[vk::AccelerationStructureInstanceKHR]) -> Vec<u8> {
    // SAFETY: the record is a plain #[repr(C)] struct of integers and floats, 64 bytes with no padding.
    let bytes = unsafe { std::slice::from_raw_parts(records.as_ptr().cast::<u8>(), std::mem::size_of_val(records)) };
    bytes.to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instance_records_hold_the_model_matrix_row_major() {
        let model = glam::Mat4::from_translation(glam::Vec3::new(1.0, 2.0, 3.0))
            * glam::Mat4::from_scale(glam::Vec3::splat(2.0));
        let r = instance_record(model.to_cols_array_2d(), 7, 0x1000);
        assert_eq!(r.transform.matrix, [2.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 2.0, 0.0, 0.0, 2.0, 3.0]);
        assert_eq!(r.instance_custom_index_and_mask.low_24(), 7);
        assert_eq!(r.instance_custom_index_and_mask.high_8(), 0xff);
        assert_eq!(instance_bytes(&[r]).len(), 64);
    }
}
