//! Stage by stage, CPU against GPU: what setup, bin_count, bin_scan and bin_fill leave in
//! their buffers must be the same on both backends, so that a parity failure of the raster can
//! be traced to the first stage that differs. Setups, counts and offsets compare in full; a
//! tile's bin compares as a set (`bin_fill` appends with atomics, so the order within a bin
//! depends on scheduling; fine raster does not depend on it).

mod common;

use tileraster::{Grid, Params, Scene, Skips, prepare};
use tileraster_cpu::StageBuffers;
use tileraster_kernels::programs::vertex::Builtin;
use tileraster_testkit::scenes;

/// The first index where `a` and `b` differ, with both values.
fn first_difference<T: PartialEq + std::fmt::Debug>(a: &[T], b: &[T]) -> Option<String> {
    if let Some(k) = a.iter().zip(b).position(|(x, y)| x != y) {
        return Some(format!("first at {k}: CPU {:?}, GPU {:?}", a[k], b[k]));
    }
    (a.len() != b.len()).then(|| format!("lengths differ: CPU {}, GPU {}", a.len(), b.len()))
}

/// Panics naming the first stage buffer that differs.
fn assert_same_stages(name: &str, cpu: &StageBuffers, gpu: &StageBuffers) {
    for (buffer, diff) in [
        ("setups", first_difference(&cpu.setups, &gpu.setups)),
        ("counts", first_difference(&cpu.counts, &gpu.counts)),
        ("offsets", first_difference(&cpu.offsets, &gpu.offsets)),
    ] {
        if let Some(diff) = diff {
            panic!("{name}: stage buffer {buffer} differs between the backends; {diff}");
        }
    }
    let tiles = cpu.counts.len();
    for tile in 0..tiles {
        let range = cpu.offsets[tile] as usize..cpu.offsets[tile + 1] as usize;
        let (mut a, mut b) = (cpu.bins[range.clone()].to_vec(), gpu.bins[range].to_vec());
        a.sort_unstable();
        b.sort_unstable();
        if let Some(diff) = first_difference(&a, &b) {
            panic!("{name}: the bin of tile {tile} holds other entries on the two backends (sorted); {diff}");
        }
    }
}

fn cases() -> Vec<(String, Scene, Grid)> {
    let grid = Grid::new(0.0, 100.0, 0.0, 100.0, 333, 257);
    let (micro, micro_grid) = scenes::micro_triangles(128, 0.5, 7);
    vec![
        ("terrain TIN".into(), scenes::terrain(0.0, 0.0, 100.0, 100.0, 30, 20, 3), grid),
        ("overlapping soup".into(), scenes::triangle_soup(&grid, 700, 30.0, 9), grid),
        ("fan around a centre".into(), scenes::fan(&grid, 60, 60, 90, 40.0, 3), grid),
        ("sliver wedge".into(), scenes::sliver_wedge(&grid, 80, 0.02, 4), grid),
        ("micro-triangles".into(), micro, micro_grid),
        ("plane, full tiles".into(), scenes::sloping_plane(), Grid::new(0.0, 1.0, 0.0, 1.0, 700, 300)),
    ]
}

#[test]
fn every_stage_leaves_the_same_buffers_on_both_backends() {
    if !common::gpu_or_skip("every_stage_leaves_the_same_buffers_on_both_backends") {
        return;
    }
    // (Not while another test lowers the device's binding limit.)
    let _turn = BINDING_LIMIT.lock().unwrap_or_else(|e| e.into_inner());
    for (name, scene, grid) in cases() {
        for (variant, skips) in common::skip_variants() {
            let prepared = prepare(&scene, &Params::new(grid).with_skips(skips), None).unwrap_or_else(|e| panic!("{name}: {e}"));
            let cpu = tileraster_cpu::stage_buffers(&prepared).expect("CPU stages");
            let gpu = tileraster_gpu::stage_buffers(&prepared).unwrap_or_else(|e| panic!("{name}, {variant}: GPU stages: {e}"));
            match (cpu, gpu) {
                (Some(cpu), Some(gpu)) => {
                    assert!(!cpu.bins.is_empty(), "{name}: nothing binned, nothing compared");
                    assert_same_stages(&format!("{name}, {variant}"), &cpu, &gpu);
                }
                (cpu, gpu) => panic!("{name}, {variant}: a window on one backend only (CPU {}, GPU {})", cpu.is_some(), gpu.is_some()),
            }
        }
    }
}

