//! `cargo xtask fingerprint`: one line per scene × mode with two hashes: of what `prepare`
//! made (every prepared triangle's bytes, the snapping, the counts, the overlap proof), and of
//! the CPU backend's raster. Work that must change no output bit is checked by running it
//! before and after and comparing the second column (and the first, where the preparation
//! itself must not change).

use std::time::Instant;
use tileraster::{Backend, Grid, Mode, Params, Scene, prepare, rasterise};
use tileraster_testkit::scenes;

/// FNV-1a, 64 bits: stable across builds and toolchains, unlike `std`'s hasher.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

fn cases() -> Vec<(String, Scene, Grid)> {
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let mut cases = Vec::new();
    for px in [0.25, 1.0, 4.0] {
        let (scene, grid) = scenes::micro_triangles(512, px, 7);
        cases.push((format!("micro-triangles {px} px, 512²"), scene, grid));
    }
    let tin = scenes::delaunay_terrain(x0, y0, 10_000.0, 10_000.0, 315, 315, 2026);
    cases.push(("TIN 99856 points, 4096²".into(), tin.clone(), Grid::new(x0, x0 + 10_000.0, y0, y0 + 10_000.0, 4096, 4096)));
    cases.push(("TIN 99856 points, offset 1000×700".into(), tin, Grid::new(x0 + 13.3, x0 + 9_000.0, y0 - 20.0, y0 + 7_000.0, 1000, 700)));
    let grid = Grid::new(0.0, 100.0, 0.0, 100.0, 333, 257);
    cases.push(("soup of 5000".into(), scenes::triangle_soup(&grid, 5000, 30.0, 9), grid));
    cases.push(("sliver wedge".into(), scenes::sliver_wedge(&grid, 800, 0.02, 4), grid));
    cases.push(("fan".into(), scenes::fan(&grid, 60, 60, 90, 40.0, 3), grid));
    cases
}

pub fn run() -> Result<String, String> {
    let mut out = String::new();
    for (name, scene, grid) in cases() {
        for mode in Mode::ALL {
            let params = Params::new(grid).with_mode(mode);
            let start = Instant::now();
            let prepared = prepare(&scene, &params, None).map_err(|e| e.to_string())?;
            let seconds = start.elapsed().as_secs_f64();
            let mut h = Fnv::new();
            for t in &prepared.triangles {
                h.bytes(bytemuck::bytes_of(t));
            }
            let rows = prepared.overlap_free_rows.clone().map_or((u32::MAX, u32::MAX), |r| (r.start, r.end));
            for v in [prepared.snap_bits as u64, prepared.culled as u64, prepared.degenerate as u64, rows.0 as u64, rows.1 as u64] {
                h.bytes(&v.to_le_bytes());
            }
            let raster = rasterise(&scene, &params, Backend::Cpu).map_err(|e| e.to_string())?;
            let mut r = Fnv::new();
            r.bytes(bytemuck::cast_slice(&raster.values));
            out.push_str(&format!("{:016x} {:016x}  {name} [{}]\n", h.0, r.0, mode.name()));
            eprintln!("{name} [{}]: prepare {:.1} ms", mode.name(), seconds * 1e3);
        }
    }
    Ok(out)
}
