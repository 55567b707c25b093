//! What a module must be before the GPU backend may run it, read from the SPIR-V itself: its
//! entry points bind exactly what their rows of the stage table say (binding numbers, each
//! buffer uniform, read-only or read-write, workgroup size), and it holds no arithmetic whose bits differ between
//! devices. Each check returns its problems, one line each; none means the module passes.

use crate::Role;
use rspirv::dr::{Instruction, Module, Operand, load_words};
use rspirv::spirv::{Decoration, ExecutionMode, Op, StorageClass};
use std::collections::{BTreeMap, HashMap, HashSet};
use tileraster_kernels::pipeline::{Access, STAGES, StageInfo};

/// Float instructions Vulkan does not round correctly, or leaves the order of to the driver:
/// division (2.5 ULP), remainders, and products that sum in an unspecified order.
const NOT_PORTABLE: [Op; 7] = [Op::FDiv, Op::FRem, Op::FMod, Op::Dot, Op::VectorTimesMatrix, Op::MatrixTimesVector, Op::MatrixTimesMatrix];

/// GLSL.std.450 instructions whose results are the same on every Vulkan device: rounding to
/// integers (`Round`, whose halfway direction is the driver's, left out), the absolute value,
/// integer signs, minima, maxima and clamps, and bit searches. Left out besides: the float
/// minimum, maximum, clamp, sign and step, whose results on NaN (and the sign of a zero
/// minimum) are the driver's; `Fract`, which a driver may clamp below 1; `Ldexp` and `Frexp`,
/// undefined where they overflow. A comparison or the integer bits do their jobs exactly.
const EXACT_GLSL: [u32; 16] = [
    2,  // RoundEven
    3,  // Trunc
    4,  // FAbs
    5,  // SAbs
    7,  // SSign
    8,  // Floor
    9,  // Ceil
    38, // UMin
    39, // SMin
    41, // UMax
    42, // SMax
    44, // UClamp
    45, // SClamp
    73, // FindILsb
    74, // FindSMsb
    75, // FindUMsb
];

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

/// Every check a fragment shader's module (`bytes`) must pass before the GPU backend runs it:
/// [`program_module`] as a `Role::Fragment` one.
pub fn fragment_module(bytes: &[u8]) -> Result<(), Vec<String>> {
    program_module(bytes, Role::Fragment)
}

/// Every check a user's shader module (`bytes`, of `role`) must pass before the GPU backend
/// runs it: its entry points are its role's stages, binding what the stage table says; its
/// arithmetic is portable; every float arithmetic result is marked `NoContraction`.
pub fn program_module(bytes: &[u8], role: Role) -> Result<(), Vec<String>> {
    let m = load(bytes).map_err(|e| vec![format!("  not a SPIR-V module: {e}")])?;
    let mut problems = entry_points_of(&m, |info| role.has(info), role != Role::Kernels);
    problems.extend(portable(&m));
    problems.extend(contraction(&m).1);
    if problems.is_empty() { Ok(()) } else { Err(problems) }
}

/// A module from its bytes (little-endian words).
pub fn load(bytes: &[u8]) -> Result<Module, String> {
    let words: Vec<u32> = bytes.as_chunks::<4>().0.iter().map(|&b| u32::from_le_bytes(b)).collect();
    load_words(words).map_err(|e| e.to_string())
}

