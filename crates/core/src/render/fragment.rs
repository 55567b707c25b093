//! A frame's programmable fragment stage (`RenderParams::fragment`): a user's fragment shader
//! (`tileraster_kernels::programs::fragment`), compiled natively for the CPU backend and to
//! SPIR-V for the GPU backend.

use tileraster_kernels::abi::FRAGMENT_CONSTANTS;
use tileraster_kernels::programs::fragment::FragmentProgram;

/// A fragment shader compiled for both backends. Made by [`fragment_stage!`](crate::fragment_stage)
/// from a shader crate that `tileraster-build` compiled in the build script.
#[derive(Clone, Copy)]
pub struct FragmentStage {
    /// The shader's name, for messages.
    pub name: &'static str,
    /// The shader itself, called natively by the CPU backend.
    pub program: &'static (dyn FragmentProgram + Sync),
    /// The same shader's module: the shading stages' entry points around it
    /// (`fragment_shader!`), as `tileraster-build` wrote it.
    pub spirv: &'static [u8],
    /// [`Self::spirv`] with the float controls declared (for adapters that report them).
    pub spirv_float_controls: &'static [u8],
}

/// Values a frame hands its fragment shader (`ShadeParams::constants`).
pub type FragmentConstants = [f32; FRAGMENT_CONSTANTS];

impl FragmentStage {
    /// The module for an adapter with (`true`) or without the float controls declared.
    pub fn module(&self, float_controls: bool) -> &'static [u8] {
        if float_controls { self.spirv_float_controls } else { self.spirv }
    }
}

impl std::fmt::Debug for FragmentStage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FragmentStage").field("name", &self.name).field("spirv_bytes", &self.spirv.len()).finish()
    }
}

/// Two stages are the same when they are the same shader and the same module.
impl PartialEq for FragmentStage {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::addr_eq(self.program, other.program) && self.spirv.as_ptr() == other.spirv.as_ptr() && self.spirv.len() == other.spirv.len()
    }
}

/// A [`FragmentStage`] of the shader `$shader` (an expression of a type implementing
/// `FragmentShader`, from a shader crate), with the modules `tileraster-build` compiled from
/// that crate in this crate's build script: their paths come from the environment variables
/// `<PREFIX>_SPV` and `<PREFIX>_FLOAT_CONTROLS_SPV`, the prefix `TILERASTER_FRAGMENT` unless
/// given.
///
/// ```ignore
/// static MARBLE: FragmentStage = tileraster::fragment_stage!(marble_shader::Marble);
/// ```
#[macro_export]
macro_rules! fragment_stage {
    ($shader:expr) => {
        $crate::fragment_stage!($shader, "TILERASTER_FRAGMENT")
    };
    ($shader:expr, $prefix:literal) => {
        $crate::render::FragmentStage {
            name: stringify!($shader),
            program: &$crate::kernels::programs::fragment::Programmed($shader),
            spirv: include_bytes!(env!(concat!($prefix, "_SPV"))),
            spirv_float_controls: include_bytes!(env!(concat!($prefix, "_FLOAT_CONTROLS_SPV"))),
        }
    };
}
