//! Compiles `shader-crate` to SPIR-V with rust-gpu through `tileraster-build`, which marks every
//! float arithmetic result `NoContraction`, checks the module against the stage table and the
//! numeric contract, and writes it twice: as it is, and with the float controls declared on
//! every entry point. `src/lib.rs` embeds both; the GPU backend hands one to the driver
//! unchanged (a passthrough module: wgpu's own translation would drop the decorations), and
//! `tests/spirv.rs` checks the decorations, the execution modes and the stage table again.

fn main() -> Result<(), tileraster_build::BuildError> {
    tileraster_build::Shader::kernels("../../shader-crate").build()
}
