//! Descriptor sets that know what they hold. Each binding names its resource and the access the
//! shaders make of it, once: the set writes the descriptor (the image layout comes from the
//! access table, `gpu::sync`) and keeps the resource, and a pass's barriers come from its sets
//! (`graph::Pass::sets`) plus the few uses no set can know (attachments, copies, indirect
//! arguments: `graph::Pass::unbound`). This module is what a pass declares; `graph` plans the
//! barriers from it.
//!
//! Data written once at load time and never by a frame (the voxel grid's uniform, the scene's
//! vertices, materials and textures) is bound with [`Binds::loaded`]: no barrier is ever
//! needed for it, and the name says so.

use crate::gpu::{Access, Bind, Buffer, Context, DescriptorSet, GpuResult, Image};
use ash::vk;
use ash::vk::Handle;
use std::sync::Arc;

/// A resource a pass touches.
#[derive(Clone, Copy)]
pub enum Res<'a> {
    Image(&'a Image),
    Buffer(&'a Buffer),
}

impl Res<'_> {
    pub(super) fn key(&self) -> u64 {
        match self {
            Res::Image(i) => i.raw.as_raw(),
            Res::Buffer(b) => b.raw.as_raw(),
        }
    }
    pub(super) fn name(&self) -> &str {
        match self {
            Res::Image(i) => &i.name,
            Res::Buffer(b) => &b.name,
        }
    }
}

/// One declared use of a resource by a pass.
#[derive(Clone, Copy)]
pub struct Use<'a> {
    pub res: Res<'a>,
    pub access: Access,
    /// The pass overwrites the whole resource: previous contents may be discarded.
    pub discard: bool,
}

impl<'a> Use<'a> {
    /// Access an image, keeping its contents.
    pub fn image(image: &'a Image, access: Access) -> Self {
        Use { res: Res::Image(image), access, discard: false }
    }
    /// Overwrite a whole image: its previous contents are discarded.
    pub fn overwrite(image: &'a Image, access: Access) -> Self {
        Use { res: Res::Image(image), access, discard: true }
    }
    pub fn buffer(buffer: &'a Buffer, access: Access) -> Self {
        Use { res: Res::Buffer(buffer), access, discard: false }
    }
}

/// A resource a set keeps, with the access its shaders make of it.
struct Held {
    res: Resource,
    access: Access,
    /// The pass overwrites the whole resource: its previous contents may be discarded.
    discard: bool,
}

#[derive(Clone)]
enum Resource {
    Image(Arc<Image>),
    Buffer(Arc<Buffer>),
}

impl Held {
    fn as_use(&self) -> Use<'_> {
        let u = match &self.res {
            Resource::Image(i) => Use::image(i, self.access),
            Resource::Buffer(b) => Use::buffer(b, self.access),
        };
        Use { discard: self.discard, ..u }
    }
    fn same(&self, other: &Held) -> bool {
        let same_res = match (&self.res, &other.res) {
            (Resource::Image(a), Resource::Image(b)) => Arc::ptr_eq(a, b),
            (Resource::Buffer(a), Resource::Buffer(b)) => Arc::ptr_eq(a, b),
            _ => false,
        };
        same_res && self.access == other.access && self.discard == other.discard
    }
}

/// The bindings of one descriptor set, in the shader's `binding = N` order, each with what
/// it holds and how the shaders touch it.
#[derive(Default)]
pub struct Binds<'a> {
    binds: Vec<Bind<'a>>,
    held: Vec<Held>,
    /// Where the resources of the last call that added bindings start in `held`.
    last: usize,
}

