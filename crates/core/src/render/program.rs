//! A frame's programmable stages: a user's fragment shader (`RenderParams::fragment`,
//! `tileraster_kernels::programs::fragment`) and vertex shader (`RenderParams::vertex`,
//! `programs::vertex`), each compiled natively for the CPU backend (and, for the vertex shader,
//! the host) and to SPIR-V for the GPU backend.

use tileraster_kernels::abi::{FRAGMENT_CONSTANTS, VERTEX_CONSTANTS};
use tileraster_kernels::programs::fragment::FragmentProgram;
use tileraster_kernels::programs::vertex::VertexProgram;

/// A shader compiled for both backends: its program `P` natively, and its crate's modules as
/// `tileraster-build` wrote them. Made by [`fragment_stage!`](crate::fragment_stage) or
/// [`vertex_stage!`](crate::vertex_stage) from a shader crate that `tileraster-build`
/// compiled in the build script: the native program and the modules both come from the
/// crate's one `fragment_shader!` or `vertex_shader!` invocation.
pub struct ProgramStage<P: ?Sized + 'static> {
    program: &'static P,
    modules: ShaderModules,
    /// A program built into the kernels (`VertexUniforms::builtin`), whose modules are theirs;
    /// 0 for a user's shader.
    builtin: u32,
}

/// A fragment shader compiled for both backends.
pub type FragmentStage = ProgramStage<dyn FragmentProgram + Sync>;
/// A vertex shader compiled for both backends.
pub type VertexStage = ProgramStage<dyn VertexProgram + Sync>;

/// Values a frame hands its fragment shader (`ShadeParams::constants`).
pub type FragmentConstants = [f32; FRAGMENT_CONSTANTS];
/// Values a frame hands its vertex shader (`VertexUniforms::constants`).
pub type VertexConstants = [f32; VERTEX_CONSTANTS];

/// A frame's vertex texture: `f32` texels row by row from the first, which a vertex shader reads
/// (`tileraster_kernels::programs::vertex::texel`), e.g. a DEM's heights. Shared (`Arc`) so that
/// a prepared mesh's frames hand the GPU the same texture once.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VertexTexture {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<f32>,
}

/// A shader crate's two modules (plain, and with the float controls declared) and its name.
#[derive(Clone, Copy)]
pub struct ShaderModules {
    name: &'static str,
    spirv: &'static [u8],
    spirv_float_controls: &'static [u8],
}

impl ShaderModules {
    /// The shader crate's name, for messages.
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// The module for an adapter with (`true`) or without the float controls declared.
    pub fn module(&self, float_controls: bool) -> &'static [u8] {
        if float_controls { self.spirv_float_controls } else { self.spirv }
    }
}

/// Two crates' modules are the same when they are the same bytes in memory (which one macro
/// invocation ties to one program).
impl PartialEq for ShaderModules {
    fn eq(&self, other: &Self) -> bool {
        let same = |a: &[u8], b: &[u8]| a.as_ptr() == b.as_ptr() && a.len() == b.len();
        self.name == other.name && same(self.spirv, other.spirv) && same(self.spirv_float_controls, other.spirv_float_controls)
    }
}

impl<P: ?Sized + 'static> ProgramStage<P> {
    /// What [`fragment_stage!`](crate::fragment_stage) and [`vertex_stage!`](crate::vertex_stage)
    /// expand to: `program` natively, and its crate's modules as `tileraster-build` wrote them
    /// (plain, and with the float controls declared). The GPU backend checks a module against
    /// the stage table and the numeric contract again before it runs it.
    #[doc(hidden)]
    pub const fn from_parts(name: &'static str, program: &'static P, spirv: &'static [u8], spirv_float_controls: &'static [u8]) -> Self {
        ProgramStage { program, modules: ShaderModules { name, spirv, spirv_float_controls }, builtin: 0 }
    }

    /// The shader crate's name, for messages.
    pub fn name(&self) -> &'static str {
        self.modules.name
    }

    /// The shader, called natively by the CPU backend.
    pub fn program(&self) -> &'static P {
        self.program
    }

    /// The module for an adapter with (`true`) or without the float controls declared.
    pub fn module(&self, float_controls: bool) -> &'static [u8] {
        self.modules.module(float_controls)
    }

    /// Its modules and name, as the GPU backend keeps them; `None` for a program built into the
    /// kernels.
    pub fn modules(&self) -> Option<ShaderModules> {
        (self.builtin == 0).then_some(self.modules)
    }

    /// Which program built into the kernels it is (`VertexUniforms::builtin`); 0 for a user's.
    pub fn builtin(&self) -> u32 {
        self.builtin
    }
}

impl VertexStage {
    /// The built-in heightfield (`programs::vertex::BUILTIN_HEIGHTS`): a grid of the vertex
    /// texture's size, vertex by vertex row by row, lifted by its texel times
    /// `RenderParams::vertex_constants[0]`. `tileraster::render::dem_grid` makes such a
    /// grid of a DEM.
    pub const HEIGHTS: VertexStage = ProgramStage {
        program: &tileraster_kernels::programs::vertex::Builtin,
        modules: ShaderModules { name: "heights", spirv: &[], spirv_float_controls: &[] },
        builtin: tileraster_kernels::programs::vertex::BUILTIN_HEIGHTS,
    };

    /// glTF's morph targets and skins (`programs::vertex::BUILTIN_DEFORM`), from the joints,
    /// weights and offsets of a vertex texture laid out as `programs::deform::DeformLayout`
    /// says, whose constants `RenderParams::vertex_constants` holds. A mesh with normals of its
    /// own has them posed alike (`programs::deform::morphed`, then each vertex's matrix's
    /// inverse transpose). `tileraster_io::read_gltf_posable` makes such a mesh and texture.
    pub const DEFORM: VertexStage = ProgramStage {
        program: &tileraster_kernels::programs::vertex::Builtin,
        modules: ShaderModules { name: "deform", spirv: &[], spirv_float_controls: &[] },
        builtin: tileraster_kernels::programs::vertex::BUILTIN_DEFORM,
    };
}

impl<P: ?Sized + 'static> Clone for ProgramStage<P> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<P: ?Sized + 'static> Copy for ProgramStage<P> {}

impl<P: ?Sized + 'static> std::fmt::Debug for ProgramStage<P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ProgramStage").field("name", &self.modules.name).field("spirv_bytes", &self.modules.spirv.len()).finish()
    }
}

/// Two stages are the same when they are made from the same modules.
impl<P: ?Sized + 'static> PartialEq for ProgramStage<P> {
    fn eq(&self, other: &Self) -> bool {
        self.modules == other.modules && self.builtin == other.builtin
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

/// The [`VertexStage`] of the shader crate `$shader_crate`, which invokes
/// `tileraster_kernels::vertex_shader!` once: as [`fragment_stage!`](crate::fragment_stage),
/// with the prefix `TILERASTER_VERTEX` unless given.
///
/// ```text
/// static WAVES: VertexStage = tileraster::vertex_stage!(waves_shader);
/// ```
#[macro_export]
macro_rules! vertex_stage {
    ($($shader_crate:ident)::+) => {
        $crate::vertex_stage!($($shader_crate)::+, "TILERASTER_VERTEX")
    };
    ($($shader_crate:ident)::+, $prefix:literal) => {
        $crate::render::VertexStage::from_parts(
            stringify!($($shader_crate)::+),
            $($shader_crate)::+::VERTEX_PROGRAM,
            include_bytes!(env!(concat!($prefix, "_SPV"))),
            include_bytes!(env!(concat!($prefix, "_FLOAT_CONTROLS_SPV"))),
        )
    };
}
