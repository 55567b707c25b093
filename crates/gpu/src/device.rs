//! Opening a Vulkan device through wgpu, and the helpers every user of one needs: error
//! scopes, buffers that grow, submit-and-read-back. The GPU backend uses them, and so do the
//! benchmark's GPU peers, which must run on the same adapter. Errors are plain strings here;
//! each user maps them into its own error type.

/// Run `f` with the process's one Vulkan instance, one caller at a time. Vulkan drivers,
/// NVIDIA's among them, have raced when several threads created instances or opened devices at
/// once, so every instance use here (listing adapters, opening devices) goes through this lock.
/// It is no licence to draw on several devices from several threads at once: the GPU peers,
/// which did, still hung on an NVIDIA H200 with it, and take turns on one device instead.
pub fn with_instance<T>(f: impl FnOnce(&wgpu::Instance) -> T) -> T {
    static INSTANCE: std::sync::OnceLock<std::sync::Mutex<wgpu::Instance>> = std::sync::OnceLock::new();
    let instance = INSTANCE.get_or_init(|| {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        std::sync::Mutex::new(wgpu::Instance::new(desc))
    });
    // A panic in another caller's `f` leaves the instance as it was: the lock's poison says nothing here.
    let instance = instance.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    f(&instance)
}

/// An open device with what its users need to know about it.
#[derive(Clone)]
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
}

impl Gpu {
    /// Open the Vulkan adapter `choose` picks, with `features`, those of `optional` it has, and
    /// the adapter's own limits (not wgpu's conservative defaults: large rasters need them). Returns the adapter too, for what
    /// wgpu reads only from it. Uncaptured errors are printed with `label`, never panicked on:
    /// callers collect errors with [`Gpu::error_scope`].
    pub fn open(
        label: &str,
        features: wgpu::Features,
        optional: wgpu::Features,
        choose: impl FnOnce(Vec<wgpu::Adapter>) -> Result<wgpu::Adapter, String>,
    ) -> Result<(Gpu, wgpu::Adapter), String> {
        let (adapter, device, queue) = with_instance(|instance| {
            let adapter = choose(pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN)))?;
            let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some(label),
                required_features: features | (adapter.features() & optional),
                required_limits: adapter.limits(),
                ..Default::default()
            }))
            .map_err(|e| format!("the device could not be opened: {e}"))?;
            Ok::<_, String>((adapter, device, queue))
        })?;
        let limits = adapter.limits();
        let label = label.to_string();
        device.on_uncaptured_error(std::sync::Arc::new(move |e| eprintln!("{label}: uncaptured GPU error: {e}")));
        Ok((Gpu { device, queue, info: adapter.get_info(), limits }, adapter))
    }

    /// Largest buffer a shader may bind as storage.
    pub fn max_storage_binding(&self) -> u64 {
        self.limits.max_storage_buffer_binding_size.min(self.limits.max_buffer_size)
    }

    /// Start collecting validation and out-of-memory errors; [`ErrorScope::finish`] says
    /// whether any was raised.
    pub fn error_scope(&self) -> ErrorScope {
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        ErrorScope { validation, memory }
    }

    /// Run `f`, turning validation and out-of-memory errors it raised into an `Err`.
    pub fn scoped<T>(&mut self, f: impl FnOnce(&mut Gpu) -> Result<T, String>) -> Result<T, String> {
        let scope = self.error_scope();
        let result = f(self);
        let raised = scope.finish();
        let value = result?;
        match raised {
            Some(e) => Err(format!("GPU error: {e}")),
            None => Ok(value),
        }
    }

    /// Submit `encoder`, wait for it, then map the first `bytes` of `readback` and hand them to
    /// `read`.
    pub fn submit_and_read(&self, encoder: wgpu::CommandEncoder, readback: &wgpu::Buffer, bytes: u64, read: impl FnOnce(&[u8])) -> Result<(), String> {
        self.queue.submit([encoder.finish()]);
        let slice = readback.slice(..bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        let mapped = (|| {
            self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| format!("waiting for the GPU failed: {e}"))?;
            rx.recv().map_err(|_| "the readback was dropped".to_string())?.map_err(|e| format!("mapping the readback buffer failed: {e}"))?;
            let view = slice.get_mapped_range().map_err(|e| format!("mapping the readback buffer failed: {e}"))?;
            read(&view);
            Ok(())
        })();
        // Unmapped on every way out: the buffer is read back into again by later calls.
        readback.unmap();
        mapped
    }
}

