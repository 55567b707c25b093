//! What a module must be before the GPU backend may run it, read from the SPIR-V itself: its
//! entry points bind exactly what their rows of the stage table say (binding numbers,
//! read-only or not, workgroup size), and it holds no arithmetic whose bits differ between
//! devices. Each check returns its problems, one line each; none means the module passes.

use rspirv::dr::{Instruction, Module, Operand};
use rspirv::spirv::{Decoration, ExecutionMode, Op, StorageClass};
use std::collections::{BTreeMap, HashMap, HashSet};
use tileraster_kernels::pipeline::{Access, StageInfo, STAGES};

/// Float instructions Vulkan does not round correctly, or leaves the order of to the driver:
/// division (2.5 ULP), remainders, and products that sum in an unspecified order.
const NOT_PORTABLE: [Op; 6] = [Op::FDiv, Op::FRem, Op::FMod, Op::Dot, Op::VectorTimesMatrix, Op::MatrixTimesVector];

/// GLSL.std.450 instructions whose results are exact on every Vulkan device: rounding to
/// integers (`Round`, whose halfway direction is the driver's, left out), the absolute value,
/// `Fract` (`x − floor(x)`, exact), `Step`, `Ldexp`, `Frexp`, integer signs, minima, maxima and
/// clamps, and bit searches. The float minimum, maximum, clamp and sign are left out: Vulkan
/// leaves their results on NaN (and the sign of a zero minimum) to the driver; a comparison
/// does the same job exactly.
const EXACT_GLSL: [u32; 19] = [
    2,  // RoundEven
    3,  // Trunc
    4,  // FAbs
    5,  // SAbs
    7,  // SSign
    8,  // Floor
    9,  // Ceil
    10, // Fract
    38, // UMin
    39, // SMin
    41, // UMax
    42, // SMax
    44, // UClamp
    45, // SClamp
    48, // Step
    51, // Frexp
    53, // Ldexp
    74, // FindSMsb
    75, // FindUMsb
];

/// The module's instructions whose bits may differ between devices, each with the function
/// that holds it.
pub fn portable(m: &Module) -> Vec<String> {
    let names = debug_names(m);
    let sets: HashMap<u32, String> = m
        .ext_inst_imports
        .iter()
        .filter_map(|i| match (i.result_id, i.operands.first()) {
            (Some(id), Some(Operand::LiteralString(name))) => Some((id, name.clone())),
            _ => None,
        })
        .collect();
    let mut problems = Vec::new();
    for f in &m.functions {
        let function = f.def.as_ref().and_then(|d| d.result_id).and_then(|id| names.get(&id).cloned()).unwrap_or_else(|| "an unnamed function".into());
        for inst in f.all_inst_iter() {
            let op = inst.class.opcode;
            let problem = if NOT_PORTABLE.contains(&op) {
                Some(format!("{op:?}"))
            } else if op == Op::ExtInst {
                let set = inst.operands.first().and_then(Operand::id_ref_any).and_then(|s| sets.get(&s)).map_or("?", String::as_str);
                let number = match inst.operands.get(1) {
                    Some(Operand::LiteralExtInstInteger(n)) => *n,
                    _ => u32::MAX,
                };
                match set {
                    "GLSL.std.450" if EXACT_GLSL.contains(&number) => None,
                    s if s.starts_with("NonSemantic.") => None,
                    s => Some(format!("{s} instruction {number}")),
                }
            } else {
                None
            };
            if let Some(p) = problem {
                problems.push(format!("  {p} in {function}"));
            }
        }
    }
    problems.dedup();
    problems
}

