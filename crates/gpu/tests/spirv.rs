//! The compiled kernels against what the host assumes of them, read from the SPIR-V itself:
//! every entry point binds exactly what its row of the stage table says (binding numbers,
//! read-only or not, workgroup size), and every float arithmetic result carries
//! `NoContraction`, in both embedded modules; the float-controls module declares 32-bit
//! round-to-nearest-even and subnormal preservation on every entry point, and is otherwise the
//! same module. Needs no adapter.

use rspirv::dr::{load_words, Instruction, Module, Operand};
use rspirv::spirv::{Capability, Decoration, ExecutionMode, Op};
use std::collections::HashSet;
use tileraster_kernels::pipeline::STAGES;

fn load(bytes: &[u8]) -> Module {
    let words: Vec<u32> = bytes.as_chunks::<4>().0.iter().map(|&b| u32::from_le_bytes(b)).collect();
    load_words(words).expect("the embedded kernels are valid SPIR-V")
}

fn module() -> Module {
    load(tileraster_gpu::KERNELS_SPV)
}

/// Both embedded modules: as compiled, and with float controls.
fn modules() -> [(&'static str, Module); 2] {
    [("plain", module()), ("float controls", load(tileraster_gpu::KERNELS_FLOAT_CONTROLS_SPV))]
}

fn id(op: &Operand) -> u32 {
    match op {
        Operand::IdRef(id) => *id,
        other => panic!("expected an id, found {other:?}"),
    }
}

use tileraster_build::check::{self, decorations};

#[test]
fn every_entry_point_binds_what_the_stage_table_says() {
    for (name, m) in modules() {
        let problems = check::entry_points(&m, |_| true);
        assert!(problems.is_empty(), "{name}: the entry points differ from the stage table:\n{}", problems.join("\n"));
    }
}

/// The check above finds what it looks for: a module with an entry point's binding moved,
/// one with a workgroup size changed, and one missing an entry point all fail it.
#[test]
fn the_stage_table_check_finds_a_broken_module() {
    let mut moved = module();
    let binding = moved.annotations.iter_mut().find(|a| a.operands.get(1) == Some(&Operand::Decoration(Decoration::Binding))).expect("a binding");
    binding.operands[2] = Operand::LiteralBit32(40);
    assert!(!check::entry_points(&moved, |_| true).is_empty(), "a moved binding");
    let mut resized = module();
    let size = resized.execution_modes.iter_mut().find(|e| e.operands[1] == Operand::ExecutionMode(ExecutionMode::LocalSize)).expect("a local size");
    size.operands[2] = Operand::LiteralBit32(7);
    assert!(!check::entry_points(&resized, |_| true).is_empty(), "a workgroup size");
    let mut missing = module();
    missing.entry_points.pop();
    assert!(!check::entry_points(&missing, |_| true).is_empty(), "an entry point missing");
    // Only the shading stages: the kernels' module has entry points such a module must not.
    assert!(!check::entry_points(&module(), |info| info.stage.colours_fragments()).is_empty(), "extra entry points");
}

/// The kernels hold no float arithmetic whose bits differ between devices (what
/// `tileraster-build` refuses in a fragment shader too), and the check finds such an
/// instruction where there is one.
#[test]
fn the_kernels_hold_only_portable_arithmetic() {
    for (name, m) in modules() {
        let problems = check::portable(&m);
        assert!(problems.is_empty(), "{name}:\n{}", problems.join("\n"));
    }
    let mut divided = module();
    let product = divided.functions.iter_mut().flat_map(|f| f.blocks.iter_mut()).flat_map(|b| b.instructions.iter_mut()).find(|i| i.class.opcode == Op::FMul).expect("a float product");
    *product = Instruction::new(Op::FDiv, product.result_type, product.result_id, product.operands.clone());
    assert_eq!(check::portable(&divided).len(), 1, "one division");
}

/// Instructions that produce a float without arithmetic a driver could fuse: moves, loads,
/// constants, selections, bit casts and conversions (exact, or correctly rounded on their own).
const NOT_ARITHMETIC: [Op; 19] = [
    Op::Load,
    Op::Phi,
    Op::Select,
    Op::CopyObject,
    Op::CompositeExtract,
    Op::CompositeConstruct,
    Op::CompositeInsert,
    Op::VectorShuffle,
    Op::VectorExtractDynamic,
    Op::Bitcast,
    Op::Undef,
    Op::Constant,
    Op::ConstantComposite,
    Op::ConstantNull,
    Op::FunctionParameter,
    Op::FunctionCall,
    Op::ConvertSToF,
    Op::ConvertUToF,
    Op::FConvert,
];

#[test]
fn every_float_arithmetic_result_carries_no_contraction() {
    for (name, m) in modules() {
        no_contraction_on_every_float_result(name, &m);
    }
}

/// The float-controls module is the plain one plus two capabilities and two execution modes
/// per entry point, and only that.
#[test]
fn the_float_controls_module_declares_rte_and_denorm_preserve_on_every_entry_point() {
    let [(_, plain), (_, controlled)] = modules();
    let modes = |m: &Module, wanted: ExecutionMode| -> HashSet<u32> {
        m.execution_modes.iter().filter(|e| e.operands[1] == Operand::ExecutionMode(wanted)).map(|e| {
            assert_eq!(e.operands[2], Operand::LiteralBit32(32), "{wanted:?} must name 32-bit floats");
            id(&e.operands[0])
        }).collect()
    };
    let entries: HashSet<u32> = controlled.entry_points.iter().map(|e| id(&e.operands[1])).collect();
    assert_eq!(entries.len(), STAGES.len());
    for wanted in [ExecutionMode::RoundingModeRTE, ExecutionMode::DenormPreserve] {
        assert_eq!(modes(&controlled, wanted), entries, "{wanted:?} on every entry point");
        assert!(modes(&plain, wanted).is_empty(), "the plain module declares no {wanted:?}");
    }
    let capabilities = |m: &Module| -> Vec<Operand> { m.capabilities.iter().map(|c| c.operands[0].clone()).collect() };
    let mut expected = capabilities(&plain);
    expected.extend([Operand::Capability(Capability::RoundingModeRTE), Operand::Capability(Capability::DenormPreserve)]);
    assert_eq!(capabilities(&controlled), expected);
    assert_eq!(controlled.execution_modes.len(), plain.execution_modes.len() + 2 * entries.len());
    use rspirv::binary::Disassemble;
    assert_eq!(controlled.functions.iter().map(|f| f.disassemble()).collect::<Vec<_>>(), plain.functions.iter().map(|f| f.disassemble()).collect::<Vec<_>>());
}

fn no_contraction_on_every_float_result(name: &str, m: &Module) {
    let decorated = decorations(m);
    let float_types: HashSet<u32> = {
        let mut set = HashSet::new();
        for t in &m.types_global_values {
            let float = match t.class.opcode {
                Op::TypeFloat => true,
                Op::TypeVector | Op::TypeMatrix => set.contains(&id(&t.operands[0])),
                _ => false,
            };
            if float {
                set.insert(t.result_id.expect("types have ids"));
            }
        }
        set
    };
    let mut checked = 0;
    let mut missing = Vec::new();
    for inst in m.functions.iter().flat_map(|f| f.all_inst_iter()) {
        let (Some(ty), Some(result)) = (inst.result_type, inst.result_id) else { continue };
        if !float_types.contains(&ty) || NOT_ARITHMETIC.contains(&inst.class.opcode) {
            continue;
        }
        checked += 1;
        let ok = decorated.get(&result).is_some_and(|ds| ds.iter().any(|(d, _)| *d == Decoration::NoContraction));
        if !ok {
            missing.push(format!("%{result} = {:?}", inst.class.opcode));
        }
    }
    assert!(missing.is_empty(), "{name}: {} of {checked} float arithmetic results lack NoContraction: {:?}", missing.len(), &missing[..missing.len().min(12)]);
    // The modes that compute in f32 are in the module: the check above has something to check.
    assert!(checked > 0, "{name}: no float arithmetic found: the plane-f32 and barycentric modes should have some");
}
