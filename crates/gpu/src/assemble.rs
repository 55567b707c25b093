//! The geometry stages on the device, as the host prepares a frame (`GeometryKernels`): the
//! vertex stage, and the assembly's rows (`assemble_count`, `assemble_scan`, `assemble_fill`,
//! `stages::assemble`). The projected vertices stay where the vertex stage wrote them, a
//! prepared mesh's faces, face materials, attributes and face normals stay on the device between its frames,
//! and the fill writes the frame's records and lists where setup and binning read them
//! ([`HeldRecords`]). The count comes back (a few words a group of faces, and the faces left to
//! the host's clipping), and so do the records, for the host's plan (its pass over them is
//! next to move to the device: docs/kernels.md).

use super::{GpuContext, KeptPositions, MAX_GROUPS, context, storage_buffer};
use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use tileraster_build::Role;
use tileraster_core::render::{
    AssembledRecords, AssemblyCount, AssemblyMesh, AssemblyPatches, GeometryKernels, KeptHanded, KeptInputs, Posing, Positions, VertexTexture,
};
use tileraster_core::{Error, Mode, Prepared};
use tileraster_kernels::TRIANGLE_GROUP;
use tileraster_kernels::abi::{
    ATTRIBUTES, AssembleParams, LIGHT_FACES, LightParams, ProjectedVertex, ShadeParams, TriangleInput, TriangleShading, VertexParams,
};
use tileraster_kernels::pipeline::{Buffer, Pipeline, STAGES, Scope, Stage};
use tileraster_kernels::stages::assemble::{ASSEMBLY_COUNTERS, CLIPPED_ON_HOST, FACE_GROUP};

/// The kernels' geometry stages on the device. One `GeometryDevice` a prepared mesh: what it
/// keeps on the device (positions, faces, attributes) serves that mesh's later frames, and it
/// holds each frame's records from its assembly to its raster call
/// (`tileraster_gpu::rasterise_frame`).
#[derive(Debug, Default)]
pub struct GeometryDevice {
    kept: Option<KeptPositions>,
    /// The frame's projected vertices where the vertex stage left them (`None` after a stage in
    /// parts: the twins assemble that frame).
    projected: Option<wgpu::Buffer>,
    /// A prepared mesh's faces and their surfaces, and the frame's vertex attributes and face
    /// normals, on the device by their keys (`KeptInputs`).
    faces: Option<(u64, wgpu::Buffer, wgpu::Buffer)>,
    attributes: Option<(u64, wgpu::Buffer, wgpu::Buffer)>,
    /// The keys the byte count takes as handed over (`KeptHanded`, the figure both backends
    /// report).
    counted: KeptInputs,
    /// The vertex texture the byte count takes as handed over last.
    held_texture: tileraster_cpu::HeldTexture,
    /// What the vertex stage binds where a frame has no vertex texture.
    no_texture: Option<wgpu::Buffer>,
    /// The vertex texture on the device, and the one it holds.
    texture: Option<(Arc<VertexTexture>, wgpu::Buffer)>,
    /// The record buffers, grown as frames need and reused.
    room: RecordRoom,
    frame: DeviceFrame,
}

/// The frame in progress on a [`GeometryDevice`], from its vertex stage to its raster call.
#[derive(Debug, Default)]
struct DeviceFrame {
    /// Whether the twins assemble it (`assembles_on_device` says so, or the device's buffers
    /// could not hold it).
    on_twins: bool,
    /// What each placed mesh's count left on the device for its fill, in the placements' order.
    counted: VecDeque<CountedMesh>,
    records: Option<HeldRecords>,
    /// The light stage's colours where it left them (Gouraud shading), for the fills.
    lit: Option<wgpu::Buffer>,
}

#[derive(Debug, Default)]
struct RecordRoom {
    inputs: Option<wgpu::Buffer>,
    shading: Option<wgpu::Buffer>,
    listed: Option<wgpu::Buffer>,
    small: Option<wgpu::Buffer>,
    lit: Option<wgpu::Buffer>,
}

