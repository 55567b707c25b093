//! The two kinds of shared-memory access the binning stages make, behind traits so that the
//! same stage function runs on a GPU storage buffer and on the host's atomics.

/// Atomic counters in device memory.
pub trait Counters {
    /// Adds `value` to counter `index` and returns the previous value.
    fn fetch_add(&mut self, index: usize, value: u32) -> u32;
}

/// A `u32` buffer written at distinct indices by many invocations.
pub trait Slots {
    fn store(&mut self, index: usize, value: u32);
}

#[cfg(target_arch = "spirv")]
impl Counters for [u32] {
    fn fetch_add(&mut self, index: usize, value: u32) -> u32 {
        use spirv_std::memory::{Scope, Semantics};
        // Queue-family scope covers every invocation of the dispatch; device scope would need
        // the VulkanMemoryModelDeviceScope capability for no gain here.
        unsafe { spirv_std::arch::atomic_i_add::<u32, { Scope::QueueFamily as u32 }, { Semantics::NONE.bits() }>(&mut self[index], value) }
    }
}

impl Slots for [u32] {
    fn store(&mut self, index: usize, value: u32) {
        self[index] = value;
    }
}
