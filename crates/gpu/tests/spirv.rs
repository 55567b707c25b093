//! The compiled kernels against what the host assumes of them, read from the SPIR-V itself:
//! every entry point binds exactly what its row of the stage table says (binding numbers,
//! read-only or not, workgroup size), and every float arithmetic result carries
//! `NoContraction`, in both embedded modules; the float-controls module declares 32-bit
//! round-to-nearest-even and subnormal preservation on every entry point, and is otherwise the
//! same module. Needs no adapter.

use rspirv::dr::{load_words, Instruction, Module, Operand};
use rspirv::spirv::{Capability, Decoration, ExecutionMode, Op, StorageClass};
use std::collections::{BTreeMap, HashMap, HashSet};
use tileraster_kernels::pipeline::{Access, STAGES};

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

/// Decorations by target id.
fn decorations(m: &Module) -> HashMap<u32, Vec<(Decoration, Vec<Operand>)>> {
    let mut out: HashMap<u32, Vec<_>> = HashMap::new();
    for a in m.annotations.iter().filter(|a| a.class.opcode == Op::Decorate) {
        if let Operand::Decoration(d) = a.operands[1] {
            out.entry(id(&a.operands[0])).or_default().push((d, a.operands[2..].to_vec()));
        }
    }
    out
}

fn literal(ops: &[Operand]) -> u32 {
    match ops.first() {
        Some(Operand::LiteralBit32(v)) => *v,
        other => panic!("expected a literal, found {other:?}"),
    }
}

#[test]
fn every_entry_point_binds_what_the_stage_table_says() {
    let m = module();
    let decorated = decorations(&m);
    let storage_buffers: HashSet<u32> = m
        .types_global_values
        .iter()
        .filter(|i| i.class.opcode == Op::Variable && i.operands.first() == Some(&Operand::StorageClass(StorageClass::StorageBuffer)))
        .filter_map(|i| i.result_id)
        .collect();
    let entries: HashMap<String, &Instruction> = m
        .entry_points
        .iter()
        .map(|e| match &e.operands[2] {
            Operand::LiteralString(name) => (name.clone(), e),
            other => panic!("entry point name: {other:?}"),
        })
        .collect();
    assert_eq!(entries.len(), STAGES.len(), "the module's entry points {:?} are not the stage table's", entries.keys().collect::<Vec<_>>());
    for info in &STAGES {
        let entry = entries.get(info.entry_point).unwrap_or_else(|| panic!("{}: no entry point {:?} in the module", info.name, info.entry_point));
        let function = id(&entry.operands[1]);
        // Binding number → read-only, for every storage buffer the entry point's interface lists.
        let mut bound = BTreeMap::new();
        for var in entry.operands[3..].iter().map(id).filter(|v| storage_buffers.contains(v)) {
            let ds = decorated.get(&var).map(Vec::as_slice).unwrap_or_default();
            let find = |d: Decoration| ds.iter().find(|(k, _)| *k == d).map(|(_, ops)| literal(ops));
            assert_eq!(find(Decoration::DescriptorSet), Some(0), "{}: buffer %{var} outside descriptor set 0", info.name);
            let binding = find(Decoration::Binding).unwrap_or_else(|| panic!("{}: buffer %{var} has no binding", info.name));
            let read_only = ds.iter().any(|(k, _)| *k == Decoration::NonWritable);
            assert!(bound.insert(binding, read_only).is_none(), "{}: binding {binding} twice", info.name);
        }
        let table: BTreeMap<u32, bool> = info.bindings.iter().enumerate().map(|(k, b)| (k as u32, b.access == Access::Read)).collect();
        assert_eq!(bound, table, "{}: bindings in the SPIR-V (number → read-only) differ from the stage table's", info.name);
        let size = m
            .execution_modes
            .iter()
            .find(|e| id(&e.operands[0]) == function && e.operands[1] == Operand::ExecutionMode(ExecutionMode::LocalSize))
            .map(|e| [2, 3, 4].map(|k| literal(&e.operands[k..])))
            .unwrap_or_else(|| panic!("{}: no LocalSize", info.name));
        assert_eq!(size, info.workgroup, "{}: workgroup size", info.name);
    }
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