/// A frame's records where `assemble_fill` wrote them: setup reads `inputs`, the shade stages
/// `shading`, binning and `fine_small` the lists. `key` is the prepared frame's
/// (`RenderInputs::records_held`).
#[derive(Debug, Clone)]
pub(super) struct HeldRecords {
    pub(super) key: u64,
    pub(super) records: u64,
    pub(super) listed: u64,
    pub(super) small: u64,
    pub(super) inputs: wgpu::Buffer,
    pub(super) shading: wgpu::Buffer,
    pub(super) listed_slots: wgpu::Buffer,
    pub(super) small_slots: wgpu::Buffer,
}

/// One placed mesh's inputs on the device, as its count left them for its fill.
#[derive(Debug, Clone)]
struct CountedMesh {
    faces: wgpu::Buffer,
    materials: wgpu::Buffer,
    projected: wgpu::Buffer,
    attributes: wgpu::Buffer,
    face_normals: wgpu::Buffer,
    group_counts: wgpu::Buffer,
}

/// Where a fill writes: the frame's records and lists.
struct RecordBuffers {
    inputs: wgpu::Buffer,
    shading: wgpu::Buffer,
    listed: wgpu::Buffer,
    small: wgpu::Buffer,
}

impl GeometryDevice {
    /// The records this device's assembly wrote for `prepared` (the frame it prepared last).
    pub(super) fn records_of(&self, prepared: &Prepared) -> Option<HeldRecords> {
        let held = self.frame.records.as_ref()?;
        let key = prepared.render.as_ref()?.records_held?;
        (held.key == key && held.records == prepared.triangles.len() as u64).then(|| held.clone())
    }

    /// The buffers of a mesh's kept (or this frame's) inputs, uploaded where not held by key.
    fn mesh_buffers(&mut self, ctx: &GpuContext, mesh: &AssemblyMesh<'_>, projected: wgpu::Buffer) -> CountedMesh {
        let faces = match (&self.faces, mesh.kept.faces) {
            (Some((held, faces, materials)), Some(key)) if *held == key => (faces.clone(), materials.clone()),
            _ => {
                self.faces = None;
                let faces = ctx.storage_with("face indices", bytemuck::cast_slice(mesh.faces), 0);
                let materials = ctx.storage_with("face materials", bytemuck::cast_slice(mesh.materials), 0);
                if let Some(key) = mesh.kept.faces {
                    self.faces = Some((key, faces.clone(), materials.clone()));
                }
                (faces, materials)
            }
        };
        let (attributes, face_normals) = match (&self.attributes, mesh.kept.attributes) {
            (Some((held, attributes, normals)), Some(key)) if *held == key => (attributes.clone(), normals.clone()),
            _ => {
                self.attributes = None;
                let attributes = ctx.storage_with("vertex attributes", bytemuck::cast_slice(mesh.attributes), 0);
                let normals = ctx.storage_with("face normals", bytemuck::cast_slice(mesh.face_normals), 0);
                if let Some(key) = mesh.kept.attributes {
                    self.attributes = Some((key, attributes.clone(), normals.clone()));
                }
                (attributes, normals)
            }
        };
        let group_counts = ctx.storage_with("group counts", &[], 8 * mesh.params.faces.div_ceil(FACE_GROUP) as u64);
        CountedMesh { faces: faces.0, materials: faces.1, projected, attributes, face_normals, group_counts }
    }
}

/// `slot`'s buffer, grown to at least `bytes` where smaller (the old one dropped first).
fn grown(device: &wgpu::Device, slot: &mut Option<wgpu::Buffer>, label: &str, bytes: u64) -> wgpu::Buffer {
    if slot.as_ref().is_none_or(|b| b.size() < bytes.max(16)) {
        *slot = None;
        *slot = Some(storage_buffer(device, label, bytes));
    }
    slot.clone().expect("grown above")
}

