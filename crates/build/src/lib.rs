//! Compiles tileraster's kernels, or a user's fragment shader crate, to SPIR-V that keeps the
//! numeric contract, from a build script.
//!
//! rust-gpu compiles the crate; then every float arithmetic result is marked `NoContraction`
//! (rust-gpu emits none, and a driver may otherwise fuse `a*b + c` into one rounding), the
//! module is checked for arithmetic whose bits differ between devices and for entry points
//! that do not bind what the stage table says, and it is written twice: as it is, and with
//! the float controls that pin the rest of IEEE-754 binary32 arithmetic down (round to nearest
//! even, subnormals kept) declared on every entry point, for adapters that report them.
//! The build script's crate then finds the two files through the environment variables
//! `<PREFIX>_SPV` and `<PREFIX>_FLOAT_CONTROLS_SPV`.
//!
//! A fragment shader crate (see `tileraster_kernels::programs::fragment`) depends on
//! `tileraster-kernels` without its default features (so that the kernels' own entry points
//! stay out of its module) and invokes `fragment_shader!` once; a host crate builds it in
//! its `build.rs`, with this crate's `compile` feature:
//!
//! ```text
//! fn main() -> Result<(), tileraster_build::BuildError> {
//!     tileraster_build::Shader::fragment("shader").build()
//! }
//! ```
//!
//! and takes it with `tileraster::fragment_stage!(my_shader)`. A vertex shader crate
//! (`programs::vertex`) is the same with `vertex_shader!`, `Shader::vertex` and
//! `tileraster::vertex_stage!`.

pub mod check;
#[cfg(feature = "compile")]
mod compile;

#[cfg(feature = "compile")]
pub use compile::Shader;

use rspirv::dr::{Instruction, Module, Operand};
use rspirv::spirv::{Capability as SpirvCapability, Decoration, ExecutionMode, Op};
use std::collections::HashSet;
use std::path::PathBuf;
use tileraster_kernels::pipeline::{Stage, StageInfo};

/// Why a crate could not be made into a module.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("rust-gpu could not compile {crate_path}: {reason}")]
    Compile { crate_path: PathBuf, reason: String },
    #[error("reading the SPIR-V rust-gpu wrote for {crate_path}: {reason}")]
    Read { crate_path: PathBuf, reason: String },
    #[error("optimising the module of {crate_path}: {reason}")]
    Optimise { crate_path: PathBuf, reason: String },
    #[error("the module of {crate_path} breaks tileraster's numeric contract:\n{}\nUse tileraster_kernels::math::float's correctly rounded div, recip and sqrt, and additions, subtractions and multiplications of floats; transcendental functions have no portable bits", .problems.join("\n"))]
    NotPortable { crate_path: PathBuf, problems: Vec<String> },
    #[error("the entry points of {crate_path} are not the stage table's:\n{}", .problems.join("\n"))]
    EntryPoints { crate_path: PathBuf, problems: Vec<String> },
    #[error("writing {path}: {reason}")]
    Write { path: PathBuf, reason: String },
    #[error("{0} is not set: call this from a build script")]
    NotInBuildScript(&'static str),
}

/// What a module is: which rows of the stage table it has entry points for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Every stage: tileraster's own kernels.
    Kernels,
    /// The stages that colour fragments, around a user's fragment shader.
    Fragment,
    /// The vertex stage, around a user's vertex shader.
    Vertex,
}

impl Role {
    /// Whether the module has an entry point for `info`'s row.
    pub fn has(self, info: &StageInfo) -> bool {
        match self {
            Role::Kernels => true,
            Role::Fragment => info.stage.colours_fragments(),
            Role::Vertex => info.stage == Stage::Vertex,
        }
    }
}

/// The float arithmetic instructions a driver could contract with a neighbour.
pub const CONTRACTIBLE: [Op; 14] = [
    Op::FAdd,
    Op::FSub,
    Op::FMul,
    Op::FDiv,
    Op::FRem,
    Op::FMod,
    Op::FNegate,
    Op::VectorTimesScalar,
    Op::MatrixTimesScalar,
    Op::VectorTimesMatrix,
    Op::MatrixTimesVector,
    Op::MatrixTimesMatrix,
    Op::OuterProduct,
    Op::Dot,
];

/// Decorates every float arithmetic result `NoContraction`, but for those of constants alone
/// (`1.0 / 255.0`): the optimiser folds them, in IEEE arithmetic with the bits the CPU's
/// compiler gives them, and the decoration would keep a division that no device divides alike.
pub fn mark_no_contraction(module: &mut Module) {
    let constants: HashSet<u32> = module
        .types_global_values
        .iter()
        .filter(|i| matches!(i.class.opcode, Op::Constant | Op::ConstantComposite | Op::ConstantNull))
        .filter_map(|i| i.result_id)
        .collect();
    let of_constants = |i: &Instruction| i.operands.iter().all(|o| matches!(o, Operand::IdRef(id) if constants.contains(id)));
    let contractible: Vec<u32> = module
        .functions
        .iter()
        .flat_map(|f| f.all_inst_iter())
        .filter(|i| CONTRACTIBLE.contains(&i.class.opcode) && !of_constants(i))
        .filter_map(|i| i.result_id)
        .collect();
    for id in contractible {
        module.annotations.push(Instruction::new(Op::Decorate, None, None, vec![Operand::IdRef(id), Operand::Decoration(Decoration::NoContraction)]));
    }
}

/// Declares 32-bit round-to-nearest-even and subnormal preservation on every entry point
/// (capabilities core since SPIR-V 1.4; the module is 1.5).
pub fn declare_float_controls(module: &mut Module) {
    for capability in [SpirvCapability::RoundingModeRTE, SpirvCapability::DenormPreserve] {
        module.capabilities.push(Instruction::new(Op::Capability, None, None, vec![Operand::Capability(capability)]));
    }
    let entries: Vec<u32> = module.entry_points.iter().filter_map(|e| e.operands.get(1).and_then(|o| o.id_ref_any())).collect();
    for entry in entries {
        for mode in [ExecutionMode::RoundingModeRTE, ExecutionMode::DenormPreserve] {
            let operands = vec![Operand::IdRef(entry), Operand::ExecutionMode(mode), Operand::LiteralBit32(32)];
            module.execution_modes.push(Instruction::new(Op::ExecutionMode, None, None, operands));
        }
    }
}