/// Uploads from twice this size up are copied into the queue's staging memory on all cores, in
/// pieces of it.
const UPLOAD_PIECE: usize = 1 << 20;

/// Write `data` at byte `offset` of `buffer` (both multiples of 4) through the queue, as
/// `Queue::write_buffer` does, but copying a large upload on all cores: the staging memory is a
/// new allocation on every call, and one core's copy of a 100k-triangle scene's 30 MB took
/// 3 ms on a 16-core host with an NVIDIA H100 (1.1 ms on all cores).
pub fn write_buffer(queue: &wgpu::Queue, buffer: &wgpu::Buffer, offset: u64, data: &[u8]) {
    use rayon::prelude::*;
    let size = match wgpu::BufferSize::new(data.len() as u64) {
        Some(size) if data.len() >= 2 * UPLOAD_PIECE => size,
        _ => return queue.write_buffer(buffer, offset, data),
    };
    // `None` where validation failed or no staging memory was left: wgpu reports either to the
    // error scopes this thread has pushed.
    let Some(mut view) = queue.write_buffer_with(buffer, offset, size) else { return };
    let mut whole = view.slice(..);
    // The address as an integer, for the tasks: each writes its own piece alone, while `view`
    // lives (`WriteOnly::as_raw_ptr` is given for such writes from several threads).
    debug_assert_eq!(whole.len(), data.len());
    let base = whole.as_raw_element_ptr().as_ptr() as usize;
    data.par_chunks(UPLOAD_PIECE).enumerate().for_each(|(k, piece)| {
        // SAFETY: the piece's range lies inside the mapping of `data.len()` bytes, no other task
        // writes it, and nothing reads the mapping until `view` is dropped.
        unsafe { std::ptr::copy_nonoverlapping(piece.as_ptr(), (base + k * UPLOAD_PIECE) as *mut u8, piece.len()) };
    });
}

/// Validation and out-of-memory errors being collected (see [`Gpu::error_scope`]).
pub struct ErrorScope {
    validation: wgpu::ErrorScopeGuard,
    memory: wgpu::ErrorScopeGuard,
}

impl ErrorScope {
    /// Stop collecting: the first error raised meanwhile, out-of-memory first.
    pub fn finish(self) -> Option<String> {
        // Scopes pop in the reverse order of their pushes.
        let memory = pollster::block_on(self.memory.pop());
        let validation = pollster::block_on(self.validation.pop());
        memory.or(validation).map(|e| e.to_string())
    }
}

/// A buffer that grows when a call needs more and is otherwise kept across calls.
pub struct Grown {
    buffer: Option<wgpu::Buffer>,
    label: &'static str,
    usage: wgpu::BufferUsages,
}

impl Grown {
    pub fn new(label: &'static str, usage: wgpu::BufferUsages) -> Self {
        Grown { buffer: None, label, usage }
    }

    /// A storage buffer that kernels read and write and the host fills and copies from.
    pub fn storage(label: &'static str) -> Self {
        Self::new(label, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC)
    }

    /// A uniform buffer that the host fills.
    pub fn uniform(label: &'static str) -> Self {
        Self::new(label, wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST)
    }

    /// A buffer the host maps to read results back.
    pub fn readback(label: &'static str) -> Self {
        Self::new(label, wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST)
    }

    /// At least `bytes` (and at least 16) bytes, a whole number of copy units.
    pub fn get(&mut self, device: &wgpu::Device, bytes: u64) -> wgpu::Buffer {
        let bytes = bytes.max(16).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
        if self.buffer.as_ref().is_none_or(|b| b.size() < bytes) {
            // Drop the old one first so both never hold memory at once.
            self.buffer = None;
            self.buffer =
                Some(device.create_buffer(&wgpu::BufferDescriptor { label: Some(self.label), size: bytes, usage: self.usage, mapped_at_creation: false }));
        }
        self.buffer.clone().expect("just created")
    }
}
