//! Where a GPU call's time and traffic go: device time per stage from timestamp queries (where
//! the adapter has them), and the count of dispatches, submissions, waits for the device and
//! bytes moved each way. `cargo xtask stage-times --backend gpu` prints them beside the CPU
//! backend's stage times.

use std::cell::{Cell, RefCell};
use std::time::{Duration, Instant};
use tileraster_kernels::pipeline::{STAGES, Stage};

/// What one call did on the device.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CallProfile {
    /// Device time per stage of the table, in milliseconds, summed over the call's windows
    /// (indexed by `Stage as usize`); `None` where the adapter has no timestamp queries or the
    /// call was not profiled.
    pub stage_ms: Option<Vec<f64>>,
    /// Compute dispatches recorded.
    pub dispatches: u64,
    /// Command buffers submitted.
    pub submissions: u64,
    /// Times the host waited for the device (each read-back is one).
    pub waits: u64,
    /// Bytes written from the host to device buffers.
    pub bytes_up: u64,
    /// Bytes copied back from the device to the host.
    pub bytes_down: u64,
    /// Windows the raster was cut into.
    pub windows: u64,
    /// Host time spent handing uploads to the queue (copies into its staging memory), ms.
    pub upload_ms: f64,
    /// Host time from each read-back's submission until its buffer was mapped, and its unmapping
    /// (finishing the command buffer, the queue's submission, the device's work, the copies
    /// over the bus and the driver's waits), ms. Stage read-backs (`stage_buffers`) count in
    /// `waits` but not here.
    pub wait_ms: f64,
    /// Host time copying the mapped read-back into the raster's layers, ms.
    pub read_back_ms: f64,
}

impl CallProfile {
    /// The device time of `stage` in milliseconds, if measured.
    pub fn stage(&self, stage: Stage) -> Option<f64> {
        self.stage_ms.as_ref().map(|ms| ms[stage as usize])
    }
}

/// The counters a context keeps for the call in progress.
#[derive(Default)]
pub(crate) struct Recorder {
    dispatches: Cell<u64>,
    submissions: Cell<u64>,
    waits: Cell<u64>,
    bytes_up: Cell<u64>,
    bytes_down: Cell<u64>,
    windows: Cell<u64>,
    upload: Cell<Duration>,
    wait: Cell<Duration>,
    read_back: Cell<Duration>,
    /// Whether the call in progress writes timestamps around its passes.
    timing: Cell<bool>,
    /// Query read-backs recorded and not yet read: each holds the timestamps of its stages'
    /// passes, a begin and an end each.
    pending: RefCell<Vec<(wgpu::Buffer, Vec<Stage>)>>,
}

fn bump(cell: &Cell<u64>, by: u64) {
    cell.set(cell.get() + by);
}

impl Recorder {
    /// Start a call: every counter at zero, with timestamps or not.
    pub fn start(&self, timing: bool) {
        for c in [&self.dispatches, &self.submissions, &self.waits, &self.bytes_up, &self.bytes_down, &self.windows] {
            c.set(0);
        }
        for c in [&self.upload, &self.wait, &self.read_back] {
            c.set(Duration::ZERO);
        }
        self.timing.set(timing);
        self.pending.borrow_mut().clear();
    }

    pub fn timing(&self) -> bool {
        self.timing.get()
    }

    pub fn dispatch(&self) {
        bump(&self.dispatches, 1);
    }

    pub fn submit(&self) {
        bump(&self.submissions, 1);
    }

    pub fn wait(&self, bytes_down: u64) {
        bump(&self.waits, 1);
        bump(&self.bytes_down, bytes_down);
    }

    /// Write `data` at the start of `buffer`, counting its bytes.
    pub fn upload(&self, queue: &wgpu::Queue, buffer: &wgpu::Buffer, data: &[u8]) {
        self.upload_at(queue, buffer, 0, data);
    }

    /// Write `data` at byte `offset` of `buffer` (a multiple of 4), counting its bytes.
    pub fn upload_at(&self, queue: &wgpu::Queue, buffer: &wgpu::Buffer, offset: u64, data: &[u8]) {
        bump(&self.bytes_up, data.len() as u64);
        let start = Instant::now();
        crate::device::write_buffer(queue, buffer, offset, data);
        self.upload.set(self.upload.get() + start.elapsed());
    }

    /// A read-back that took `total` from its submission to the end of its copy, `copying` of
    /// it in the host's copy out of the mapped buffer.
    pub fn read_back(&self, total: Duration, copying: Duration) {
        self.wait.set(self.wait.get() + total.saturating_sub(copying));
        self.read_back.set(self.read_back.get() + copying);
    }

    pub fn window(&self) {
        bump(&self.windows, 1);
    }

    /// Write a timestamp before and after each of `stages`' passes into a query set of their
    /// own, resolved into a buffer the host reads when the call ends. Returns the query set, the
    /// n-th pass writing queries 2n and 2n + 1.
    pub fn time_passes(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        stages: Vec<Stage>,
        record: impl FnOnce(&mut wgpu::CommandEncoder, &wgpu::QuerySet),
    ) {
        let count = 2 * stages.len() as u32;
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor { label: Some("stage timestamps"), ty: wgpu::QueryType::Timestamp, count });
        record(encoder, &queries);
        let bytes = count as u64 * wgpu::QUERY_SIZE as u64;
        let buffer = |usage| device.create_buffer(&wgpu::BufferDescriptor { label: Some("stage timestamps"), size: bytes, usage, mapped_at_creation: false });
        let resolved = buffer(wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC);
        let readback = buffer(wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
        encoder.resolve_query_set(&queries, 0..count, &resolved, 0);
        encoder.copy_buffer_to_buffer(&resolved, 0, &readback, 0, bytes);
        self.pending.borrow_mut().push((readback, stages));
    }

    /// The call's profile, reading the timestamps back (after every submission has finished).
    /// Later calls write no timestamps until the next [`Self::start`] asks for them.
    pub fn finish(&self, device: &wgpu::Device, period_ns: f32) -> Result<CallProfile, String> {
        let stage_ms = if self.timing.replace(false) {
            let mut ms = vec![0.0; STAGES.len()];
            for (readback, stages) in self.pending.borrow_mut().drain(..) {
                let slice = readback.slice(..);
                slice.map_async(wgpu::MapMode::Read, |_| {});
                device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| format!("waiting for the timestamps: {e}"))?;
                let view = slice.get_mapped_range().map_err(|e| format!("mapping the timestamps: {e}"))?;
                let ticks: &[u64] = bytemuck::cast_slice(&view);
                for (n, stage) in stages.iter().enumerate() {
                    ms[*stage as usize] += ticks[2 * n + 1].saturating_sub(ticks[2 * n]) as f64 * period_ns as f64 / 1e6;
                }
            }
            Some(ms)
        } else {
            None
        };
        Ok(CallProfile {
            stage_ms,
            dispatches: self.dispatches.get(),
            submissions: self.submissions.get(),
            waits: self.waits.get(),
            bytes_up: self.bytes_up.get(),
            bytes_down: self.bytes_down.get(),
            windows: self.windows.get(),
            upload_ms: self.upload.get().as_secs_f64() * 1e3,
            wait_ms: self.wait.get().as_secs_f64() * 1e3,
            read_back_ms: self.read_back.get().as_secs_f64() * 1e3,
        })
    }
}
