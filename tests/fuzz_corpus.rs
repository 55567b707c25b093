//! The fuzz target's decoder and checks (`fuzz/fuzz_targets/decode.rs`) without cargo-fuzz:
//! a few thousand deterministic pseudo-random byte strings, each decoded into a small scene,
//! grid and value mode and rasterised on the CPU, must give a typed error or a raster whose
//! cells are nodata or finite, with owner and coverage agreeing — and never panic.

#[path = "../fuzz/fuzz_targets/decode.rs"]
mod decode;

use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};

/// xorshift64: deterministic bytes.
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

/// Run every input; panic listing the failures, two of each kind with their bytes and what they
/// decode to.
/// Returns how many inputs came out how (`"covered"`: rasterised with a covered cell).
fn run_all(inputs: impl Iterator<Item = (String, Vec<u8>)>) -> BTreeMap<String, usize> {
    let mut failures: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut outcomes = BTreeMap::new();
    let mut count = 0;
    for (name, bytes) in inputs {
        count += 1;
        let case = decode::decode(&bytes);
        let outcome = catch_unwind(AssertUnwindSafe(|| decode::check(&case))).unwrap_or_else(|panic| {
            let text = panic.downcast_ref::<String>().cloned().or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()));
            Err(format!("panic: {}", text.unwrap_or_default()))
        });
        let what = match outcome {
            Ok(decode::Outcome::Refused(error)) => {
                *outcomes.entry(error).or_default() += 1;
                continue;
            }
            Ok(decode::Outcome::Rasterised(covered)) => {
                *outcomes.entry(if covered > 0 { "covered" } else { "empty" }.to_string()).or_default() += 1;
                continue;
            }
            Err(what) => what,
        };
        {
            // Group by the message without its numbers, up to the owner's vertices.
            let kind: String = what.split(" [[").next().unwrap_or_default().chars().filter(|c| !c.is_ascii_digit()).collect();
            let list = failures.entry(kind).or_default();
            if list.len() < 2 {
                list.push(format!("{name}: {what}\n    input: {bytes:02x?}\n    decoded: {case:?}"));
            } else {
                list.push(name);
            }
        }
    }
    eprintln!("outcomes: {outcomes:?}");
    if !failures.is_empty() {
        let total: usize = failures.values().map(Vec::len).sum();
        let mut report = format!("{total} of {count} inputs fail:\n");
        for (kind, list) in &failures {
            report += &format!("\n== {kind} ({} inputs)\n", list.len());
            for line in list.iter().take(2) {
                report += &format!("  {line}\n");
            }
        }
        panic!("{report}");
    }
    outcomes
}

#[test]
fn pseudo_random_inputs() {
    let mut rng = XorShift(0x9e37_79b9_7f4a_7c15);
    let inputs = (0..4000).map(|n| {
        let len = 8 + rng.next() as usize % 2000;
        let bytes: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
        (format!("pseudo-random input {n}"), bytes)
    });
    let outcomes = run_all(inputs);
    // The decoder must reach the rasteriser, not only its validation.
    let covered = outcomes.get("covered").copied().unwrap_or(0);
    assert!(covered >= 400, "only {covered} of 4000 inputs rasterised to a covered cell: {outcomes:?}");
}
