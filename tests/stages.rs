//! Stage by stage, CPU against GPU: what setup, bin_count, bin_scan and bin_fill leave in
//! their buffers must be the same on both backends, so that a parity failure of the raster can
//! be traced to the first stage that differs. Setups, counts and offsets compare in full; a
//! tile's bin compares as a set (`bin_fill` appends with atomics, so the order within a bin
//! depends on scheduling; fine raster does not depend on it).

mod common;

use tileraster::{Grid, Params, Scene, Skips, prepare};
use tileraster_cpu::StageBuffers;
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

/// What the host's preparation hands the vertex stage, kept, the stage run as its CPU twin.
#[derive(Default)]
struct Recorded {
    params: Option<tileraster_kernels::abi::VertexParams>,
    positions: Vec<tileraster_kernels::abi::RelativePosition>,
}

impl tileraster::render::GeometryKernels for Recorded {
    fn vertex(
        &mut self,
        params: &tileraster_kernels::abi::VertexParams,
        positions: tileraster_core::render::Positions<'_>,
        projected: &mut Vec<tileraster_kernels::abi::ProjectedVertex>,
    ) -> Result<u64, tileraster::Error> {
        self.params = Some(*params);
        self.positions = positions.pairs.to_vec();
        tileraster_cpu::vertex(params, positions.pairs, projected);
        Ok(positions.bytes(true))
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
    tileraster_cpu::vertex(&stage, &positions, &mut cpu);
    let handed = Positions { pairs: &positions, kept: None };
    tileraster_gpu::GeometryDevice::default().vertex(&stage, handed, &mut gpu).unwrap();
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
        assert_eq!(device.vertex(&stage, kept, &mut gpu).unwrap(), kept.bytes(handed), "call {call}");
        same(&format!("kept, call {call}"), &gpu);
    }
    let reversed: Vec<RelativePosition> = positions.iter().rev().copied().collect();
    let other = Positions { pairs: &reversed, kept: Some(8) };
    assert_eq!(device.vertex(&stage, other, &mut gpu).unwrap(), other.bytes(true));
    let mut cpu_reversed = Vec::new();
    tileraster_cpu::vertex(&stage, &reversed, &mut cpu_reversed);
    assert!(bytes(&gpu) == bytes(&cpu_reversed), "another mesh's kept positions: the stage read stale ones");
    // A device that binds fewer positions at once runs the stage in parts: the same bytes.
    let limit = 10_000 * std::mem::size_of::<RelativePosition>() as u64;
    let parts = {
        let _turn = BINDING_LIMIT.lock().unwrap_or_else(|e| e.into_inner());
        tileraster::set_gpu_binding_limit(limit);
        let parts = tileraster_gpu::GeometryDevice::default().vertex(&stage, handed, &mut gpu);
        // Kept in parts: handed over once too.
        let mut device = tileraster_gpu::GeometryDevice::default();
        let kept_parts = [true, false].map(|handed| {
            let mut out = Vec::new();
            let counted = device.vertex(&stage, kept, &mut out).map(|b| b == kept.bytes(handed));
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
