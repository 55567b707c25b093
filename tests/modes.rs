//! Every value mode keeps the promise `docs/numeric-contract.md` makes for it, cell by cell,
//! against an f64 evaluation on the cell's own owner triangle (so no cell is excused):
//!
//! - `exact`: `|v − p| ≤ 0.5 ulp(p) + 2^-32·S`, `p` the plane through the unsnapped vertices;
//! - `plane-f32`: `|v − p| ≤ 2^-21·S + (2 + Δi + Δj)·2^-150`, the same `p`;
//! - `barycentric`: `|v − q| ≤ 2^-21·max|zk|`, `q` the plane through the snapped vertices;
//!
//! with `S = max|zk| + |∂z/∂i|·W + |∂z/∂j|·H` over the triangle's `W × H` pixel bounding box.
//! And the CPU and GPU rasters are bit-identical in every mode: every adapter for `exact`; for
//! the `f32` modes, every adapter the backend's check accepts (it refuses the others with a
//! typed error), and the adapter the tests run on must be one.

mod common;

use tileraster::{Backend, Grid, Mode, Outputs, Params, Scene, prepare, rasterise};
use tileraster_testkit::reference::{degenerate, plane_at, ulps};
use tileraster_testkit::scenes;

/// Per-pixel gradients and pixel bounding box of a triangle given in raster space.
fn raster_plane(p: [[f64; 2]; 3], z: [f64; 3]) -> (f64, f64, f64, f64) {
    let (au, av, az) = (p[1][0] - p[0][0], p[1][1] - p[0][1], z[1] - z[0]);
    let (bu, bv, bz) = (p[2][0] - p[0][0], p[2][1] - p[0][1], z[2] - z[0]);
    let det = au * bv - av * bu;
    let gi = (az * bv - av * bz) / det;
    let gj = (au * bz - az * bu) / det;
    let w = p.iter().map(|q| q[0]).fold(f64::MIN, f64::max) - p.iter().map(|q| q[0]).fold(f64::MAX, f64::min) + 1.0;
    let h = p.iter().map(|q| q[1]).fold(f64::MIN, f64::max) - p.iter().map(|q| q[1]).fold(f64::MAX, f64::min) + 1.0;
    (gi, gj, w, h)
}

/// Snapped vertices (raster space) of every prepared triangle, by scene index.
fn snapped_vertices(scene: &Scene, params: &Params) -> Vec<Option<[[f64; 2]; 3]>> {
    let prepared = prepare(scene, params, None).expect("prepare");
    let unit = (1u64 << prepared.snap_bits) as f64;
    let mut out = vec![None; scene.triangles.len()];
    for t in &prepared.triangles {
        out[t.index as usize] = Some([0, 1, 2].map(|k| [t.x[k] as f64 / unit, t.y[k] as f64 / unit]));
    }
    out
}

/// Checks every covered cell against `mode`'s bound; returns the largest share of the bound
/// any cell used, so the caller can print how tight it is.
fn check_bound(name: &str, scene: &Scene, grid: Grid, mode: Mode, backend: Backend) -> f64 {
    let params = Params::new(grid).with_mode(mode).with_outputs(Outputs { owner: true, coverage: false, tiles: false });
    let raster = rasterise(scene, &params, backend).unwrap_or_else(|e| panic!("{name}: {e}"));
    let owners = raster.owner.as_ref().expect("owner asked for");
    let snapped = snapped_vertices(scene, &params);
    let mut worst: f64 = 0.0;
    let mut checked = 0u64;
    for j in 0..grid.height {
        for i in 0..grid.width {
            let k = (j * grid.width + i) as usize;
            let t = owners[k];
            if t == u32::MAX {
                continue;
            }
            let tri = scene.triangles[t as usize];
            assert!(!degenerate(scene, tri), "{name}: a degenerate triangle owns ({i}, {j})");
            let z = tri.map(|c| scene.vertices[c as usize][2]);
            let zmax = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let unsnapped = tri.map(|c| {
                let (u, v) = grid.to_raster(scene.vertices[c as usize][0], scene.vertices[c as usize][1]);
                [u, v]
            });
            let (gi, gj, w, h) = raster_plane(unsnapped, z);
            let s = zmax + gi.abs() * w + gj.abs() * h;
            let v = raster.values[k];
            let (want, bound) = match mode {
                Mode::Exact => {
                    let (x, y) = grid.cell_centre(i, j);
                    let p = plane_at(scene, tri, x, y);
                    (p, 0.5 * ulp_of(p) + 2f64.powi(-32) * s)
                }
                Mode::PlaneF32 => {
                    let (x, y) = grid.cell_centre(i, j);
                    // The absolute term of subnormal coefficients (docs/numeric-contract.md §6):
                    // beside 2^-21·S it matters only where heights are subnormal.
                    (plane_at(scene, tri, x, y), 2f64.powi(-21) * s + (2.0 + w + h) * 2f64.powi(-150))
                }
                Mode::Barycentric => {
                    // Preparation may have swapped two corners to orient the triangle: pair each
                    // snapped vertex with the unsnapped one it came from (the nearest).
                    let p = snapped[t as usize].expect("owner was prepared");
                    let z = p.map(|q| {
                        let d = |u: &[f64; 2]| (u[0] - q[0]).powi(2) + (u[1] - q[1]).powi(2);
                        let nearest = (0..3).min_by(|&a, &b| d(&unsnapped[a]).total_cmp(&d(&unsnapped[b]))).unwrap();
                        z[nearest]
                    });
                    let (sgi, sgj, _, _) = raster_plane(p, z);
                    let q = z[0] + sgi * (i as f64 + 0.5 - p[0][0]) + sgj * (j as f64 + 0.5 - p[0][1]);
                    (q, 2f64.powi(-21) * zmax)
                }
            };
            let err = (v as f64 - want).abs();
            assert!(
                err <= bound,
                "{name} [{} {}]: cell ({i}, {j}) of triangle {t} is {v:e}, the f64 value is {want:e}: error {err:e} > bound {bound:e} ({:.2} ulp)",
                mode.name(),
                backend.name(),
                ulps(v, want)
            );
            worst = worst.max(if bound > 0.0 { err / bound } else { 0.0 });
            checked += 1;
        }
    }
    assert!(checked > 0, "{name}: no covered cell was checked");
    worst
}