/// Whether each of a mesh's assembly inputs fits one binding of the device.
fn fits_one_binding(ctx: &GpuContext, mesh: &AssemblyMesh<'_>) -> bool {
    use std::mem::size_of_val as size;
    let largest = [size(mesh.faces), size(mesh.projected), size(mesh.attributes), size(mesh.face_normals)];
    largest.into_iter().all(|b| b as u64 <= ctx.max_binding())
}

impl GeometryKernels for GeometryDevice {
    fn vertex(
        &mut self,
        params: &VertexParams,
        positions: Positions<'_>,
        posing: Option<&Posing<'_>>,
        projected: &mut Vec<ProjectedVertex>,
    ) -> Result<u64, Error> {
        // A new frame: the last one's records go.
        self.frame = DeviceFrame::default();
        let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
        // The stage's pairs rest on what the `f32` modes rest on: correctly rounded `f32`
        // arithmetic, no contraction, subnormals kept.
        ctx.check_float_modes(Mode::Barycentric)?;
        // (A program built into the kernels runs in their module.)
        let program = posing.and_then(|p| p.stage.modules()).map(|m| ctx.program_index(m, Role::Vertex)).transpose()?;
        // The vertex texture, on the device once for as long as frames hand the same one; a
        // texture of the same size replaces only the texels that differ.
        let texture = posing.and_then(|p| p.texture);
        if let Some(t) = texture {
            let bytes = std::mem::size_of_val(&t.texels[..]) as u64;
            if bytes > ctx.max_binding() {
                return Err(Error::Gpu(format!("the vertex texture's {bytes} bytes exceed the device's largest binding, {} bytes", ctx.max_binding())));
            }
        }
        let update = tileraster_cpu::texture_update(posing, &positions, &mut self.held_texture);
        let buffer = match texture {
            Some(t) => {
                let whole = |ctx: &GpuContext| ctx.storage_with("vertex texture", bytemuck::cast_slice(&t.texels), 4);
                let buffer = match (self.texture.take(), update.clone()) {
                    // The same texels as the device holds.
                    (Some(held), None) => held.1,
                    (Some((_, buffer)), Some(texels)) if texels.len() < t.texels.len() => {
                        let offset = (texels.start * std::mem::size_of::<f32>()) as u64;
                        ctx.recorder.upload_at(&ctx.gpu.queue, &buffer, offset, bytemuck::cast_slice(&t.texels[texels]));
                        buffer
                    }
                    _ => whole(&ctx),
                };
                self.texture = Some((t.clone(), buffer.clone()));
                buffer
            }
            // (Bound all the same: the stage table's row has the binding.)
            None => self.no_texture.get_or_insert_with(|| ctx.storage_with("no vertex texture", &[], 16)).clone(),
        };
        let bytes = ctx.vertex_unchecked(params, positions, program, &buffer, &mut self.kept, &mut self.projected, projected)?;
        Ok(bytes + update.map_or(0, |texels| (texels.len() * std::mem::size_of::<f32>()) as u64))
    }

    fn assemble_count(&mut self, mesh: &AssemblyMesh<'_>) -> Result<AssemblyCount, Error> {
        let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
        let projected = self.projected.clone().filter(|p| p.size() >= std::mem::size_of_val(mesh.projected) as u64);
        let here = super::assembles_on_device(ctx.gpu.info.device_type) && fits_one_binding(&ctx, mesh);
        let (false, Some(projected), true) = (self.frame.on_twins, projected, here) else {
            self.frame.on_twins = true;
            return tileraster_cpu::GeometryTwins::default().assemble_count(mesh);
        };
        let scope = ctx.gpu.error_scope();
        let buffers = self.mesh_buffers(&ctx, mesh, projected);
        let count = ctx.count_rows(mesh, &buffers);
        let raised = scope.finish();
        if raised.is_some() || count.is_err() {
            // What a failed call may have left unwritten is handed over again.
            (self.faces, self.attributes) = (None, None);
        }
        if let Some(e) = raised {
            return Err(Error::Gpu(format!("the assembly's count: {e}")));
        }
        self.frame.counted.push_back(buffers);
        count
    }

