//! The parser fuzz targets' checks (`fuzz/fuzz_targets/points_check.rs`, `mesh_check.rs`,
//! `las_check.rs`, `part_check.rs`) without cargo-fuzz: deterministic inputs, random bytes and
//! mangled files, must never panic, and each must be refused with the file named or give
//! finite points (and a consistent TIN), a consistent mesh, or a part a mosaic can place.

#[path = "../fuzz/fuzz_targets/las_check.rs"]
mod las_check;
#[path = "../fuzz/fuzz_targets/mesh_check.rs"]
mod mesh_check;
#[path = "../fuzz/fuzz_targets/part_check.rs"]
mod part_check;

// The point-file check comes with the LAS check, which builds on it.
use las_check::points_check;

use std::io::Cursor;
use std::panic::{AssertUnwindSafe, catch_unwind};

/// xorshift64: deterministic bytes.
fn xorshift(mut state: u64) -> impl FnMut() -> u64 {
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    }
}

/// A valid file, mutated: random bytes, cut short, one to four bytes changed (three times in
/// four within its first `head` bytes), or a field of 1 to 8 bytes set to one of `extremes`
/// or to random bits.
fn mutated(seed: &[u8], next: &mut impl FnMut() -> u64, head: usize, extremes: &[u64]) -> Vec<u8> {
    let mut data = seed.to_vec();
    match next() % 5 {
        0 => data = (0..next() % 400).map(|_| next() as u8).collect(),
        1 => data.truncate(next() as usize % seed.len()),
        2 | 3 => {
            for _ in 0..1 + next() % 4 {
                let at = next() as usize % if next().is_multiple_of(4) { data.len() } else { data.len().min(head) };
                data[at] = next() as u8;
            }
        }
        _ => {
            let at = next() as usize % (data.len() - 8);
            let pick = next() as usize % (extremes.len() + 1);
            let value = extremes.get(pick).copied().unwrap_or_else(&mut *next).to_le_bytes();
            let width = [1, 2, 4, 8][(next() % 4) as usize];
            data[at..at + width].copy_from_slice(&value[..width]);
        }
    }
    data
}

/// `check` of input `k`: its outcome, or a failure naming the input and the problem or panic.
fn checked<O>(k: usize, data: &[u8], check: impl FnOnce(&[u8]) -> Result<O, String>) -> O {
    match catch_unwind(AssertUnwindSafe(|| check(data))) {
        Ok(Ok(outcome)) => outcome,
        Ok(Err(problem)) => panic!("input {k} {data:?}: {problem}"),
        Err(_) => panic!("input {k} {data:?}: panicked"),
    }
}

#[test]
fn mesh_files_never_panic_and_are_refused_or_read_consistently() {
    let mut next = xorshift(0x2545_f491_4f6c_dd1d);
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let stl = "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n";
    let mut binary_stl = vec![0u8; 80];
    binary_stl.extend(1u32.to_le_bytes());
    binary_stl.extend([0u8; 12]);
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        binary_stl.extend(v.to_le_bytes());
    }
    binary_stl.extend([0u8; 2]);
    let seeds: [(u8, &[u8]); 4] = [(0, obj.as_bytes()), (1, ply.as_bytes()), (2, stl.as_bytes()), (2, &binary_stl)];
    let (mut refused, mut meshes) = (0, 0);
    for k in 0..4000 {
        // A valid file of each kind, mutated: bytes changed, cut short, or random throughout.
        let (kind, seed) = seeds[k % seeds.len()];
        let mut data = vec![kind];
        match next() % 4 {
            0 => data.extend((0..next() % 200).map(|_| next() as u8)),
            1 => data.extend_from_slice(&seed[..(next() as usize % (seed.len() + 1))]),
            _ => {
                data.extend_from_slice(seed);
                for _ in 0..1 + next() % 4 {
                    let at = 1 + (next() as usize % (data.len() - 1).max(1));
                    if at < data.len() {
                        data[at] = next() as u8;
                    }
                }
            }
        }
        match checked(k, &data, mesh_check::check) {
            mesh_check::Outcome::Refused => refused += 1,
            mesh_check::Outcome::Mesh(_) => meshes += 1,
        }
    }
    eprintln!("mesh files: {refused} refused, {meshes} read");
    assert!(refused > 0 && meshes > 0, "the inputs reach both outcomes: {refused}/{meshes}");
}

#[test]
fn point_files_never_panic_and_are_refused_or_triangulated_consistently() {
    let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
    let pieces =
        ["x,y,h\n", "1,2,3\n", "0 0 0\n", "1e308 1 1\n", "NaN,1,2\n", "-0,0,1\n", "3;4;5\n", "#c\n", "\t", ",", " ", "\n", "inf", "7", "\r\n", "\u{fffd}"];
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
                if next().is_multiple_of(40) {
                    fields[(next() % 3) as usize] = pieces[(next() % pieces.len() as u64) as usize].trim().to_string();
                }
                data.extend_from_slice(format!("{}\n", fields.join(separator)).as_bytes());
            }
        } else {
            for _ in 0..next() % 40 {
                data.extend_from_slice(pieces[(next() % pieces.len() as u64) as usize].as_bytes());
            }
        }
        match checked(k, &data, points_check::check) {
            points_check::Outcome::Refused => refused += 1,
            points_check::Outcome::Points(_) => points += 1,
            points_check::Outcome::Triangulated(_) => triangulated += 1,
        }
    }
    eprintln!("point files: {refused} refused, {points} parsed but not triangulable, {triangulated} triangulated");
    assert!(refused > 0 && points > 0 && triangulated > 0, "the inputs reach every outcome: {refused}/{points}/{triangulated}");
}