/// The comparison finds what it is for: a changed setup, count or bin entry is named.
#[test]
fn a_differing_stage_buffer_is_named() {
    let (scene, grid) = (scenes::terrain(0.0, 0.0, 100.0, 100.0, 12, 10, 3), Grid::new(0.0, 100.0, 0.0, 100.0, 97, 61));
    let prepared = prepare(&scene, &Params::new(grid).with_skips(Skips::NONE), None).unwrap();
    let cpu = tileraster_cpu::stage_buffers(&prepared).unwrap().expect("a window");
    assert_same_stages("itself", &cpu, &cpu);
    let caught = |change: &dyn Fn(&mut StageBuffers), what: &str| {
        let mut other = cpu.clone();
        change(&mut other);
        let message = std::panic::catch_unwind(|| assert_same_stages("changed", &cpu, &other)).expect_err("a difference is caught");
        let text = message.downcast_ref::<String>().cloned().unwrap_or_default();
        assert!(text.contains(what), "{text}");
    };
    caught(&|b| b.setups[3].coverage.index += 1, "setups");
    caught(&|b| b.counts[5] += 1, "counts");
    caught(&|b| *b.bins.last_mut().unwrap() ^= 1, "bin of tile");
}

/// Held by a test while it changes the GPU's binding limit, and by the tests it would change.
static BINDING_LIMIT: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// What the host's preparation hands the vertex and assembly stages, kept, the stages run as
/// their CPU twins.
#[derive(Default)]
struct Recorded {
    params: Option<tileraster_kernels::abi::VertexParams>,
    positions: Vec<tileraster_kernels::abi::RelativePosition>,
    assembled: Vec<RecordedMesh>,
    /// Vertices the light stage lit on both backends.
    lit_compared: usize,
}

/// A placed mesh's faces as the host handed them to the assembly stages, and what the twins made.
struct RecordedMesh {
    params: tileraster_kernels::abi::AssembleParams,
    faces: Vec<u32>,
    projected: Vec<tileraster_kernels::abi::ProjectedVertex>,
    attributes: Vec<[f32; tileraster_kernels::abi::ATTRIBUTES]>,
    lit: Vec<[f32; 4]>,
    face_normals: Vec<tileraster_kernels::abi::FaceNormal>,
    shade: tileraster_kernels::abi::ShadeParams,
    materials: Vec<tileraster_kernels::abi::FaceMaterial>,
    count: tileraster_core::render::AssemblyCount,
    patches: tileraster_core::render::AssemblyPatches,
    inputs: Vec<tileraster_kernels::abi::TriangleInput>,
    shading: Vec<tileraster_kernels::abi::TriangleShading>,
}

impl tileraster::render::GeometryKernels for Recorded {
    fn vertex(
        &mut self,
        params: &tileraster_kernels::abi::VertexParams,
        positions: tileraster_core::render::Positions<'_>,
        posing: Option<&tileraster_core::render::Posing<'_>>,
        projected: &mut Vec<tileraster_kernels::abi::ProjectedVertex>,
    ) -> Result<u64, tileraster::Error> {
        self.params = Some(*params);
        self.positions = positions.pairs.to_vec();
        tileraster_cpu::GeometryTwins::default().vertex(params, positions, posing, projected)?;
        Ok(positions.bytes(true))
    }

    fn light(
        &mut self,
        shade: &tileraster_kernels::abi::ShadeParams,
        attributes: &[[f32; tileraster_kernels::abi::ATTRIBUTES]],
        _kept: Option<u64>,
        lit: &mut Vec<[f32; 4]>,
    ) -> Result<u64, tileraster::Error> {
        tileraster_cpu::light(shade, attributes, lit);
        // The device's light stage writes the twin's bytes.
        let device = tileraster_gpu::light_rows(shade, attributes)?;
        assert!(bytemuck::cast_slice::<_, u8>(&device) == bytemuck::cast_slice::<_, u8>(lit), "the light stage differs between the backends");
        self.lit_compared += lit.len();
        Ok(0)
    }

    fn assemble_count(&mut self, mesh: &tileraster_core::render::AssemblyMesh<'_>) -> Result<tileraster_core::render::AssemblyCount, tileraster::Error> {
        Ok(tileraster_cpu::assemble_count(mesh))
    }

