//! Helpers shared by the integration tests.
#![allow(dead_code)]

use tileraster::{Backend, Error, Params, Raster, Scene, Skip, Skips, rasterise};
use tileraster_cpu::FinePath;

/// Whether GPU tests should run. Without an adapter they fail loudly, unless the user asked
/// to skip them with `TILERASTER_SKIP_GPU=1`, in which case the skip is printed.
pub fn gpu_or_skip(test: &str) -> bool {
    match tileraster::gpu_adapter() {
        Ok(_) => true,
        Err(e) if std::env::var("TILERASTER_SKIP_GPU").as_deref() == Ok("1") => {
            // Straight to the process's stderr: the test harness would swallow `eprintln!`
            // of a passing test, and a skip must be seen.
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "SKIPPED (TILERASTER_SKIP_GPU=1): {test}: {e}");
            false
        }
        Err(e) => panic!(
            "{test}: the GPU backend is unavailable: {e}\n\
             To skip GPU tests deliberately, set TILERASTER_SKIP_GPU=1."
        ),
    }
}

/// Every way the tests run the pipeline: with all of its skips, with none, and with each
/// one turned off alone. No skip may change a bit.
pub fn skip_variants() -> Vec<(String, Skips)> {
    let mut out = vec![("all skips".to_string(), Skips::ALL), ("no skips".to_string(), Skips::NONE)];
    out.extend(Skip::ALL.iter().map(|&skip| (format!("all skips but {skip}"), Skips::all_but(skip))));
    out
}

/// Panic with the first differing pixels unless `a` and `b` are bit-identical.
pub fn assert_same_bits(what: &str, a: &Raster, b: &Raster) {
    let (count, first) = a.compare_bits(b, 12);
    if count > 0 {
        let list: Vec<String> = first.iter().map(|d| format!("  {d}")).collect();
        panic!("{what}: rasters differ in {count} cells; first ones:\n{}", list.join("\n"));
    }
}

/// Rasterise on both backends, with every skip variant, and require bit-identical results
/// everywhere and equal statistics on both backends; print the first differing pixels with
/// both values if they are not. Returns the rasters with all skips.
pub fn assert_parity(name: &str, scene: &Scene, params: &Params) -> Option<(Raster, Raster)> {
    assert_plain_twin(name, scene, params);
    if !gpu_or_skip(name) {
        return None;
    }
    let mut first: Option<(Raster, Raster)> = None;
    for (variant, skips) in skip_variants() {
        let params = params.with_skips(skips);
        let cpu = rasterise(scene, &params, Backend::Cpu).unwrap_or_else(|e| panic!("{name}, {variant}: CPU backend failed: {e}"));
        let gpu = rasterise(scene, &params, Backend::Gpu).unwrap_or_else(|e| panic!("{name}, {variant}: GPU backend failed: {e}"));
        assert_same_bits(&format!("{name}, {variant}, cpu vs gpu"), &cpu, &gpu);
        assert_eq!(cpu.stats, gpu.stats, "{name}, {variant}: the backends' statistics differ");
        match &first {
            None => first = Some((cpu, gpu)),
            Some((reference, _)) => assert_same_bits(&format!("{name}, all skips vs {variant}"), reference, &cpu),
        }
    }
    first
}

/// The CPU backend's fine-raster fast paths (row spans, whole and overlap-free tiles, wide
/// vectors), all together and each alone, against its plain twin, which runs each tile as the
/// GPU runs its workgroup: the same bits and statistics, with every skip variant.
pub fn assert_plain_twin(name: &str, scene: &Scene, params: &Params) {
    for (variant, skips) in skip_variants() {
        let prepared = tileraster::prepare(scene, &params.with_skips(skips), None).unwrap_or_else(|e| panic!("{name}, {variant}: {e}"));
        let run = |path| tileraster_cpu::rasterise_with(&prepared, path).unwrap_or_else(|e| panic!("{name}, {variant}, {path:?}: {e}"));
        let plain = run(FinePath::Plain);
        for path in FinePath::HEIGHTFIELD {
            let fast = run(path);
            assert_same_bits(&format!("{name}, {variant}, CPU {path:?} vs plain twin"), &fast, &plain);
            assert_eq!(fast.stats, plain.stats, "{name}, {variant}: the statistics of {path:?} and the plain twin differ");
        }
    }
}

/// Run on the CPU, expecting success.
pub fn cpu(scene: &Scene, params: &Params) -> Raster {
    rasterise(scene, params, Backend::Cpu).unwrap_or_else(|e| panic!("CPU backend failed: {e}"))
}

pub fn expect_err(result: Result<Raster, Error>) -> Error {
    match result {
        Ok(_) => panic!("expected an error, got a raster"),
        Err(e) => e,
    }
}

/// Render `mesh` on `backend`, panicking with the backend and the error on failure.
pub fn render_frame(mesh: &tileraster::render::Mesh, params: &tileraster::render::RenderParams, backend: Backend) -> tileraster::render::Frame {
    tileraster::render::render(mesh, params, backend).unwrap_or_else(|e| panic!("{backend:?}: {e}"))
}

