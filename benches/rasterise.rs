//! Rasterisation time per backend, side by side in one run: the demo's terrain TIN and the
//! two-triangle sloping plane. The GPU rows need a Vulkan adapter (lavapipe counts); without
//! one they are left out and the reason is printed.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use tileraster::{rasterise, scenes, Backend, Grid, Params, Scene};

fn plane() -> Scene {
    Scene::new(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 10.0], [1.0, 1.0, 30.0], [0.0, 1.0, 20.0]],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

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

fn bench(c: &mut Criterion) {
    let terrain = scenes::terrain(500_000.0, 5_000_000.0, 10_000.0, 10_000.0, 200, 200, 2026);
    let cases = [
        ("terrain 80k triangles", terrain, Grid::new(500_000.0, 510_000.0, 5_000_000.0, 5_010_000.0, 1024, 1024)),
        ("plane 2 triangles", plane(), Grid::new(0.0, 1.0, 0.0, 1.0, 2048, 2048)),
    ];
    let backends = backends();
    for (name, scene, grid) in &cases {
        let mut group = c.benchmark_group(*name);
        group.sample_size(10).throughput(Throughput::Elements(grid.pixel_count()));
        let params = Params::new(*grid);
        for &backend in &backends {
            group.bench_with_input(BenchmarkId::new(backend.name(), format!("{}²", grid.width)), &backend, |b, &backend| {
                b.iter(|| rasterise(scene, &params, backend).expect("rasterise"))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