    fn hold_records(&mut self, records: u64, listed: u64, small: u64) -> Result<Option<u64>, Error> {
        static KEYS: AtomicU64 = AtomicU64::new(1);
        let key = KEYS.fetch_add(1, Ordering::Relaxed);
        let ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
        let inputs = records * std::mem::size_of::<TriangleInput>() as u64;
        let shading = records * std::mem::size_of::<TriangleShading>() as u64;
        if self.frame.on_twins || inputs.max(shading) > ctx.max_binding() {
            self.frame.on_twins = true;
        } else {
            let (room, device) = (&mut self.room, &ctx.gpu.device);
            self.frame.records = Some(HeldRecords {
                key,
                records,
                listed,
                small,
                inputs: grown(device, &mut room.inputs, "triangle inputs", inputs),
                shading: grown(device, &mut room.shading, "triangle shading", shading),
                listed_slots: grown(device, &mut room.listed, "listed", 4 * listed),
                small_slots: grown(device, &mut room.small, "small listed", 4 * small),
            });
        }
        // (A frame its twins assemble is counted as the device would hand it over: its
        // records are uploaded whole by its raster call, as `Stats::bytes_uploaded` says.)
        Ok(Some(key))
    }

    fn light(&mut self, shade: &ShadeParams, attributes: &[[f32; ATTRIBUTES]], kept: Option<u64>, lit: &mut Vec<[f32; 4]>) -> Result<u64, Error> {
        let fills_here = !self.frame.on_twins && self.frame.records.is_some();
        let held = match (&self.attributes, kept) {
            (Some((held, attributes, _)), Some(key)) if *held == key => Some(attributes.clone()),
            _ => None,
        };
        let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
        let scope = ctx.gpu.error_scope();
        // Room for the colours on the device only where the device's fills read them.
        let colours = (attributes.len() * std::mem::size_of::<[f32; 4]>()) as u64;
        let out = fills_here.then(|| grown(&ctx.gpu.device, &mut self.room.lit, "lit colours", colours));
        match (&out, held) {
            (Some(out), Some(attributes_buffer)) => ctx.light_rows(shade, attributes.len() as u32, &attributes_buffer, out)?,
            _ => {
                // The twins fill, or the attributes are not on the device (then the colours go
                // up for the device's fills).
                tileraster_cpu::light(shade, attributes, lit);
                if let Some(out) = &out {
                    ctx.recorder.upload(&ctx.gpu.queue, out, bytemuck::cast_slice(lit));
                }
            }
        }
        if let Some(e) = scope.finish() {
            self.frame.lit = None;
            return Err(Error::Gpu(format!("the light stage: {e}")));
        }
        self.frame.lit = out;
        Ok(tileraster_core::render::light_bytes())
    }

    fn assemble_fill(&mut self, mesh: &AssemblyMesh<'_>, count: &AssemblyCount, patches: &AssemblyPatches, out: AssembledRecords<'_>) -> Result<u64, Error> {
        // (Counted as the twins count it: the figure is the backends' common one.)
        let bytes = mesh.bytes(patches, KeptHanded::of(&mesh.kept, &mut self.counted));
        let (false, Some(records), Some(counted)) = (self.frame.on_twins, &self.frame.records, self.frame.counted.pop_front()) else {
            // The frame's records are then the host's alone.
            (self.frame.on_twins, self.frame.records) = (true, None);
            tileraster_cpu::GeometryTwins::default().assemble_fill(mesh, count, patches, out)?;
            return Ok(bytes);
        };
        let target = RecordBuffers {
            inputs: records.inputs.clone(),
            shading: records.shading.clone(),
            listed: records.listed_slots.clone(),
            small: records.small_slots.clone(),
        };
        let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
        let scope = ctx.gpu.error_scope();
        let lit = self.frame.lit.clone();
        let filled = ctx.fill_rows(mesh, &counted, lit, count, patches, &target).and_then(|(encoder, _)| {
            // This mesh's records back, for the host's plan.
            let first = (mesh.params.first_listed + mesh.params.first_small) as u64;
            let at = |size: usize| first * size as u64;
            let input_bytes = std::mem::size_of_val(out.inputs) as u64;
            let shading_bytes = std::mem::size_of_val(out.shading) as u64;
            let parts = [
                (&target.inputs, at(std::mem::size_of::<TriangleInput>()), input_bytes),
                (&target.shading, at(std::mem::size_of::<TriangleShading>()), shading_bytes),
            ];
            let read = ctx.read_parts(encoder, &parts)?;
            bytemuck::cast_slice_mut::<_, u8>(out.inputs).copy_from_slice(&read[0]);
            bytemuck::cast_slice_mut::<_, u8>(out.shading).copy_from_slice(&read[1]);
            Ok(())
        });
        let raised = scope.finish();
        if raised.is_some() || filled.is_err() {
            self.frame.records = None;
        }
        if let Some(e) = raised {
            return Err(Error::Gpu(format!("the assembly's fill: {e}")));
        }
        filled?;
        Ok(bytes)
    }
}

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

