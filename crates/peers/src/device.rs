//! Opening a wgpu device, shared by the GPU peers.

/// An open device with what the peers need to know about it.
pub(crate) struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
}

impl Gpu {
    /// Open the preferred Vulkan adapter: a discrete GPU first, a CPU implementation such as
    /// lavapipe last. `TILERASTER_ADAPTER=<substring>` (case-insensitive) picks one by name.
    pub fn open(label: &str) -> Result<Gpu, String> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        let adapter = choose_adapter(adapters)?;
        // The adapter's own limits, not wgpu's conservative defaults: large rasters need them.
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some(label),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| format!("the device could not be opened: {e}"))?;
        // Errors are collected by error scopes around each call; never panic on them.
        device.on_uncaptured_error(std::sync::Arc::new(|e| eprintln!("tileraster-peers: uncaptured GPU error: {e}")));
        Ok(Gpu { device, queue, info: adapter.get_info(), limits })
    }

    /// Largest buffer a shader may bind as storage.
    pub fn max_storage_binding(&self) -> u64 {
        self.limits.max_storage_buffer_binding_size.min(self.limits.max_buffer_size)
    }

    /// Run `f`, turning validation and out-of-memory errors it raised into an `Err`.
    pub fn scoped<T>(&mut self, f: impl FnOnce(&mut Gpu) -> Result<T, String>) -> Result<T, String> {
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let result = f(self);
        let memory_error = pollster::block_on(memory.pop());
        let validation_error = pollster::block_on(validation.pop());
        let value = result?;
        match memory_error.or(validation_error) {
            Some(e) => Err(format!("GPU error: {e}")),
            None => Ok(value),
        }
    }

    /// Submit `encoder`, then map the first `bytes` of `readback` and hand them to `read`.
    pub fn submit_and_read(
        &self,
        encoder: wgpu::CommandEncoder,
        readback: &wgpu::Buffer,
        bytes: u64,
        read: impl FnOnce(&[u8]),
    ) -> Result<(), String> {
        self.queue.submit([encoder.finish()]);
        let slice = readback.slice(..bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| format!("waiting for the GPU failed: {e}"))?;
        rx.recv()
            .map_err(|_| "the readback was dropped".to_string())?
            .map_err(|e| format!("mapping the readback buffer failed: {e}"))?;
        {
            let view = slice.get_mapped_range().map_err(|e| format!("mapping the readback buffer failed: {e}"))?;
            read(&view);
        }
        readback.unmap();
        Ok(())
    }
}

/// The adapter tileraster's GPU backend uses (its choice, `TILERASTER_ADAPTER` included), so
/// that the peers run on the same device as the kernels they are compared with.
fn choose_adapter(adapters: Vec<wgpu::Adapter>) -> Result<wgpu::Adapter, String> {
    let name = tileraster_gpu::adapter().map_err(|e| e.to_string())?.name;
    let seen: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
    adapters
        .into_iter()
        .find(|a| a.get_info().name == name)
        .ok_or_else(|| format!("tileraster's adapter {name:?} is not among {seen:?}"))
}

/// A buffer that grows when a call needs more and is otherwise kept across calls.
pub(crate) struct Grown {
    buffer: Option<wgpu::Buffer>,
    label: &'static str,
    usage: wgpu::BufferUsages,
}

impl Grown {
    pub fn new(label: &'static str, usage: wgpu::BufferUsages) -> Self {
        Grown { buffer: None, label, usage }
    }

    /// At least `bytes` (and at least 16) bytes.
    pub fn get(&mut self, device: &wgpu::Device, bytes: u64) -> wgpu::Buffer {
        let bytes = bytes.max(16).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
        if self.buffer.as_ref().is_none_or(|b| b.size() < bytes) {
            // Drop the old one first so both never hold memory at once.
            self.buffer = None;
            self.buffer = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size: bytes,
                usage: self.usage,
                mapped_at_creation: false,
            }));
        }
        self.buffer.clone().expect("just created")
    }
}
