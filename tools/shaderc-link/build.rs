//! Debian's `libshaderc_combined.a` (package libshaderc-dev) contains shaderc only, not the
//! glslang and SPIRV-Tools code it calls, and Debian's `libshaderc.so.1` cannot be linked
//! either. Link the static glslang (glslang-dev) and SPIRV-Tools (spirv-tools) archives and
//! libstdc++ explicitly. Anything that depends on this crate gets these link lines.
fn main() {
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    let dir = std::env::var("SHADERC_LIB_DIR").unwrap_or_else(|_| "/usr/lib/x86_64-linux-gnu".into());
    for lib in ["libglslang.a", "libSPIRV-Tools.a", "libshaderc_combined.a"] {
        if !std::path::Path::new(&dir).join(lib).exists() {
            println!(
                "cargo:warning={dir}/{lib} is missing: install libshaderc-dev glslang-dev spirv-tools \
                 (see README, 'Set-up') or set SHADERC_LIB_DIR"
            );
        }
    }
    println!("cargo:rustc-link-search=native={dir}");
    for lib in [
        "glslang",
        "MachineIndependent",
        "GenericCodeGen",
        "OSDependent",
        "OGLCompiler",
        "HLSL",
        "SPIRV",
        "glslang-default-resource-limits",
        "SPIRV-Tools-opt",
        "SPIRV-Tools",
    ] {
        println!("cargo:rustc-link-lib=static={lib}");
    }
    println!("cargo:rustc-link-lib=dylib=stdc++");
}