/// Run the assembly's rows on the device over `mesh` alone (its records from slot 0, whatever
/// its `first_listed` and `first_small`), `patches` standing for the host's clipping of the
/// faces the count leaves it (they must be the ones it leaves): each row's output read back,
/// for the comparison of the backends stage by stage.
pub fn assemble_rows(mesh: &AssemblyMesh<'_>, patches: &AssemblyPatches) -> Result<AssembledOnDevice, Error> {
    let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
    ctx.check_float_modes(Mode::Barycentric)?;
    let scope = ctx.gpu.error_scope();
    let result = ctx.assemble_rows(mesh, patches);
    if let Some(e) = scope.finish() {
        return Err(Error::Gpu(format!("the assembly stages: {e}")));
    }
    result
}

/// Run the light stage on the device over `attributes` with the lights of `shade`, its
/// colours read back: for the comparison of the backends stage by stage.
pub fn light_rows(shade: &ShadeParams, attributes: &[[f32; ATTRIBUTES]]) -> Result<Vec<[f32; 4]>, Error> {
    let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
    ctx.check_float_modes(Mode::Barycentric)?;
    let scope = ctx.gpu.error_scope();
    let bytes = (attributes.len() * std::mem::size_of::<[f32; 4]>()) as u64;
    let buffer = ctx.storage_with("vertex attributes", bytemuck::cast_slice(attributes), 0);
    let out = ctx.storage_with("lit colours", &[], bytes);
    let read = ctx.light_rows(shade, attributes.len() as u32, &buffer, &out).and_then(|()| {
        let encoder = ctx.gpu.device.create_command_encoder(&Default::default());
        ctx.read_parts(encoder, &[(&out, 0, bytes)])
    });
    if let Some(e) = scope.finish() {
        return Err(Error::Gpu(format!("the light stage: {e}")));
    }
    Ok(bytemuck::pod_collect_to_vec(&read?[0]))
}

impl GpuContext {
    /// The index in `self.pipelines` of the pipeline of frame stage `stage`, built on first use.
    pub(super) fn frame_row(&mut self, stage: Stage) -> usize {
        self.frame_row_of(stage, None)
    }

