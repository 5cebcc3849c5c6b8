//! dvsgi: Deferred Voxel Shading — voxel cone traced global illumination over Vulkan.
//!
//! Layers, each with one error type: [`scene`] (files -> scene model, `SceneError`),
//! [`gpu`] (Vulkan context, memory, barriers, pipelines; `GpuError`), [`render`] (passes and
//! frames over `gpu`), [`output`] (image files; `OutputError`); [`Error`] joins them.

pub mod bench;
pub mod cli;
pub mod error;
pub mod gpu;
pub mod metrics;
pub mod model;
pub mod output;
pub mod pareto;
pub mod reference;
pub mod regions;
pub mod render;
pub mod scene;
pub mod soak;
pub mod sweep;
pub mod view;

pub use error::{Error, Result};