/// Differences between the module's entry points and the stage table's rows that `rows`
/// picks: missing or extra entry points, bindings (number → read-only) and workgroup sizes.
pub fn entry_points(m: &Module, rows: impl Fn(&StageInfo) -> bool) -> Vec<String> {
    let decorated = decorations(m);
    let storage_buffers: HashSet<u32> = m
        .types_global_values
        .iter()
        .filter(|i| i.class.opcode == Op::Variable && i.operands.first() == Some(&Operand::StorageClass(StorageClass::StorageBuffer)))
        .filter_map(|i| i.result_id)
        .collect();
    let entries: HashMap<String, &Instruction> = m
        .entry_points
        .iter()
        .filter_map(|e| match e.operands.get(2) {
            Some(Operand::LiteralString(name)) => Some((name.clone(), e)),
            _ => None,
        })
        .collect();
    let mut problems = Vec::new();
    let wanted: Vec<&StageInfo> = STAGES.iter().filter(|s| rows(s)).collect();
    for name in entries.keys().filter(|name| !wanted.iter().any(|s| s.entry_point == name.as_str())) {
        problems.push(format!(
            "  {name:?} is not an entry point this module should have (a fragment shader crate takes tileraster-kernels with default-features = false, and invokes fragment_shader! once)"
        ));
    }
    for info in wanted {
        let Some(entry) = entries.get(info.entry_point) else {
            problems.push(format!("  no entry point {:?} (stage {}): invoke fragment_shader! in the crate", info.entry_point, info.name));
            continue;
        };
        let Some(function) = entry.operands.get(1).and_then(Operand::id_ref_any) else { continue };
        // Binding number → read-only, for every storage buffer the entry point's interface lists.
        let mut bound = BTreeMap::new();
        for var in entry.operands[3..].iter().filter_map(Operand::id_ref_any).filter(|v| storage_buffers.contains(v)) {
            let ds = decorated.get(&var).map(Vec::as_slice).unwrap_or_default();
            let find = |d: Decoration| ds.iter().find(|(k, _)| *k == d).and_then(|(_, ops)| literal(ops));
            if find(Decoration::DescriptorSet) != Some(0) {
                problems.push(format!("  {}: buffer %{var} outside descriptor set 0", info.name));
            }
            let read_only = ds.iter().any(|(k, _)| *k == Decoration::NonWritable);
            match find(Decoration::Binding) {
                Some(binding) if bound.insert(binding, read_only).is_some() => problems.push(format!("  {}: binding {binding} twice", info.name)),
                Some(_) => {}
                None => problems.push(format!("  {}: buffer %{var} has no binding", info.name)),
            }
        }
        let table: BTreeMap<u32, bool> = info.bindings.iter().enumerate().map(|(k, b)| (k as u32, b.access == Access::Read)).collect();
        if bound != table {
            problems.push(format!("  {}: bindings (number → read-only) {bound:?}, the stage table's {table:?}", info.name));
        }
        let size = m
            .execution_modes
            .iter()
            .find(|e| e.operands.first().and_then(Operand::id_ref_any) == Some(function) && e.operands.get(1) == Some(&Operand::ExecutionMode(ExecutionMode::LocalSize)))
            .map(|e| [2, 3, 4].map(|k| literal(&e.operands[k..]).unwrap_or(0)));
        if size != Some(info.workgroup) {
            problems.push(format!("  {}: workgroup size {size:?}, the stage table's {:?}", info.name, info.workgroup));
        }
    }
    problems
}

/// Decorations by target id.
pub fn decorations(m: &Module) -> HashMap<u32, Vec<(Decoration, Vec<Operand>)>> {
    let mut out: HashMap<u32, Vec<_>> = HashMap::new();
    for a in m.annotations.iter().filter(|a| a.class.opcode == Op::Decorate) {
        if let (Some(target), Some(Operand::Decoration(d))) = (a.operands.first().and_then(Operand::id_ref_any), a.operands.get(1)) {
            out.entry(target).or_default().push((*d, a.operands[2..].to_vec()));
        }
    }
    out
}

fn debug_names(m: &Module) -> HashMap<u32, String> {
    m.debug_names
        .iter()
        .filter(|d| d.class.opcode == Op::Name)
        .filter_map(|d| match (d.operands.first().and_then(Operand::id_ref_any), d.operands.get(1)) {
            (Some(id), Some(Operand::LiteralString(name))) => Some((id, name.clone())),
            _ => None,
        })
        .collect()
}

fn literal(ops: &[Operand]) -> Option<u32> {
    match ops.first() {
        Some(Operand::LiteralBit32(v)) => Some(*v),
        _ => None,
    }
}
