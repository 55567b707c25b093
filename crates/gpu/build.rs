//! Compiles `shader-crate` to one SPIR-V module with rust-gpu; `src/lib.rs` embeds it.

use spirv_builder::{Capability, SpirvBuilder};
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let kernels = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shader-crate");
    let mut builder = SpirvBuilder::new(kernels, "spirv-unknown-vulkan1.2")
        .capability(Capability::Int64);
    builder.build_script.defaults = true;
    builder.build_script.env_shader_spv_path = Some(true);
    builder.build()?;
    Ok(())
}