impl<'a> Binds<'a> {
    pub fn new() -> Binds<'a> {
        Binds::default()
    }

    /// Start a binding.
    fn push(&mut self, bind: Bind<'a>) {
        self.binds.push(bind);
        self.last = self.held.len();
    }

    fn hold(&mut self, res: Resource, access: Access) {
        let h = Held { res, access, discard: false };
        if !self.held.iter().any(|o| o.same(&h)) {
            self.held.push(h);
        }
    }

    /// A uniform buffer, read with `access`.
    pub fn uniform(mut self, buffer: &'a Arc<Buffer>, access: Access) -> Self {
        self.push(Bind::Uniform(buffer));
        self.hold(Resource::Buffer(buffer.clone()), access);
        self
    }

    /// A storage buffer, read or written with `access`.
    pub fn storage(mut self, buffer: &'a Arc<Buffer>, access: Access) -> Self {
        self.push(Bind::Storage(buffer));
        self.hold(Resource::Buffer(buffer.clone()), access);
        self
    }

    /// A combined image sampler, in the layout `access` needs.
    pub fn sampled(self, image: &'a Arc<Image>, sampler: vk::Sampler, access: Access) -> Self {
        self.sampled_array([image], sampler, access)
    }

    /// An array of combined image samplers (one sampler for all), in the layout `access` needs.
    pub fn sampled_array(
        mut self,
        images: impl IntoIterator<Item = &'a Arc<Image>>,
        sampler: vk::Sampler,
        access: Access,
    ) -> Self {
        let images: Vec<_> = images.into_iter().collect();
        let layout = access.info().layout;
        self.push(Bind::SampledArray(images.iter().map(|i| i.view).collect(), sampler, layout));
        for i in images {
            self.hold(Resource::Image(i.clone()), access);
        }
        self
    }

    /// An array of sampled images without a sampler, in the layout `access` needs.
    pub fn images(mut self, images: impl IntoIterator<Item = &'a Arc<Image>>, access: Access) -> Self {
        let images: Vec<_> = images.into_iter().collect();
        self.push(Bind::ImageArray(images.iter().map(|i| i.view).collect(), access.info().layout));
        for i in images {
            self.hold(Resource::Image(i.clone()), access);
        }
        self
    }

    /// A storage image (its whole view), read or written with `access`.
    pub fn storage_image(self, image: &'a Arc<Image>, access: Access) -> Self {
        self.storage_images([image], access)
    }

    /// An array of storage images (their whole views), read or written with `access`.
    pub fn storage_images(mut self, images: impl IntoIterator<Item = &'a Arc<Image>>, access: Access) -> Self {
        let images: Vec<_> = images.into_iter().collect();
        self.push(Bind::StorageImageArray(images.iter().map(|i| i.view).collect()));
        for i in images {
            self.hold(Resource::Image(i.clone()), access);
        }
        self
    }

    /// An array of storage image views, each a part (a mip level) of the image beside it.
    pub fn storage_views(
        mut self,
        views: impl IntoIterator<Item = (&'a Arc<Image>, vk::ImageView)>,
        access: Access,
    ) -> Self {
        let views: Vec<_> = views.into_iter().collect();
        self.push(Bind::StorageImageArray(views.iter().map(|(_, v)| *v).collect()));
        for (i, _) in views {
            self.hold(Resource::Image(i.clone()), access);
        }
        self
    }

    /// A sampler on its own (combined with images in the shader).
    pub fn sampler(mut self, sampler: vk::Sampler) -> Self {
        self.push(Bind::Sampler(sampler));
        self
    }

    /// A top-level acceleration structure, traced by ray queries: its backing `buffer` is what
    /// a rebuild writes.
    pub fn acceleration_structure(mut self, raw: vk::AccelerationStructureKHR, buffer: &Arc<Buffer>) -> Self {
        self.push(Bind::AccelerationStructure(raw));
        self.hold(Resource::Buffer(buffer.clone()), Access::ComputeShaderReadAccelerationStructure);
        self
    }

    /// Data written once at load time and never by a frame: bound without tracking.
    pub fn loaded(mut self, bind: Bind<'a>) -> Self {
        self.push(bind);
        self
    }

    /// A binding the pipeline never touches (a specialization constant switches its code off,
    /// the set's layout is shared with a pipeline that does): bound without tracking.
    pub fn idle(mut self, bind: Bind<'a>) -> Self {
        self.push(bind);
        self
    }

    /// The resources the last call added (a binding, or another list's bindings) are
    /// overwritten whole by the pass: their previous contents may be discarded.
    pub fn overwritten(mut self) -> Self {
        for h in &mut self.held[self.last..] {
            h.discard = true;
        }
        self
    }

    /// Every resource these bindings hold is overwritten whole by the pass.
    pub fn overwritten_all(mut self) -> Self {
        for h in &mut self.held {
            h.discard = true;
        }
        self
    }

    /// Another list's bindings after these.
    pub fn extend(mut self, other: Binds<'a>) -> Self {
        self.binds.extend(other.binds);
        self.last = self.held.len();
        for h in other.held {
            if !self.held.iter().any(|o| o.same(&h)) {
                self.held.push(h);
            }
        }
        self
    }

    /// Create the set.
    pub fn build(self, ctx: &Arc<Context>, name: &str, stages: vk::ShaderStageFlags) -> GpuResult<PassSet> {
        let set = DescriptorSet::new(ctx, name, stages, &self.binds)?;
        Ok(PassSet { set, held: self.held })
    }
}

/// A descriptor set and the resources it holds, with their accesses.
pub struct PassSet {
    set: DescriptorSet,
    held: Vec<Held>,
}

impl PassSet {
    pub fn layout(&self) -> vk::DescriptorSetLayout {
        self.set.layout
    }
    pub fn raw(&self) -> vk::DescriptorSet {
        self.set.set
    }
    /// What the set's shaders read and write, each resource with its access once.
    pub fn uses(&self) -> impl Iterator<Item = Use<'_>> {
        self.held.iter().map(Held::as_use)
    }
}