/// The spacing of `f32` values at `p` (the subnormal spacing below the normal range).
fn ulp_of(p: f64) -> f64 {
    let r = p.abs().max(f32::MIN_POSITIVE as f64);
    2f64.powi(r.log2().floor() as i32 - 23).max(2f64.powi(-149))
}

fn cases() -> Vec<(&'static str, Scene, Grid)> {
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let mut rough = scenes::terrain(x0, y0, 800.0, 800.0, 60, 60, 13);
    let mut rng = scenes::Rng::new(13);
    for v in &mut rough.vertices {
        v[2] = rng.range(0.0, 1000.0);
    }
    let lattice_grid = Grid::new(0.0, 300.0, 0.0, 200.0, 300, 200);
    let sliver_grid = Grid::new(0.0, 400.0, 0.0, 100.0, 400, 100);
    let soup_grid = Grid::new(0.0, 256.0, 0.0, 256.0, 256, 256);
    vec![
        ("utm terrain", scenes::terrain(x0, y0, 3000.0, 3000.0, 80, 80, 21), Grid::new(x0, x0 + 3000.0, y0, y0 + 3000.0, 600, 600)),
        ("rough utm tin", rough, Grid::new(x0, x0 + 800.0, y0, y0 + 800.0, 500, 500)),
        ("centre lattice", scenes::centre_lattice(&lattice_grid, 7, 3), lattice_grid),
        ("sliver wedge", scenes::sliver_wedge(&sliver_grid, 300, 0.02, 4), sliver_grid),
        ("triangle soup", scenes::triangle_soup(&soup_grid, 800, 40.0, 9), soup_grid),
    ]
}

fn check_mode(mode: Mode) {
    let gpu = common::gpu_or_skip(&format!("bounds of {}", mode.name()));
    for (name, scene, grid) in cases() {
        let mut backends = vec![Backend::Cpu];
        if gpu {
            backends.push(Backend::Gpu);
        }
        for backend in backends {
            let worst = check_bound(name, &scene, grid, mode, backend);
            eprintln!("{name} [{} {}]: worst cell used {:.3} of the bound", mode.name(), backend.name(), worst);
        }
    }
}

#[test]
fn exact_mode_is_within_half_an_ulp_plus_quantisation() {
    check_mode(Mode::Exact);
}

#[test]
fn plane_f32_mode_is_within_its_bound() {
    check_mode(Mode::PlaneF32);
}

#[test]
fn barycentric_mode_is_within_its_bound() {
    check_mode(Mode::Barycentric);
}

/// Bit-identical in every mode, with every skip variant: the `f32` modes too, since the
/// adapter the tests run on must pass the backend's check (next test).
#[test]
fn cpu_and_gpu_agree_in_every_mode() {
    for (name, scene, grid) in cases() {
        for mode in Mode::ALL {
            let params = Params::new(grid).with_mode(mode).with_outputs(Outputs { owner: true, coverage: true, tiles: false });
            common::assert_parity(&format!("{name} [{}]", mode.name()), &scene, &params);
        }
    }
}

/// The `f32` modes run on this adapter with the CPU backend's bits. The backend checks each
/// adapter on a frame of subnormal and rounded arithmetic before its first `f32`-mode frame and
/// refuses the modes where the bits differ; here that frame must be accepted and match.
#[test]
fn f32_modes_are_accepted_on_this_adapter_and_match_the_cpu() {
    let name = "f32_modes_are_accepted_on_this_adapter_and_match_the_cpu";
    if !common::gpu_or_skip(name) {
        return;
    }
    let adapter = tileraster::gpu_adapter().expect("checked above");
    let (scene, grid) = tileraster_gpu::f32_probe();
    for mode in [Mode::PlaneF32, Mode::Barycentric] {
        let params = Params::new(grid).with_mode(mode);
        let cpu = rasterise(&scene, &params, Backend::Cpu).expect("CPU backend");
        let gpu = rasterise(&scene, &params, Backend::Gpu).unwrap_or_else(|e| panic!("{adapter} ({}): {e}", adapter.float_controls));
        common::assert_same_bits(&format!("{name}, {mode:?} on {adapter}"), &cpu, &gpu);
    }
}
