//! The point-file fuzz target's check (`fuzz/fuzz_targets/points_check.rs`) without
//! cargo-fuzz: deterministic inputs, random bytes and mangled point files, must never panic,
//! and each must be refused with the file named or give finite points and a consistent TIN.

#[path = "../fuzz/fuzz_targets/points_check.rs"]
mod points_check;

use std::panic::{catch_unwind, AssertUnwindSafe};

#[test]
fn point_files_never_panic_and_are_refused_or_triangulated_consistently() {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let pieces = ["x,y,h\n", "1,2,3\n", "0 0 0\n", "1e308 1 1\n", "NaN,1,2\n", "-0,0,1\n", "3;4;5\n", "#c\n", "\t", ",", " ", "\n", "inf", "7", "\r\n", "\u{fffd}"];
    let (mut refused, mut points, mut triangulated) = (0, 0, 0);
    for k in 0..3000 {
        let mut data = vec![k as u8];
        if k % 3 == 0 {
            data.extend((0..next() % 64).map(|_| next() as u8));
        } else if k % 3 == 1 {
            // Point lines of small numbers (repeats and lines likely), now and then spoiled.
            let separator = [",", ";", " ", "\t"][(next() % 4) as usize];
            for _ in 0..next() % 30 {
                let mut fields: Vec<String> = (0..3).map(|_| (next() % 12).to_string()).collect();
                if next() % 40 == 0 {
                    fields[(next() % 3) as usize] = pieces[(next() % pieces.len() as u64) as usize].trim().to_string();
                }
                data.extend_from_slice(format!("{}\n", fields.join(separator)).as_bytes());
            }
        } else {
            for _ in 0..next() % 40 {
                data.extend_from_slice(pieces[(next() % pieces.len() as u64) as usize].as_bytes());
            }
        }
        match catch_unwind(AssertUnwindSafe(|| points_check::check(&data))) {
            Ok(Ok(points_check::Outcome::Refused)) => refused += 1,
            Ok(Ok(points_check::Outcome::Points(_))) => points += 1,
            Ok(Ok(points_check::Outcome::Triangulated(_))) => triangulated += 1,
            Ok(Err(problem)) => panic!("input {k} {data:?}: {problem}"),
            Err(_) => panic!("input {k} {data:?}: panicked"),
        }
    }
    eprintln!("point files: {refused} refused, {points} parsed but not triangulable, {triangulated} triangulated");
    assert!(refused > 0 && points > 0 && triangulated > 0, "the inputs reach every outcome: {refused}/{points}/{triangulated}");
}