/// The CPU frame, after checking that the GPU backend gives the same bits: colour, ids,
/// fragment counts, depth and statistics.
pub fn assert_frame_parity(what: &str, mesh: &tileraster::render::Mesh, params: &tileraster::render::RenderParams) -> tileraster::render::Frame {
    let cpu = render_frame(mesh, params, Backend::Cpu);
    if gpu_or_skip(what) {
        let gpu = render_frame(mesh, params, Backend::Gpu);
        assert!(cpu.colour == gpu.colour && cpu.ids == gpu.ids && cpu.fragments == gpu.fragments, "{what}: the frames differ");
        assert!(cpu.depth.iter().zip(&gpu.depth).all(|(a, b)| a.to_bits() == b.to_bits()), "{what}: depths differ");
        assert_eq!(cpu.stats, gpu.stats, "{what}: statistics");
    }
    cpu
}

/// A camera that sees both squares of [`skinned_gltf`] in perspective, from above and to the
/// right, whatever their pose.
pub fn skinned_camera() -> tileraster::render::Camera {
    tileraster::render::Camera {
        eye: [1.5, 1.5, 3.0],
        target: [1.0, 0.5, 0.0],
        up: [0.0, 1.0, 0.0],
        projection: tileraster::render::Projection::Perspective { fov_deg: 50.0 },
        near: 0.5,
        far: 20.0,
    }
}

/// A glTF file (with its `.bin`) animated by a skin and a morph target: two unit squares side
/// by side in the plane z = 0, x from 0 to 2 and y from 0 to 1, normals +z. The vertices at
/// x = 0 and x = 1 follow joint 0 (node 1, at the origin), those at x = 2 joint 1 (node 2, at
/// x = 1), which the animation turns about +y from no turn at 0 s to 90° at 1 s (`LINEAR`):
/// the right square turns edge-on to a viewer on the z axis. One morph target moves the
/// vertices at x = 0 by −½ in x, its weight animated from 0 at 0 s to 1 at 1 s. At rest, the
/// squares as given.
pub fn skinned_gltf(dir: &std::path::Path) -> std::path::PathBuf {
    let positions: [[f32; 3]; 6] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [2.0, 1.0, 0.0]];
    let normals = [[0.0f32, 0.0, 1.0]; 6];
    let offsets: [[f32; 3]; 6] = [[-0.5, 0.0, 0.0], [0.0; 3], [0.0; 3], [-0.5, 0.0, 0.0], [0.0; 3], [0.0; 3]];
    let joints: [[u16; 4]; 6] = [[0; 4], [0; 4], [1, 0, 0, 0], [0; 4], [0; 4], [1, 0, 0, 0]];
    let weights = [[1.0f32, 0.0, 0.0, 0.0]; 6];
    // Column-major: the identity, and a move by −1 in x (joint 1's inverse bind).
    let binds: [[f32; 16]; 2] = [
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 1.0],
    ];
    let times = [0.0f32, 1.0];
    let half = std::f32::consts::FRAC_1_SQRT_2;
    let turns = [[0.0f32, 0.0, 0.0, 1.0], [0.0, half, 0.0, half]];
    let morph = [0.0f32, 1.0];
    let indices: [u16; 12] = [0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4];
    let mut buffer = Vec::new();
    let mut views = Vec::new();
    let mut add = |bytes: Vec<u8>| {
        views.push(format!(r#"{{"buffer": 0, "byteOffset": {}, "byteLength": {}}}"#, buffer.len(), bytes.len()));
        buffer.extend(bytes);
    };
    let floats = |v: &[f32]| v.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>();
    let shorts = |v: &[u16]| v.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>();
    add(floats(positions.as_flattened()));
    add(floats(normals.as_flattened()));
    add(floats(offsets.as_flattened()));
    add(shorts(joints.as_flattened()));
    add(floats(weights.as_flattened()));
    add(floats(binds.as_flattened()));
    add(floats(&times));
    add(floats(turns.as_flattened()));
    add(floats(&morph));
    add(shorts(&indices));
    std::fs::write(dir.join("skinned.bin"), &buffer).unwrap();
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0, "skin": 0}}, {{"children": [2]}}, {{"translation": [1, 0, 0]}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "JOINTS_0": 3, "WEIGHTS_0": 4}}, "targets": [{{"POSITION": 2}}], "indices": 9}}]}}],
  "skins": [{{"inverseBindMatrices": 5, "joints": [1, 2]}}],
  "animations": [{{
    "channels": [{{"sampler": 0, "target": {{"node": 2, "path": "rotation"}}}}, {{"sampler": 1, "target": {{"node": 0, "path": "weights"}}}}],
    "samplers": [{{"input": 6, "output": 7, "interpolation": "LINEAR"}}, {{"input": 6, "output": 8, "interpolation": "LINEAR"}}]
  }}],
  "buffers": [{{"uri": "skinned.bin", "byteLength": {}}}],
  "bufferViews": [{}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3", "min": [0, 0, 0], "max": [2, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 6, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5126, "count": 6, "type": "VEC3", "min": [-0.5, 0, 0], "max": [0, 0, 0]}},
    {{"bufferView": 3, "componentType": 5123, "count": 6, "type": "VEC4"}},
    {{"bufferView": 4, "componentType": 5126, "count": 6, "type": "VEC4"}},
    {{"bufferView": 5, "componentType": 5126, "count": 2, "type": "MAT4"}},
    {{"bufferView": 6, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]}},
    {{"bufferView": 7, "componentType": 5126, "count": 2, "type": "VEC4"}},
    {{"bufferView": 8, "componentType": 5126, "count": 2, "type": "SCALAR"}},
    {{"bufferView": 9, "componentType": 5123, "count": 12, "type": "SCALAR"}}
  ]
}}"#,
        buffer.len(),
        views.join(", ")
    );
    let path = dir.join("skinned.gltf");
    std::fs::write(&path, json).unwrap();
    path
}
