//! The assembly's rows on the device (`assemble_count`, `assemble_scan`, `assemble_fill`,
//! `stages::assemble`). A frame's preparation runs their CPU twins for now: the records they
//! write are the ones the raster stages read, so the device's rows pay once those records stay
//! on the device (docs/kernels.md, "The assembly on the device"). Until then [`assemble_rows`]
//! runs them over what a preparation handed its twins, for the comparison of the backends.

use super::{GpuContext, MAX_GROUPS, context};
use tileraster_core::Error;
use tileraster_core::render::{AssemblyCount, AssemblyMesh, AssemblyPatches};
use tileraster_kernels::abi::{AssembleParams, TriangleInput, TriangleShading};
use tileraster_kernels::pipeline::{Buffer, Pipeline, STAGES, Scope, Stage};
use tileraster_kernels::stages::assemble::{ASSEMBLY_COUNTERS, FACE_GROUP};

/// What the assembly's rows leave on the device for one placed mesh, read back: what
/// `assemble_count` counted (its faces left to the host sorted into face order: the device
/// appends them in no order), `assemble_scan`'s ranks, and `assemble_fill`'s records and lists.
#[derive(Debug, Clone, PartialEq)]
pub struct AssembledOnDevice {
    pub count: AssemblyCount,
    pub offsets: Vec<u32>,
    pub inputs: Vec<TriangleInput>,
    pub shading: Vec<TriangleShading>,
    pub listed: Vec<u32>,
    pub small: Vec<u32>,
}

/// Run the assembly's rows on the device over `mesh` (the first of a frame's placements: its
/// records from slot 0), `patches` standing for the host's clipping of the faces the count
/// leaves it (they must be the ones it leaves).
pub fn assemble_rows(mesh: &AssemblyMesh<'_>, patches: &AssemblyPatches) -> Result<AssembledOnDevice, Error> {
    let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
    ctx.check_float_modes(tileraster_core::Mode::Barycentric)?;
    let scope = ctx.gpu.error_scope();
    let result = ctx.assemble_rows(mesh, patches);
    if let Some(e) = scope.finish() {
        return Err(Error::Gpu(format!("the assembly stages: {e}")));
    }
    result
}

impl GpuContext {
    /// The index in `self.pipelines` of the pipeline of frame stage `stage`, built on first use.
    pub(super) fn frame_row(&mut self, stage: Stage) -> usize {
        let row = STAGES.iter().position(|s| s.stage == stage).expect("every stage has a row");
        let build = super::Build { row, fragment: None, spec: [None; 2] };
        if let Some(k) = self.pipelines.iter().position(|(b, _)| *b == build) {
            return k;
        }
        let info = &STAGES[row];
        let label = format!("tileraster kernels, {}", info.name);
        let module = super::passthrough_module(&self.gpu.device, &label, self.kernels, &build.spec, |other| other.stage == info.stage);
        let cache = self.pipeline_cache.as_ref().map(|c| &c.cache);
        self.pipelines.push((build, super::stage_pipeline(&self.gpu.device, &module, info, cache)));
        if let Some(cache) = &self.pipeline_cache {
            cache.save();
        }
        self.pipelines.len() - 1
    }

    /// The rows of `stages` in a table of rows for [`Self::encode_stages`].
    pub(super) fn frame_rows(&mut self, stages: &[Stage]) -> Vec<Option<usize>> {
        let mut rows = vec![None; STAGES.len()];
        for &stage in stages {
            rows[stage as usize] = Some(self.frame_row(stage));
        }
        rows
    }

    /// A storage buffer holding `data` (at least 16 bytes, as bindings want an element).
    fn storage_with(&self, label: &str, data: &[u8], room: u64) -> wgpu::Buffer {
        let size = (data.len() as u64).max(room).max(16).next_multiple_of(16);
        let buffer = self.gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        if !data.is_empty() {
            self.recorder.upload(&self.gpu.queue, &buffer, data);
        }
        buffer
    }

