//! Compiles `shader-crate` to one SPIR-V module with rust-gpu, then marks every float
//! arithmetic result `NoContraction` (rust-gpu emits none), so that no driver may fuse
//! `a*b + c` into one rounding. `src/lib.rs` embeds the result; the GPU backend hands it to
//! the driver unchanged (a passthrough module: wgpu's own translation would drop the
//! decorations), and `tests/spirv.rs` checks both the decorations and the stage table.

use rspirv::binary::Assemble;
use rspirv::dr::{load_words, Instruction, Operand};
use rspirv::spirv::{Decoration, Op};
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
    let out = Path::new(&std::env::var("OUT_DIR")?).join("tileraster-kernels.spv");
    let bytes: Vec<u8> = module.assemble().iter().flat_map(|w| w.to_le_bytes()).collect();
    std::fs::write(&out, bytes)?;
    println!("cargo::rustc-env=TILERASTER_KERNELS_SPV={}", out.display());
    Ok(())
}
