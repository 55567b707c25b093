//! Compiles `shader-crate` to one SPIR-V module with rust-gpu, then marks every float
//! arithmetic result `NoContraction` (rust-gpu emits none), so that no driver may fuse
//! `a*b + c` into one rounding. It writes that module twice: as it is, and with the float
//! controls that pin the rest of IEEE-754 binary32 arithmetic down (round to nearest even,
//! subnormals kept) declared on every entry point, for adapters that report them (Vulkan
//! leaves both to the driver otherwise). `src/lib.rs` embeds both; the GPU backend hands one to
//! the driver unchanged (a passthrough module: wgpu's own translation would drop the
//! decorations), and `tests/spirv.rs` checks the decorations, the execution modes and the
//! stage table.

use rspirv::binary::Assemble;
use rspirv::dr::{load_words, Instruction, Operand};
use rspirv::spirv::{Capability as SpirvCapability, Decoration, ExecutionMode, Op};
use spirv_builder::{Capability, SpirvBuilder};
use std::path::Path;

/// The float arithmetic instructions a driver could contract with a neighbour.
const CONTRACTIBLE: [Op; 14] = [
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

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let kernels = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shader-crate");
    let mut builder = SpirvBuilder::new(kernels, "spirv-unknown-vulkan1.2").capability(Capability::Int64);
    builder.build_script.defaults = true;
    let result = builder.build()?;
    let words: Vec<u32> = std::fs::read(result.module.unwrap_single())?.as_chunks::<4>().0.iter().map(|&b| u32::from_le_bytes(b)).collect();
    let mut module = load_words(words).map_err(|e| format!("reading rust-gpu's SPIR-V: {e}"))?;
    let contractible: Vec<u32> = module
        .functions
        .iter()
        .flat_map(|f| f.all_inst_iter())
        .filter(|i| CONTRACTIBLE.contains(&i.class.opcode))
        .filter_map(|i| i.result_id)
        .collect();
    for id in contractible {
        module.annotations.push(Instruction::new(Op::Decorate, None, None, vec![Operand::IdRef(id), Operand::Decoration(Decoration::NoContraction)]));
    }
    let out_dir = std::env::var("OUT_DIR")?;
    write_module(&module, &out_dir, "tileraster-kernels.spv", "TILERASTER_KERNELS_SPV")?;
    declare_float_controls(&mut module);
    write_module(&module, &out_dir, "tileraster-kernels-float-controls.spv", "TILERASTER_KERNELS_FLOAT_CONTROLS_SPV")?;
    Ok(())
}

/// Declares 32-bit round-to-nearest-even and subnormal preservation on every entry point
/// (capabilities core since SPIR-V 1.4; the module is 1.5).
fn declare_float_controls(module: &mut rspirv::dr::Module) {
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

fn write_module(module: &rspirv::dr::Module, out_dir: &str, name: &str, env: &str) -> Result<(), Box<dyn std::error::Error>> {
    let out = Path::new(out_dir).join(name);
    let bytes: Vec<u8> = module.assemble().iter().flat_map(|w| w.to_le_bytes()).collect();
    std::fs::write(&out, bytes)?;
    println!("cargo::rustc-env={env}={}", out.display());
    Ok(())
}