    /// [`Self::frame_row`] from the module of the user's shader `program` (an index into
    /// `programs`), else the kernels'.
    pub(super) fn frame_row_of(&mut self, stage: Stage, program: Option<usize>) -> usize {
        let row = STAGES.iter().position(|s| s.stage == stage).expect("every stage has a row");
        let build = super::Build { row, program, spec: [None; 2] };
        if let Some(k) = self.pipelines.iter().position(|(b, _)| *b == build) {
            return k;
        }
        let info = &STAGES[row];
        let (module, label) = self.module_of(&build);
        let module = super::passthrough_module(&self.gpu.device, &label, module, &build.spec, |other| other.stage == info.stage);
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

    /// A storage buffer holding `data`, of at least `room` bytes.
    fn storage_with(&self, label: &str, data: &[u8], room: u64) -> wgpu::Buffer {
        let buffer = storage_buffer(&self.gpu.device, label, (data.len() as u64).max(room));
        if !data.is_empty() {
            self.recorder.upload(&self.gpu.queue, &buffer, data);
        }
        buffer
    }

    /// Copy `parts` (buffer, offset, bytes) out of the device in one submission after
    /// `encoder`'s work.
    fn read_parts(&mut self, mut encoder: wgpu::CommandEncoder, parts: &[(&wgpu::Buffer, u64, u64)]) -> Result<Vec<Vec<u8>>, Error> {
        let total: u64 = parts.iter().map(|p| p.2).sum();
        let readback = self.buffers.readback.get(&self.gpu.device, total.max(4));
        let mut at = 0;
        for &(buffer, offset, bytes) in parts {
            if bytes > 0 {
                encoder.copy_buffer_to_buffer(buffer, offset, &readback, at, bytes);
            }
            at += bytes;
        }
        self.recorder.submit();
        self.recorder.wait(total);
        let mut out = Vec::new();
        let split = |b: &[u8]| {
            let mut at = 0;
            for &(_, _, bytes) in parts {
                out.push(b[at as usize..(at + bytes) as usize].to_vec());
                at += bytes;
            }
        };
        self.gpu.submit_and_read(encoder, &readback, total.max(4), split).map_err(|e| Error::Gpu(format!("the assembly stages: {e}")))?;
        Ok(out)
    }

    /// Workgroups for `faces`, in 2D past [`MAX_GROUPS`], and `params` with their shape.
    fn face_dispatch(params: &AssembleParams) -> ((u32, u32), AssembleParams) {
        let groups = params.faces.div_ceil(FACE_GROUP).max(1);
        let (x, y) = (groups.min(MAX_GROUPS), groups.div_ceil(MAX_GROUPS));
        ((x, y), AssembleParams { groups: params.faces.div_ceil(FACE_GROUP), dispatch_width: x * FACE_GROUP, ..*params })
    }

    /// The light stage over the frame's `vertices` (their `attributes` on the device) into
    /// `out`, submitted: the fills that read the colours are submitted after it.
    fn light_rows(&mut self, shade: &ShadeParams, vertices: u32, attributes: &wgpu::Buffer, out: &wgpu::Buffer) -> Result<(), Error> {
        let groups = vertices.div_ceil(TRIANGLE_GROUP).max(1);
        let (x, y) = (groups.min(MAX_GROUPS), groups.div_ceil(MAX_GROUPS));
        let params = LightParams { vertices, dispatch_width: x * TRIANGLE_GROUP, _pad: [0; 2] };
        let params_buf = self.storage_with("light params", bytemuck::bytes_of(&params), 0);
        let shade_buf = self.storage_with("shade params", bytemuck::bytes_of(shade), 0);
        let rows = self.frame_rows(&[Stage::Light]);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        let bound = |buffer| match buffer {
            Buffer::LightParams => Some(params_buf.clone()),
            Buffer::ShadeParams => Some(shade_buf.clone()),
            Buffer::VertexAttributes => Some(attributes.clone()),
            Buffer::LitColours => Some(out.clone()),
            _ => None,
        };
        self.encode_stages(&mut encoder, Pipeline::Render, &rows, Scope::Frame, &Default::default(), (x, y), &bound)?;
        self.recorder.submit();
        self.gpu.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// `assemble_count` over `mesh`'s faces in `buffers`, its count read back: its group
    /// counts and counters, then the faces it left to the host (where it left any), in face
    /// order.
    fn count_rows(&mut self, mesh: &AssemblyMesh<'_>, buffers: &CountedMesh) -> Result<AssemblyCount, Error> {
        let (groups, params) = Self::face_dispatch(&mesh.params);
        let params_buf = self.storage_with("assemble params", bytemuck::bytes_of(&params), 0);
        let count_bytes = 8 * params.groups as u64;
        let counters = self.storage_with("assembly counters", &[], 4 * ASSEMBLY_COUNTERS as u64);
        let clipped = self.storage_with("clipped faces", &[], 4 * params.faces as u64);
        let rows = self.frame_rows(&[Stage::AssembleCount]);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&buffers.group_counts, 0, None);
        encoder.clear_buffer(&counters, 0, None);
        let bound = |buffer| match buffer {
            Buffer::AssembleParams => Some(params_buf.clone()),
            Buffer::FaceIndices => Some(buffers.faces.clone()),
            Buffer::Projected => Some(buffers.projected.clone()),
            Buffer::FaceMaterials => Some(buffers.materials.clone()),
            Buffer::GroupCounts => Some(buffers.group_counts.clone()),
            Buffer::AssemblyCounters => Some(counters.clone()),
            Buffer::ClippedFaces => Some(clipped.clone()),
            _ => None,
        };
        self.encode_stages(&mut encoder, Pipeline::Render, &rows, Scope::Frame, &Default::default(), groups, &bound)?;
        let read = self.read_parts(encoder, &[(&buffers.group_counts, 0, count_bytes), (&counters, 0, 4 * ASSEMBLY_COUNTERS as u64)])?;
        let group_counts: Vec<u32> = bytemuck::pod_collect_to_vec(&read[0]);
        let counters_host: Vec<u32> = bytemuck::pod_collect_to_vec(&read[1]);
        let counters_host: [u32; ASSEMBLY_COUNTERS] = counters_host.try_into().expect("the counters' words");
        let left = counters_host[CLIPPED_ON_HOST as usize] as u64;
        let mut clipped_host: Vec<u32> = Vec::new();
        if left > 0 {
            let encoder = self.gpu.device.create_command_encoder(&Default::default());
            clipped_host = bytemuck::pod_collect_to_vec(&self.read_parts(encoder, &[(&clipped, 0, 4 * left)])?[0]);
            clipped_host.sort_unstable();
        }
        Ok(AssemblyCount { group_counts, counters: counters_host, clipped: clipped_host })
    }

    /// `assemble_scan` and `assemble_fill` over `mesh`'s faces in `buffers`, `count` being
    /// what `count_rows` read back, into `target` (at the mesh's `first_listed` and
    /// `first_small`): recorded into the returned encoder, not yet submitted, with the group
    /// offsets' buffer.
    #[allow(clippy::too_many_arguments)]
    fn fill_rows(
        &mut self,
        mesh: &AssemblyMesh<'_>,
        buffers: &CountedMesh,
        lit: Option<wgpu::Buffer>,
        count: &AssemblyCount,
        patches: &AssemblyPatches,
        target: &RecordBuffers,
    ) -> Result<(wgpu::CommandEncoder, wgpu::Buffer), Error> {
        debug_assert_eq!(count.group_counts.len() as u32, 2 * mesh.params.faces.div_ceil(FACE_GROUP));
        let (groups, params) = Self::face_dispatch(&AssembleParams { patches: patches.patches.len() as u32, ..mesh.params });
        let params_buf = self.storage_with("assemble params", bytemuck::bytes_of(&params), 0);
        let patch_buf = self.storage_with("patches", bytemuck::cast_slice(&patches.patches), 0);
        let pieces = self.storage_with("pieces", bytemuck::cast_slice(&patches.inputs), 0);
        let piece_shading = self.storage_with("piece shading", bytemuck::cast_slice(&patches.shading), 0);
        let offsets = self.storage_with("group offsets", &[], 8 * params.groups as u64 + 8);
        // The frame's lights, handed over where the fill lights faces; the light stage's
        // colours where it lit the vertices (else the mesh's, or none).
        let lights = if params.lighting == LIGHT_FACES { bytemuck::bytes_of(mesh.shade) } else { &[][..] };
        let shade = self.storage_with("shade params", lights, std::mem::size_of::<ShadeParams>() as u64);
        let lit = lit.unwrap_or_else(|| self.storage_with("lit colours", bytemuck::cast_slice(mesh.lit), 0));
        let rows = self.frame_rows(&[Stage::AssembleScan, Stage::AssembleFill]);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        let bound = |buffer| match buffer {
            Buffer::AssembleParams => Some(params_buf.clone()),
            Buffer::FaceIndices => Some(buffers.faces.clone()),
            Buffer::Projected => Some(buffers.projected.clone()),
            Buffer::VertexAttributes => Some(buffers.attributes.clone()),
            Buffer::LitColours => Some(lit.clone()),
            Buffer::FaceNormals => Some(buffers.face_normals.clone()),
            Buffer::ShadeParams => Some(shade.clone()),
            Buffer::FaceMaterials => Some(buffers.materials.clone()),
            Buffer::GroupCounts => Some(buffers.group_counts.clone()),
            Buffer::Patches => Some(patch_buf.clone()),
            Buffer::Pieces => Some(pieces.clone()),
            Buffer::PieceShading => Some(piece_shading.clone()),
            Buffer::GroupOffsets => Some(offsets.clone()),
            Buffer::Inputs => Some(target.inputs.clone()),
            Buffer::Shading => Some(target.shading.clone()),
            Buffer::Listed => Some(target.listed.clone()),
            Buffer::SmallListed => Some(target.small.clone()),
            _ => None,
        };
        self.encode_stages(&mut encoder, Pipeline::Render, &rows, Scope::Frame, &Default::default(), groups, &bound)?;
        Ok((encoder, offsets))
    }

    fn assemble_rows(&mut self, mesh: &AssemblyMesh<'_>, patches: &AssemblyPatches) -> Result<AssembledOnDevice, Error> {
        let mesh = AssemblyMesh { params: AssembleParams { first_listed: 0, first_small: 0, ..mesh.params }, ..*mesh };
        let buffers = CountedMesh {
            faces: self.storage_with("face indices", bytemuck::cast_slice(mesh.faces), 0),
            materials: self.storage_with("face materials", bytemuck::cast_slice(mesh.materials), 0),
            projected: self.storage_with("projected vertices", bytemuck::cast_slice(mesh.projected), 0),
            attributes: self.storage_with("vertex attributes", bytemuck::cast_slice(mesh.attributes), 0),
            face_normals: self.storage_with("face normals", bytemuck::cast_slice(mesh.face_normals), 0),
            group_counts: self.storage_with("group counts", &[], 8 * mesh.params.faces.div_ceil(FACE_GROUP) as u64),
        };
        let count = self.count_rows(&mesh, &buffers)?;

        // The ranks and the records.
        let sum = |k: usize| count.group_counts.iter().skip(k).step_by(2).map(|&n| n as u64).sum::<u64>();
        let listed = sum(0) + patches.patches.iter().map(|p| p.listed as u64).sum::<u64>();
        let small = sum(1) + patches.patches.iter().map(|p| p.small as u64).sum::<u64>();
        let records = listed + small;
        let input_bytes = records * std::mem::size_of::<TriangleInput>() as u64;
        let shading_bytes = records * std::mem::size_of::<TriangleShading>() as u64;
        let target = RecordBuffers {
            inputs: self.storage_with("triangle inputs", &[], input_bytes),
            shading: self.storage_with("triangle shading", &[], shading_bytes),
            listed: self.storage_with("listed", &[], 4 * listed),
            small: self.storage_with("small listed", &[], 4 * small),
        };
        let (encoder, offsets) = self.fill_rows(&mesh, &buffers, None, &count, patches, &target)?;
        let offsets_bytes = 8 * mesh.params.faces.div_ceil(FACE_GROUP) as u64 + 8;
        let parts = [
            (&offsets, 0, offsets_bytes),
            (&target.inputs, 0, input_bytes),
            (&target.shading, 0, shading_bytes),
            (&target.listed, 0, 4 * listed),
            (&target.small, 0, 4 * small),
        ];
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