/// LAS 1.`minor` bytes of `n` points in point `format`, LASzip-compressed or not.
fn las_file(minor: u8, format: u8, compressed: bool, n: usize) -> Vec<u8> {
    let mut builder = las::Builder::from((1, minor));
    builder.point_format = las::point::Format::new(format).unwrap();
    builder.point_format.is_compressed = compressed;
    builder.transforms.x = las::Transform { scale: 0.01, offset: 500.0 };
    builder.transforms.y = las::Transform { scale: 0.01, offset: 700.0 };
    let mut writer = las::Writer::new(Cursor::new(Vec::new()), builder.into_header().unwrap()).unwrap();
    let format = *writer.header().point_format();
    for k in 0..n {
        let (x, y, z) = (500.0 + (k % 4) as f64 * 2.5, 700.0 + (k / 4) as f64 * 1.5 + (k % 3) as f64 * 0.25, (k * 7 % 11) as f64 * 0.5);
        let (gps_time, color) = (format.has_gps_time.then_some(k as f64), format.has_color.then_some(las::Color::new(9, 8, 7)));
        writer.write_point(las::Point { x, y, z, gps_time, color, ..Default::default() }).unwrap();
    }
    writer.into_inner().unwrap().into_inner()
}

#[test]
fn las_files_never_panic_and_are_refused_or_read_consistently() {
    let mut next = xorshift(0xd1b5_4a32_d192_ed03);
    let seeds = [
        las_file(2, 0, false, 9),
        las_file(2, 1, true, 12),
        las_file(2, 3, true, 10),
        las_file(4, 1, false, 11),
        las_file(4, 6, true, 13),
        las_file(4, 7, false, 8),
    ];
    let (mut refused, mut points, mut triangulated) = (0, 0, 0);
    for k in 0..4000 {
        // Byte changes mostly in the header, VLRs and first records.
        let data = mutated(&seeds[k % seeds.len()], &mut next, 420, &[u64::MAX, u32::MAX as u64, 1 << 40, 0]);
        match checked(k, &data, las_check::check) {
            las_check::Outcome::Refused => refused += 1,
            las_check::Outcome::Points(_) => points += 1,
            las_check::Outcome::Triangulated(_) => triangulated += 1,
        }
    }
    eprintln!("LAS/LAZ files: {refused} refused, {points} read but not triangulable, {triangulated} triangulated");
    assert!(refused > 0 && points + triangulated > 0, "the inputs reach both outcomes: {refused}/{points}/{triangulated}");
}

/// Small GeoTIFF parts as `tileraster` writes them: strips, tiles with deflate, BigTIFF with
/// a CRS, UInt32 owners.
fn part_files() -> Vec<Vec<u8>> {
    use tileraster::{Grid, Window};
    use tileraster_io::{BigTiff, Compression, GeoTiffOptions, GeoTiffWriter, Sample};
    let dir = std::env::temp_dir().join(format!("tileraster-fuzz-parts-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let grid = Grid::new(500_000.0, 500_300.0, 5_000_000.0, 5_000_200.0, 30, 20);
    let cases = [
        (Sample::Float32 { nodata: -9999.0 }, GeoTiffOptions::default()),
        (Sample::Float32 { nodata: f32::NAN }, GeoTiffOptions { tiled: true, compress: Compression::Deflate, epsg: Some(32633), ..Default::default() }),
        (Sample::UInt32, GeoTiffOptions { bigtiff: BigTiff::Yes, epsg: Some(4326), ..Default::default() }),
    ];
    let files = cases
        .iter()
        .map(|(sample, options)| {
            let path = dir.join("part.tif");
            let mut w = GeoTiffWriter::create(&path, &grid, Window { x0: 4, y0: 6, width: 12, height: 9 }, *sample, options).unwrap();
            w.write_rows(&(0..108u32).collect::<Vec<_>>()).unwrap();
            w.finish().unwrap();
            std::fs::read(&path).unwrap()
        })
        .collect();
    std::fs::remove_dir_all(&dir).ok();
    files
}

#[test]
fn mosaic_parts_never_panic_and_are_refused_or_placed() {
    let mut next = xorshift(0x6a09_e667_f3bc_c908);
    let seeds = part_files();
    let (mut refused, mut parts) = (0, 0);
    for k in 0..3000 {
        let extremes = [u64::MAX, u32::MAX as u64, 1 << 40, 0, f64::NAN.to_bits(), (-1.0f64).to_bits()];
        let data = mutated(&seeds[k % seeds.len()], &mut next, usize::MAX, &extremes);
        match checked(k, &data, part_check::check) {
            part_check::Outcome::Refused => refused += 1,
            part_check::Outcome::Part => parts += 1,
        }
    }
    eprintln!("mosaic parts: {refused} refused, {parts} placed");
    assert!(refused > 0 && parts > 0, "the inputs reach both outcomes: {refused}/{parts}");
}
