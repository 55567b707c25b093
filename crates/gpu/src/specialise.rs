//! Specialisation constants, set in the module itself.
//!
//! The shading entry points take the frame's `ShadeVariant` as specialisation constant
//! `ShadeVariant::SPEC_ID`; `fine_raster` the frame's value mode and its way through the bins
//! as `HeightProgram::MODE_SPEC_ID`, which is also the way of `fine_depth` and `fine_samples`
//! (`fine::WALK_SPEC_ID`, with the frame's depth test: `DepthProgram::spec_bits`) and whether
//! `bin_fill` writes its keys (`bin::KEYS_SPEC_ID`): each pipeline is built from its own copy
//! of the module. wgpu hands a passthrough module to the driver without
//! specialisation info, so the backend writes the value into the module instead: it becomes the
//! constant's default, which the driver then uses as it would a specialised value, folding the
//! branches the frame does not take out of the pipeline.

/// SPIR-V opcodes and the decoration this reads.
const OP_DECORATE: u32 = 71;
const OP_SPEC_CONSTANT: u32 = 50;
const DECORATION_SPEC_ID: u32 = 1;
/// Words before the first instruction.
const HEADER_WORDS: usize = 5;

/// `module` (SPIR-V words) with every 32-bit specialisation constant decorated `SpecId spec_id`
/// set to `value`; how many it set.
pub fn specialise(module: &[u32], spec_id: u32, value: u32) -> Result<(Vec<u32>, usize), String> {
    let mut words = module.to_vec();
    let instructions = instructions(&words)?;
    let ids: Vec<u32> = instructions
        .iter()
        .filter(|&&(at, op, len)| op == OP_DECORATE && len == 4 && words[at + 2] == DECORATION_SPEC_ID && words[at + 3] == spec_id)
        .map(|&(at, ..)| words[at + 1])
        .collect();
    let mut set = 0;
    for &(at, op, len) in &instructions {
        // OpSpecConstant <result type> <result id> <value> (one word for 32 bits).
        if op == OP_SPEC_CONSTANT && len == 4 && ids.contains(&words[at + 2]) {
            words[at + 3] = value;
            set += 1;
        }
    }
    Ok((words, set))
}

/// Every instruction of a module: where it starts, its opcode and its length in words.
fn instructions(words: &[u32]) -> Result<Vec<(usize, u32, usize)>, String> {
    if words.len() < HEADER_WORDS || words[0] != 0x0723_0203 {
        return Err("not a SPIR-V module".into());
    }
    let mut out = Vec::new();
    let mut at = HEADER_WORDS;
    while at < words.len() {
        let (len, op) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if len == 0 || at + len > words.len() {
            return Err(format!("a SPIR-V instruction at word {at} runs past the module's end"));
        }
        out.push((at, op, len));
        at += len;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tileraster_kernels::abi::ShadeVariant;

    #[test]
    fn the_shading_entry_points_take_the_variant() {
        for module in [crate::KERNELS_SPV, crate::KERNELS_FLOAT_CONTROLS_SPV] {
            let words: Vec<u32> = bytemuck::pod_collect_to_vec(module);
            let (patched, set) = specialise(&words, ShadeVariant::SPEC_ID, 0x8000_1234).unwrap();
            // shade and fine_samples take the variant (the compiler may merge their two
            // identical constants into one).
            assert!(set >= 1, "no constant with the variant's SpecId");
            let changed: Vec<usize> = (0..words.len()).filter(|&k| words[k] != patched[k]).collect();
            assert_eq!(changed.len(), set, "only the constants' values change");
            assert!(changed.iter().all(|&k| patched[k] == 0x8000_1234 && words[k] == ShadeVariant::GENERIC.0));
            let (_, modes) = specialise(&words, tileraster_kernels::programs::height::HeightProgram::MODE_SPEC_ID, 1).unwrap();
            assert_eq!(modes, 1, "fine_raster's value mode (one constant, which fine_depth and bin_fill share)");
            assert_eq!(specialise(&words, 7, 1).unwrap().1, 0, "no other SpecId");
        }
        assert!(specialise(&[1, 2, 3], 0, 0).is_err());
    }
}