    /// Copy `parts` (buffer, bytes) out of the device in one submission after `encoder`'s work.
    fn read_parts(&mut self, mut encoder: wgpu::CommandEncoder, parts: &[(&wgpu::Buffer, u64)]) -> Result<Vec<Vec<u8>>, Error> {
        let total: u64 = parts.iter().map(|p| p.1).sum();
        let readback = self.buffers.readback.get(&self.gpu.device, total.max(4));
        let mut at = 0;
        for &(buffer, bytes) in parts {
            if bytes > 0 {
                encoder.copy_buffer_to_buffer(buffer, 0, &readback, at, bytes);
            }
            at += bytes;
        }
        self.recorder.submit();
        self.recorder.wait(total);
        let mut out = Vec::new();
        let split = |b: &[u8]| {
            let mut at = 0;
            for &(_, bytes) in parts {
                out.push(b[at as usize..(at + bytes) as usize].to_vec());
                at += bytes;
            }
        };
        self.gpu.submit_and_read(encoder, &readback, total.max(4), split).map_err(|e| Error::Gpu(format!("the assembly stages: {e}")))?;
        Ok(out)
    }

    fn assemble_rows(&mut self, mesh: &AssemblyMesh<'_>, patches: &AssemblyPatches) -> Result<AssembledOnDevice, Error> {
        let faces = mesh.params.faces;
        let groups = faces.div_ceil(FACE_GROUP).max(1);
        let (x, y) = (groups.min(MAX_GROUPS), groups.div_ceil(MAX_GROUPS));
        let params = AssembleParams {
            groups: faces.div_ceil(FACE_GROUP),
            dispatch_width: x * FACE_GROUP,
            patches: patches.patches.len() as u32,
            first_listed: 0,
            first_small: 0,
            ..mesh.params
        };
        let params_buf = self.storage_with("assemble params", bytemuck::bytes_of(&params), 0);
        let faces_buf = self.storage_with("face indices", bytemuck::cast_slice(mesh.faces), 0);
        let projected = self.storage_with("projected vertices", bytemuck::cast_slice(mesh.projected), 0);
        let attributes = self.storage_with("vertex attributes", bytemuck::cast_slice(mesh.attributes), 0);
        let lights = self.storage_with("lit faces", bytemuck::cast_slice(mesh.lights), 0);
        let textures = self.storage_with("face textures", bytemuck::cast_slice(mesh.textures), 0);
        let patch_buf = self.storage_with("patches", bytemuck::cast_slice(&patches.patches), 0);
        let pieces = self.storage_with("pieces", bytemuck::cast_slice(&patches.inputs), 0);
        let piece_shading = self.storage_with("piece shading", bytemuck::cast_slice(&patches.shading), 0);
        let count_bytes = 8 * params.groups as u64;
        let group_counts = self.storage_with("group counts", &[], count_bytes);
        let counters = self.storage_with("assembly counters", &[], 4 * ASSEMBLY_COUNTERS as u64);
        let clipped = self.storage_with("clipped faces", &[], 4 * faces as u64);

        // The count, read back: the host sizes the records by it (as it clips by it).
        let rows = self.frame_rows(&[Stage::AssembleCount]);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&group_counts, 0, None);
        encoder.clear_buffer(&counters, 0, None);
        let bound = |buffer| match buffer {
            Buffer::AssembleParams => Some(params_buf.clone()),
            Buffer::FaceIndices => Some(faces_buf.clone()),
            Buffer::Projected => Some(projected.clone()),
            Buffer::GroupCounts => Some(group_counts.clone()),
            Buffer::AssemblyCounters => Some(counters.clone()),
            Buffer::ClippedFaces => Some(clipped.clone()),
            _ => None,
        };
        let frame = Default::default();
        self.encode_stages(&mut encoder, Pipeline::Render, &rows, Scope::Frame, &frame, (x, y), &bound)?;
        let read = self.read_parts(encoder, &[(&group_counts, count_bytes), (&counters, 4 * ASSEMBLY_COUNTERS as u64), (&clipped, 4 * faces as u64)])?;
        let group_counts_host: Vec<u32> = bytemuck::pod_collect_to_vec(&read[0]);
        let counters_host: Vec<u32> = bytemuck::pod_collect_to_vec(&read[1]);
        let counters_host: [u32; ASSEMBLY_COUNTERS] = counters_host.try_into().expect("the counters' words");
        let left = counters_host[tileraster_kernels::stages::assemble::CLIPPED_ON_HOST as usize] as usize;
        let mut clipped_host: Vec<u32> = bytemuck::pod_collect_to_vec(&read[2]);
        clipped_host.truncate(left);
        clipped_host.sort_unstable();
        let count = AssemblyCount { group_counts: group_counts_host, counters: counters_host, clipped: clipped_host };

