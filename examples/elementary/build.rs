//! Compiles the shader crate (`shader/`) to SPIR-V for the GPU backend; `src/lib.rs` takes it
//! with `tileraster::fragment_stage!`, beside the same crate linked natively for the CPU.

fn main() -> Result<(), tileraster_build::BuildError> {
    tileraster_build::Shader::fragment("shader").build()
}
