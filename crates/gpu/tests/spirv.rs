//! The compiled kernels against what the host assumes of them, read from the SPIR-V itself:
//! every entry point binds exactly what its row of the stage table says (binding numbers, each
//! buffer uniform, read-only or read-write, workgroup size), and every float arithmetic result carries
//! `NoContraction`, in both embedded modules; the float-controls module declares 32-bit
//! round-to-nearest-even and subnormal preservation on every entry point, and is otherwise the
//! same module. Needs no adapter.

use rspirv::dr::{Instruction, Module, Operand};
use rspirv::spirv::{Capability, Decoration, ExecutionMode, Op, StorageClass};
use std::collections::HashSet;
use tileraster_kernels::pipeline::STAGES;

fn load(bytes: &[u8]) -> Module {
    check::load(bytes).expect("the embedded kernels are valid SPIR-V")
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

use tileraster_build::check;

#[test]
fn every_entry_point_binds_what_the_stage_table_says() {
    for (name, m) in modules() {
        let problems = check::entry_points(&m, |_| true);
        assert!(problems.is_empty(), "{name}: the entry points differ from the stage table:\n{}", problems.join("\n"));
    }
}

/// The check above finds what it looks for: a module with an entry point's binding moved,
/// one with a workgroup size changed, one with the frame's uniform buffer declared a storage
/// buffer, and one missing an entry point all fail it.
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
    let mut storage = module();
    let frame = storage
        .types_global_values
        .iter_mut()
        .find(|i| i.class.opcode == Op::Variable && i.operands.first() == Some(&Operand::StorageClass(StorageClass::Uniform)))
        .expect("a uniform buffer");
    frame.operands[0] = Operand::StorageClass(StorageClass::StorageBuffer);
    assert!(!check::entry_points(&storage, |_| true).is_empty(), "a uniform buffer bound as a storage buffer");
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
    let product = divided
        .functions
        .iter_mut()
        .flat_map(|f| f.blocks.iter_mut())
        .flat_map(|b| b.instructions.iter_mut())
        .find(|i| i.class.opcode == Op::FMul)
        .expect("a float product");
    *product = Instruction::new(Op::FDiv, product.result_type, product.result_id, product.operands.clone());
    assert_eq!(check::portable(&divided).len(), 1, "one division");
    // GLSL.std.450 calls: `Floor` is exact everywhere, `FMin` leaves NaN to the driver.
    for (number, refused) in [(8, false), (37, true)] {
        let mut called = module();
        let bound = called.header.as_ref().expect("a header").bound;
        called.header.as_mut().expect("a header").bound = bound + 1;
        called.ext_inst_imports.push(Instruction::new(Op::ExtInstImport, None, Some(bound), vec![Operand::LiteralString("GLSL.std.450".into())]));
        let product = called
            .functions
            .iter_mut()
            .flat_map(|f| f.blocks.iter_mut())
            .flat_map(|b| b.instructions.iter_mut())
            .find(|i| i.class.opcode == Op::FMul)
            .expect("a float product");
        let operands = vec![Operand::IdRef(bound), Operand::LiteralExtInstInteger(number), product.operands[0].clone(), product.operands[1].clone()];
        *product = Instruction::new(Op::ExtInst, product.result_type, product.result_id, operands);
        assert_eq!(check::portable(&called).len(), usize::from(refused), "GLSL.std.450 instruction {number}");
    }
}

#[test]
fn every_float_arithmetic_result_carries_no_contraction() {
    for (name, m) in modules() {
        let (checked, missing) = check::contraction(&m);
        assert!(
            missing.is_empty(),
            "{name}: {} of {checked} float arithmetic results lack NoContraction:\n{}",
            missing.len(),
            missing[..missing.len().min(12)].join("\n")
        );
        // The modes that compute in f32 are in the module: the check above has something to check.
        assert!(checked > 0, "{name}: no float arithmetic found: the plane-f32 and barycentric modes should have some");
    }
}

/// The float-controls module is the plain one plus two capabilities and two execution modes
/// per entry point, and only that.
#[test]
fn the_float_controls_module_declares_rte_and_denorm_preserve_on_every_entry_point() {
    let [(_, plain), (_, controlled)] = modules();
    let modes = |m: &Module, wanted: ExecutionMode| -> HashSet<u32> {
        m.execution_modes
            .iter()
            .filter(|e| e.operands[1] == Operand::ExecutionMode(wanted))
            .map(|e| {
                assert_eq!(e.operands[2], Operand::LiteralBit32(32), "{wanted:?} must name 32-bit floats");
                id(&e.operands[0])
            })
            .collect()
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