    fn assemble_fill(
        &mut self,
        mesh: &tileraster_core::render::AssemblyMesh<'_>,
        count: &tileraster_core::render::AssemblyCount,
        patches: &tileraster_core::render::AssemblyPatches,
        out: tileraster_core::render::AssembledRecords<'_>,
    ) -> Result<u64, tileraster::Error> {
        let offsets = tileraster_cpu::assemble_scan(&mesh.params, &count.group_counts, &patches.patches);
        let tileraster_core::render::AssembledRecords { inputs, shading, .. } = out;
        tileraster_cpu::assemble_fill(mesh, &offsets, patches, tileraster_core::render::AssembledRecords { inputs, shading, lists: None });
        self.assembled.push(RecordedMesh {
            params: mesh.params,
            faces: mesh.faces.to_vec(),
            projected: mesh.projected.to_vec(),
            attributes: mesh.attributes.to_vec(),
            lit: mesh.lit.to_vec(),
            face_normals: mesh.face_normals.to_vec(),
            shade: *mesh.shade,
            materials: mesh.materials.to_vec(),
            count: count.clone(),
            patches: patches.clone(),
            inputs: inputs.to_vec(),
            shading: shading.to_vec(),
        });
        Ok(0)
    }
}

/// The vertex stage on the device writes the CPU twin's bytes, on what the host hands it for
/// terrain in UTM coordinates seen from within (vertices behind the camera and beyond the guard
/// band among them), and on positions outside the stage's domain.
#[test]
fn the_vertex_stage_is_the_same_bits_on_both_backends() {
    use tileraster::render::{Camera, GeometryKernels, Projection, RenderParams};
    use tileraster_core::render::Positions;
    use tileraster_kernels::abi::{ProjectedVertex, RelativePosition};
    if !common::gpu_or_skip("the_vertex_stage_is_the_same_bits_on_both_backends") {
        return;
    }
    let mut mesh = tileraster_testkit::meshes::terrain(300, 10_000.0, 400.0);
    mesh.positions.iter_mut().for_each(|p| *p = [p[0] + 500_000.0, p[1] + 5_000_000.0, p[2]]);
    let eye = [504_000.0, 5_004_000.0, 450.0];
    let camera = Camera::look_at(eye, [506_000.0, 5_005_000.0, 200.0], [0.0, 0.0, 1.0], Projection::Perspective { fov_deg: 60.0 }, &mesh);
    let params = RenderParams::new(1280, 720, camera.view_projection(1280, 720).unwrap());
    let mut recorded = Recorded::default();
    tileraster_core::render::prepare_render(&mesh, &params, &mut recorded).unwrap();
    let stage = recorded.params.expect("the preparation ran the vertex stage");
    let mut positions = recorded.positions;
    assert_eq!(positions.len(), mesh.positions.len());
    // Far out but inside the domain; then outside it: too large for the pairs, a NaN, an
    // infinity, and the smallest subnormal.
    let far = |v: f32| RelativePosition { hi: [v, v, v], lo: [0.0; 3] };
    positions.extend([far(1e30), far(-1e30), far(1e36), far(3e38), far(f32::NAN), far(f32::INFINITY)]);
    positions.push(RelativePosition { hi: [0.0; 3], lo: [f32::from_bits(1); 3] });
    let stage = tileraster_kernels::abi::VertexParams { vertices: positions.len() as u32, ..stage };
    let (mut cpu, mut gpu) = (Vec::new(), Vec::new());
    tileraster_cpu::vertex(&Builtin, &stage, &[], &positions, &mut cpu);
    let handed = Positions { pairs: &positions, kept: None };
    tileraster_gpu::GeometryDevice::default().vertex(&stage, handed, None, &mut gpu).unwrap();
    let projected = cpu.iter().filter(|p| p.is_projected()).count();
    let refused = cpu.len() - projected;
    println!("{} vertices: {projected} projected, {refused} outside the stage's domain", cpu.len());
    assert!(projected > positions.len() / 4 && refused > positions.len() / 10, "{projected} projected, {refused} not");
    assert!(cpu[cpu.len() - 5..cpu.len() - 1].iter().all(|p| *p == ProjectedVertex::NONE), "{:?}", &cpu[cpu.len() - 7..]);
    let bytes = |v: &[ProjectedVertex]| -> Vec<u8> { bytemuck::cast_slice(v).to_vec() };
    let same = |what: &str, gpu: &[ProjectedVertex]| {
        if let Some(diff) = first_difference(&bytes(&cpu), &bytes(gpu)) {
            let k = cpu.iter().zip(gpu).position(|(a, b)| bytemuck::bytes_of(a) != bytemuck::bytes_of(b));
            panic!("{what}: the vertex stage differs between the backends: {diff}; vertex {k:?}: CPU {:?}, GPU {:?}", k.map(|k| cpu[k]), k.map(|k| gpu[k]));
        }
    };
    same("in one dispatch", &gpu);
    // Kept positions: handed over once, then read where the device keeps them; other
    // positions under another key (as many) replace them.
    let mut device = tileraster_gpu::GeometryDevice::default();
    let kept = Positions { pairs: &positions, kept: Some(7) };
    for (call, handed) in [(1, true), (2, false)] {
        assert_eq!(device.vertex(&stage, kept, None, &mut gpu).unwrap(), kept.bytes(handed), "call {call}");
        same(&format!("kept, call {call}"), &gpu);
    }
    let reversed: Vec<RelativePosition> = positions.iter().rev().copied().collect();
    let other = Positions { pairs: &reversed, kept: Some(8) };
    assert_eq!(device.vertex(&stage, other, None, &mut gpu).unwrap(), other.bytes(true));
    let mut cpu_reversed = Vec::new();
    tileraster_cpu::vertex(&Builtin, &stage, &[], &reversed, &mut cpu_reversed);
    assert!(bytes(&gpu) == bytes(&cpu_reversed), "another mesh's kept positions: the stage read stale ones");
    // A device that binds fewer positions at once runs the stage in parts: the same bytes.
    let limit = 10_000 * std::mem::size_of::<RelativePosition>() as u64;
    let parts = {
        let _turn = BINDING_LIMIT.lock().unwrap_or_else(|e| e.into_inner());
        tileraster::set_gpu_binding_limit(limit);
        let parts = tileraster_gpu::GeometryDevice::default().vertex(&stage, handed, None, &mut gpu);
        // Kept in parts: handed over once too.
        let mut device = tileraster_gpu::GeometryDevice::default();
        let kept_parts = [true, false].map(|handed| {
            let mut out = Vec::new();
            let counted = device.vertex(&stage, kept, None, &mut out).map(|b| b == kept.bytes(handed));
            (counted, out)
        });
        tileraster::set_gpu_binding_limit(u64::MAX);
        (parts, kept_parts)
    };
    let (parts, kept_parts) = parts;
    parts.unwrap();
    same("in ten parts", &gpu);
    for (call, (counted, out)) in kept_parts.into_iter().enumerate() {
        assert!(counted.unwrap(), "kept in parts, call {call}: bytes counted");
        same(&format!("kept in parts, call {call}"), &out);
    }
}

