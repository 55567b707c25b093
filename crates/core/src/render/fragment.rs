//! A frame's programmable fragment stage (`RenderParams::fragment`): a user's fragment shader
//! (`tileraster_kernels::programs::fragment`), compiled natively for the CPU backend and to
//! SPIR-V for the GPU backend.

use tileraster_kernels::abi::FRAGMENT_CONSTANTS;
use tileraster_kernels::programs::fragment::FragmentProgram;

/// A fragment shader compiled for both backends. Made by [`fragment_stage!`](crate::fragment_stage)
/// from a shader crate that `tileraster-build` compiled in the build script: the native
/// program and the module both come from the crate's one `fragment_shader!` invocation.
#[derive(Clone, Copy)]
pub struct FragmentStage {
    name: &'static str,
    program: &'static (dyn FragmentProgram + Sync),
    spirv: &'static [u8],
    spirv_float_controls: &'static [u8],
}

/// Values a frame hands its fragment shader (`ShadeParams::constants`).
pub type FragmentConstants = [f32; FRAGMENT_CONSTANTS];

impl FragmentStage {
    /// What [`fragment_stage!`](crate::fragment_stage) expands to: `program` natively, and its
    /// crate's modules as `tileraster-build` wrote them (plain, and with the float controls
    /// declared). The GPU backend checks a module against the stage table and the numeric
    /// contract again before it runs it.
    #[doc(hidden)]
    pub const fn from_parts(
        name: &'static str,
        program: &'static (dyn FragmentProgram + Sync),
        spirv: &'static [u8],
        spirv_float_controls: &'static [u8],
    ) -> Self {
        FragmentStage { name, program, spirv, spirv_float_controls }
    }

    /// The shader crate's name, for messages.
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// The shader, called natively by the CPU backend.
    pub fn program(&self) -> &'static (dyn FragmentProgram + Sync) {
        self.program
    }

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

/// Two stages are the same when they are made from the same modules (which one macro
/// invocation ties to one program).
impl PartialEq for FragmentStage {
    fn eq(&self, other: &Self) -> bool {
        let same = |a: &[u8], b: &[u8]| a.as_ptr() == b.as_ptr() && a.len() == b.len();
        self.name == other.name && same(self.spirv, other.spirv) && same(self.spirv_float_controls, other.spirv_float_controls)
    }
}

/// The [`FragmentStage`] of the shader crate `$shader_crate` (its path, as a dependency of this
/// crate), which invokes `tileraster_kernels::fragment_shader!` once: that invocation's
/// program natively, and the modules `tileraster-build` compiled from the crate in this crate's
/// build script, found through the environment variables `<PREFIX>_SPV` and
/// `<PREFIX>_FLOAT_CONTROLS_SPV` (the prefix `TILERASTER_FRAGMENT` unless given).
///
/// ```text
/// static MARBLE: FragmentStage = tileraster::fragment_stage!(procedural_shader);
/// ```
#[macro_export]
macro_rules! fragment_stage {
    ($($shader_crate:ident)::+) => {
        $crate::fragment_stage!($($shader_crate)::+, "TILERASTER_FRAGMENT")
    };
    ($($shader_crate:ident)::+, $prefix:literal) => {
        $crate::render::FragmentStage::from_parts(
            stringify!($($shader_crate)::+),
            $($shader_crate)::+::FRAGMENT_PROGRAM,
            include_bytes!(env!(concat!($prefix, "_SPV"))),
            include_bytes!(env!(concat!($prefix, "_FLOAT_CONTROLS_SPV"))),
        )
    };
}