        // The ranks and the records.
        let sum = |k: usize| count.group_counts.iter().skip(k).step_by(2).map(|&n| n as u64).sum::<u64>();
        let listed = sum(0) + patches.patches.iter().map(|p| p.listed as u64).sum::<u64>();
        let small = sum(1) + patches.patches.iter().map(|p| p.small as u64).sum::<u64>();
        let records = listed + small;
        let offsets_bytes = 8 * params.groups as u64 + 8;
        let offsets = self.storage_with("group offsets", &[], offsets_bytes);
        let input_bytes = records * std::mem::size_of::<TriangleInput>() as u64;
        let shading_bytes = records * std::mem::size_of::<TriangleShading>() as u64;
        let inputs = self.storage_with("triangle inputs", &[], input_bytes);
        let shading = self.storage_with("triangle shading", &[], shading_bytes);
        let listed_buf = self.storage_with("listed", &[], 4 * listed);
        let small_buf = self.storage_with("small listed", &[], 4 * small);
        let rows = self.frame_rows(&[Stage::AssembleScan, Stage::AssembleFill]);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        let bound = |buffer| match buffer {
            Buffer::AssembleParams => Some(params_buf.clone()),
            Buffer::FaceIndices => Some(faces_buf.clone()),
            Buffer::Projected => Some(projected.clone()),
            Buffer::VertexAttributes => Some(attributes.clone()),
            Buffer::LitFaces => Some(lights.clone()),
            Buffer::FaceTextures => Some(textures.clone()),
            Buffer::GroupCounts => Some(group_counts.clone()),
            Buffer::Patches => Some(patch_buf.clone()),
            Buffer::Pieces => Some(pieces.clone()),
            Buffer::PieceShading => Some(piece_shading.clone()),
            Buffer::GroupOffsets => Some(offsets.clone()),
            Buffer::Inputs => Some(inputs.clone()),
            Buffer::Shading => Some(shading.clone()),
            Buffer::Listed => Some(listed_buf.clone()),
            Buffer::SmallListed => Some(small_buf.clone()),
            _ => None,
        };
        self.encode_stages(&mut encoder, Pipeline::Render, &rows, Scope::Frame, &frame, (x, y), &bound)?;
        let parts = [(&offsets, offsets_bytes), (&inputs, input_bytes), (&shading, shading_bytes), (&listed_buf, 4 * listed), (&small_buf, 4 * small)];
        let read = self.read_parts(encoder, &parts)?;
        Ok(AssembledOnDevice {
            count,
            offsets: bytemuck::pod_collect_to_vec(&read[0]),
            inputs: bytemuck::pod_collect_to_vec(&read[1]),
            shading: bytemuck::pod_collect_to_vec(&read[2]),
            listed: bytemuck::pod_collect_to_vec(&read[3]),
            small: bytemuck::pod_collect_to_vec(&read[4]),
        })
    }
}
