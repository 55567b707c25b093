//! What per-face materials cost a frame: the 100,352-triangle terrain filling 1920 × 1080 under
//! `Shading::Pbr`, one surface for the whole mesh against four materials taken face by face
//! (each face's surface copied into its triangles by the assembly, each fragment's material
//! read from the frame's table), on the CPU backend, a prepared mesh's frames.
//!
//! `cargo bench --bench materials`

use criterion::{Criterion, criterion_group, criterion_main};
use tileraster::Backend;
use tileraster::render::{Camera, Material, Mesh, PreparedMesh, Projection, RenderParams, Shading};
use tileraster_testkit::meshes;

fn terrain_params() -> RenderParams {
    let camera = Camera {
        eye: [50.0, -40.0, 60.0],
        target: [50.0, 50.0, 0.0],
        up: [0.0, 0.0, 1.0],
        projection: Projection::Perspective { fov_deg: 60.0 },
        near: 1.0,
        far: 400.0,
    };
    RenderParams { shading: Shading::Pbr, ..RenderParams::new(1920, 1080, camera.view_projection(1920, 1080).unwrap()) }
}

fn bench(c: &mut Criterion) {
    let terrain = meshes::terrain(224, 100.0, 12.0);
    let faces = terrain.triangles.len() as u32;
    let materials = vec![
        Material { metallic: 0.0, roughness: 0.5, ..Material::default() },
        Material { metallic: 1.0, roughness: 0.3, ..Material::default() },
        Material { metallic: 0.2, roughness: 0.8, double_sided: true, ..Material::default() },
        Material { metallic: 0.5, roughness: 0.5, emissive: [0.05, 0.02, 0.0], ..Material::default() },
    ];
    let meshes = [
        ("one surface", terrain.clone()),
        ("four materials by face", Mesh { materials, face_materials: Some((0..faces).map(|f| f % 4).collect()), ..terrain }),
    ];
    let params = terrain_params();
    let mut group = c.benchmark_group(format!("materials/{faces} triangles, 1920x1080, pbr"));
    group.sample_size(10);
    // `MATERIALS_FIRST=1` measures the four materials first (the order shows in the figures
    // on a shared machine).
    let mut meshes = meshes.to_vec();
    if std::env::var("MATERIALS_FIRST").as_deref() == Ok("1") {
        meshes.reverse();
    }
    for (name, mesh) in meshes {
        let mut prepared = PreparedMesh::new(mesh).unwrap();
        group.bench_function(name, |b| b.iter(|| prepared.render(&params, Backend::Cpu).unwrap()));
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