/// The float arithmetic results that lack `NoContraction`, and how many such results the
/// module has.
pub fn contraction(m: &Module) -> (usize, Vec<String>) {
    let decorated = decorations(m);
    let mut float_types = HashSet::new();
    for t in &m.types_global_values {
        let float = match t.class.opcode {
            Op::TypeFloat => true,
            Op::TypeVector | Op::TypeMatrix => t.operands.first().and_then(Operand::id_ref_any).is_some_and(|c| float_types.contains(&c)),
            _ => false,
        };
        if let (true, Some(id)) = (float, t.result_id) {
            float_types.insert(id);
        }
    }
    let mut checked = 0;
    let mut missing = Vec::new();
    for inst in m.functions.iter().flat_map(|f| f.all_inst_iter()) {
        let (Some(ty), Some(result)) = (inst.result_type, inst.result_id) else { continue };
        if !float_types.contains(&ty) || NOT_ARITHMETIC.contains(&inst.class.opcode) {
            continue;
        }
        checked += 1;
        if !decorated.get(&result).is_some_and(|ds| ds.iter().any(|(d, _)| *d == Decoration::NoContraction)) {
            missing.push(format!("  %{result} = {:?}", inst.class.opcode));
        }
    }
    (checked, missing)
}

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
/// picks: missing or extra entry points, bindings (number → access) and workgroup sizes.
pub fn entry_points(m: &Module, rows: impl Fn(&StageInfo) -> bool) -> Vec<String> {
    entry_points_of(m, rows, false)
}

/// [`entry_points`], where `unread` lets an entry point leave out a binding the table makes
/// read-only: a user's shader that never reads the frame's vertex texture leaves it out of its
/// module (the compiler drops an unused buffer), and a pipeline's layout may hold bindings its
/// shader does not use. The kernels' own module is held to every binding.
pub fn entry_points_of(m: &Module, rows: impl Fn(&StageInfo) -> bool, unread: bool) -> Vec<String> {
    let decorated = decorations(m);
    // Buffer variables: storage or uniform (which the table calls `Access::Uniform`).
    let buffers: HashMap<u32, StorageClass> = m
        .types_global_values
        .iter()
        .filter(|i| i.class.opcode == Op::Variable)
        .filter_map(|i| match i.operands.first() {
            Some(Operand::StorageClass(class @ (StorageClass::StorageBuffer | StorageClass::Uniform))) => Some((i.result_id?, *class)),
            _ => None,
        })
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
            "  {name:?} is not an entry point this module should have (a fragment shader crate takes tileraster-kernels with default-features = false, and makes its entry points with fragment_shader!)"
        ));
    }
    for info in wanted {
        let Some(entry) = entries.get(info.entry_point) else {
            problems.push(format!("  no entry point {:?} (stage {})", info.entry_point, info.name));
            continue;
        };
        let Some(function) = entry.operands.get(1).and_then(Operand::id_ref_any) else { continue };
        // Binding number → access, for every buffer the entry point's interface lists.
        let mut bound = BTreeMap::new();
        for (var, class) in entry.operands[3..].iter().filter_map(Operand::id_ref_any).filter_map(|v| Some((v, *buffers.get(&v)?))) {
            let ds = decorated.get(&var).map(Vec::as_slice).unwrap_or_default();
            let find = |d: Decoration| ds.iter().find(|(k, _)| *k == d).and_then(|(_, ops)| literal(ops));
            if find(Decoration::DescriptorSet) != Some(0) {
                problems.push(format!("  {}: buffer %{var} outside descriptor set 0", info.name));
            }
            let access = match class {
                StorageClass::Uniform => Access::Uniform,
                _ if ds.iter().any(|(k, _)| *k == Decoration::NonWritable) => Access::Read,
                _ => Access::ReadWrite,
            };
            match find(Decoration::Binding) {
                Some(binding) if bound.insert(binding, access).is_some() => problems.push(format!("  {}: binding {binding} twice", info.name)),
                Some(_) => {}
                None => problems.push(format!("  {}: buffer %{var} has no binding", info.name)),
            }
        }
        let mut table: BTreeMap<u32, Access> = info.bindings.iter().enumerate().map(|(k, b)| (k as u32, b.access)).collect();
        if unread {
            table.retain(|k, access| bound.contains_key(k) || !matches!(access, Access::Read | Access::Uniform));
        }
        if bound != table {
            problems.push(format!("  {}: bindings (number → access) {bound:?}, the stage table's {table:?}", info.name));
        }
        let size = m
            .execution_modes
            .iter()
            .find(|e| {
                e.operands.first().and_then(Operand::id_ref_any) == Some(function)
                    && e.operands.get(1) == Some(&Operand::ExecutionMode(ExecutionMode::LocalSize))
            })
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
