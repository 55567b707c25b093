//! Rasterisation time per backend and mode, side by side in one run: the seed design's
//! two-triangle plane at 512² to 8192², a 100k-point terrain TIN onto 4096², micro-triangles
//! of 0.25, 1 and 4 px, slivers and a rough TIN at UTM coordinates. The GPU rows need a Vulkan
//! adapter (lavapipe counts); without one they are left out and the reason is printed.
//! `cargo xtask bench-report` runs a reduced set with errors and peers and writes the report.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use tileraster::{Backend, Grid, Mode, Params, Scene, rasterise};
use tileraster_testkit::scenes;

fn backends() -> Vec<Backend> {
    match tileraster::gpu_adapter() {
        Ok(adapter) => {
            eprintln!("GPU adapter: {adapter}");
            vec![Backend::Cpu, Backend::Gpu]
        }
        Err(e) => {
            eprintln!("GPU rows left out: {e}");
            vec![Backend::Cpu]
        }
    }
}

fn cases() -> Vec<(String, Scene, Grid, &'static [Mode])> {
    let all: &'static [Mode] = &Mode::ALL;
    let exact: &'static [Mode] = &[Mode::Exact];
    let mut cases = Vec::new();
    for n in [512, 1024, 2048, 4096, 8192] {
        cases.push((format!("plane {n}²"), scenes::sloping_plane(), Grid::new(0.0, 1.0, 0.0, 1.0, n, n), if n == 4096 { all } else { exact }));
    }
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let tin = scenes::delaunay_terrain(x0, y0, 10_000.0, 10_000.0, 315, 315, 2026);
    cases.push(("terrain TIN 100k points 4096²".into(), tin, Grid::new(x0, x0 + 10_000.0, y0, y0 + 10_000.0, 4096, 4096), all));
    for px in [0.25, 1.0, 4.0] {
        let (scene, grid) = scenes::micro_triangles(512, px, 7);
        cases.push((format!("micro-triangles {px} px 512²"), scene, grid, exact));
    }
    let sliver_grid = Grid::new(0.0, 1024.0, 0.0, 256.0, 1024, 256);
    cases.push(("slivers 0.1 px".into(), scenes::sliver_wedge(&sliver_grid, 2000, 0.1, 4), sliver_grid, exact));
    let utm = scenes::delaunay_terrain(x0, y0, 2000.0, 2000.0, 200, 200, 13);
    cases.push(("UTM TIN 2048²".into(), utm, Grid::new(x0, x0 + 2000.0, y0, y0 + 2000.0, 2048, 2048), exact));
    cases
}

fn bench(c: &mut Criterion) {
    let backends = backends();
    for (name, scene, grid, modes) in cases() {
        let mut group = c.benchmark_group(&name);
        group.sample_size(10).throughput(Throughput::Elements(grid.pixel_count()));
        for &mode in modes {
            let params = Params::new(grid).with_mode(mode);
            for &backend in &backends {
                group.bench_with_input(BenchmarkId::new(backend.name(), mode.name()), &backend, |b, &backend| {
                    b.iter(|| rasterise(&scene, &params, backend).expect("rasterise"))
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