/// The assembly's rows on the device write the CPU twins' bytes: counts, ranks, records and
/// lists, on what a preparation handed the twins (a grid cut by the near and far planes, so
/// that the host clips faces and the rows patch them in; every shading and interpolation,
/// culling, several samples; a second placement's records after the first's). The lists are
/// the plan's.
#[test]
fn the_assembly_stages_are_the_same_bits_on_both_backends() {
    use tileraster::render::{Camera, Cull, Eye, Instance, Interpolation, Projection, RenderParams, Shading, World};
    use tileraster_core::render::{AssembledRecords, AssemblyMesh};
    if !common::gpu_or_skip("the_assembly_stages_are_the_same_bits_on_both_backends") {
        return;
    }
    let mesh = tileraster_testkit::meshes::terrain(500, 400.0, 0.0);
    let (w, h) = (180u32, 120u32);
    let eye = [201.3, 197.9, 0.4];
    let camera = Camera { eye, target: [180.0, 270.0, -3.0], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 60.0 }, near: 0.3, far: 80.0 };
    let view = camera.view_projection(w, h).unwrap();
    let base = RenderParams { eye: Some(Eye::Point(eye)), ..RenderParams::new(w, h, view) };
    let cases = [
        ("flat shading, flat interpolation", RenderParams { cull: Cull::None, shading: Shading::Flat, interpolation: Interpolation::Flat, ..base.clone() }),
        ("Gouraud shading, back faces culled", RenderParams { cull: Cull::Back, shading: Shading::Smooth, ..base.clone() }),
        ("Phong shading, four samples", RenderParams { samples: 4, ..base.clone() }),
        ("ids", RenderParams { shading: Shading::Ids, ..base.clone() }),
    ];
    let (mut compared, mut patched, mut lit_compared) = (0, 0, 0);
    for (name, params) in cases {
        let mut recorded = Recorded::default();
        let (prepared, _) = tileraster_core::render::prepare_render(&mesh, &params, &mut recorded).unwrap();
        let [one] = &recorded.assembled[..] else { panic!("{name}: one placed mesh, {} assembled", recorded.assembled.len()) };
        let lit = params.shading == Shading::Smooth;
        assert_eq!(recorded.lit_compared > 0, lit, "{name}: the light stage runs for Gouraud shading alone");
        lit_compared += recorded.lit_compared;
        let input = AssemblyMesh {
            params: one.params,
            faces: &one.faces,
            projected: &one.projected,
            attributes: &one.attributes,
            lit: &one.lit,
            face_normals: &one.face_normals,
            shade: &one.shade,
            materials: &one.materials,
            kept: Default::default(),
        };
        let device = tileraster_gpu::assemble_rows(&input, &one.patches).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(device.count, one.count, "{name}: assemble_count");
        assert_eq!(device.offsets, tileraster_cpu::assemble_scan(&one.params, &one.count.group_counts, &one.patches.patches), "{name}: assemble_scan");
        let same = |what: &str, cpu: &[u8], gpu: &[u8]| {
            if let Some(diff) = first_difference(cpu, gpu) {
                panic!("{name}: assemble_fill's {what} differ between the backends: {diff}");
            }
        };
        same("inputs", bytemuck::cast_slice(&one.inputs), bytemuck::cast_slice(&device.inputs));
        same("shading", bytemuck::cast_slice(&one.shading), bytemuck::cast_slice(&device.shading));
        // The twin's lists, and the plan's (the frame's records are this mesh's).
        let (mut inputs, mut shading) = (one.inputs.clone(), one.shading.clone());
        let (mut listed, mut small) = (vec![0; device.listed.len()], vec![0; device.small.len()]);
        let offsets = tileraster_cpu::assemble_scan(&one.params, &one.count.group_counts, &one.patches.patches);
        let out = AssembledRecords { inputs: &mut inputs, shading: &mut shading, lists: Some((&mut listed, &mut small)) };
        tileraster_cpu::assemble_fill(&input, &offsets, &one.patches, out);
        assert_eq!((&listed, &small), (&device.listed, &device.small), "{name}: the lists");
        let plan = prepared.plan(prepared.window, false).unwrap();
        assert_eq!((&plan.listed, &plan.small), (&device.listed, &device.small), "{name}: the lists are not the plan's");
        assert!(bytemuck::cast_slice::<_, u8>(&prepared.triangles) == bytemuck::cast_slice::<_, u8>(&one.inputs), "{name}: the frame's records");
        assert!(one.count.clipped.len() > 100 && one.inputs.len() > 400, "{name}: {} clipped, {} records", one.count.clipped.len(), one.inputs.len());
        compared += one.inputs.len();
        patched += one.patches.inputs.len();
    }
    // Two placements: the second's records and lists follow the first's.
    let world = World {
        meshes: vec![mesh.clone()],
        instances: vec![
            Instance::of(0),
            Instance { transform: [[1.0, 0.0, 0.0, 3.0], [0.0, 1.0, 0.0, 2.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]], ..Instance::of(0) },
        ],
    };
    let mut recorded = Recorded::default();
    let (prepared, _) = tileraster_core::render::prepare_world(&world, &base, &mut recorded).unwrap();
    let [first, second] = &recorded.assembled[..] else { panic!("two placed meshes, {} assembled", recorded.assembled.len()) };
    assert_eq!((second.params.first_listed + second.params.first_small) as usize, first.inputs.len());
    let records: Vec<u8> = [bytemuck::cast_slice::<_, u8>(&first.inputs), bytemuck::cast_slice(&second.inputs)].concat();
    assert!(records == bytemuck::cast_slice::<_, u8>(&prepared.triangles), "the world's records are its placements' in turn");
    println!("{compared} records compared, {patched} of them pieces of faces clipped on the host; {lit_compared} vertices lit");
    assert!(patched > 20, "{patched} pieces");
}
