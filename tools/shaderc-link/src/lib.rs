//! Re-exports `shaderc`; depending on this crate (and naming it with `extern crate`) adds the
//! static glslang/SPIRV-Tools link lines that Debian's shaderc package needs. See build.rs.
pub use shaderc;
