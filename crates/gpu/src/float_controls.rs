//! The float arithmetic of the `f32` value modes on an adapter.
//!
//! Exact mode is integers only. `plane-f32` and `barycentric` add and multiply `f32`s, each
//! result marked `NoContraction` (see `build.rs`); Vulkan still leaves two things to the
//! driver unless a shader declares them: the rounding direction, and whether subnormal
//! operands and results are flushed to zero (NVIDIA's driver flushes by default). The kernels
//! declare round-to-nearest-even and subnormal preservation where the adapter reports it can
//! honour them (`VkPhysicalDeviceFloatControlsProperties`), and before the first `f32`-mode
//! frame the backend checks, on a small frame built to expose both, that the adapter gives the
//! CPU backend's bits. An adapter that does not is refused for those modes with a typed error.

use tileraster_core::{Error, Grid, Mode, Params, Raster, Scene, prepare};

/// What the adapter reports it can guarantee for 32-bit floats when a shader declares it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FloatControls {
    /// `shaderRoundingModeRTEFloat32`: round to nearest, ties to even, on request.
    pub rounding_rte: bool,
    /// `shaderDenormPreserveFloat32`: subnormals kept, on request.
    pub denorm_preserve: bool,
}

impl FloatControls {
    /// The adapter's float-control properties (Vulkan 1.2, or `VK_KHR_shader_float_controls`);
    /// all `false` where it reports none.
    pub fn of(adapter: &wgpu::Adapter) -> Self {
        // SAFETY: the hal adapter is only read, while `adapter` keeps it alive.
        let Some(hal) = (unsafe { adapter.as_hal::<wgpu::hal::api::Vulkan>() }) else {
            return FloatControls::default();
        };
        let shared = hal.shared_instance();
        // vkGetPhysicalDeviceProperties2 is Vulkan 1.1; wgpu asks for at least that where it can.
        if shared.instance_api_version() < ash::vk::API_VERSION_1_1 {
            return FloatControls::default();
        }
        let mut controls = ash::vk::PhysicalDeviceFloatControlsProperties::default();
        let mut properties = ash::vk::PhysicalDeviceProperties2::default().push_next(&mut controls);
        // SAFETY: a valid physical device of this instance, and a well-formed `pNext` chain. A
        // device that knows no float controls leaves the chained struct as it was (all false).
        unsafe { shared.raw_instance().get_physical_device_properties2(hal.raw_physical_device(), &mut properties) };
        FloatControls {
            rounding_rte: controls.shader_rounding_mode_rte_float32 == ash::vk::TRUE,
            denorm_preserve: controls.shader_denorm_preserve_float32 == ash::vk::TRUE,
        }
    }

    /// Whether the kernels declare both (the module with float controls): where the adapter
    /// reports both, and on NVIDIA's proprietary driver, which reports no subnormal
    /// preservation yet honours the declaration (as vkd3d-proton relies on for Shader Model
    /// 6.2) and flushes subnormals without it. Either way the backend's check on the probe frame
    /// decides whether the `f32` modes run.
    pub fn declared(&self, info: &wgpu::AdapterInfo) -> bool {
        self.rounding_rte && (self.denorm_preserve || info.driver == "NVIDIA")
    }
}

impl std::fmt::Display for FloatControls {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let yes_no = |b: bool| if b { "yes" } else { "no" };
        write!(f, "f32 round-to-nearest-even on request: {}, subnormals kept on request: {}", yes_no(self.rounding_rte), yes_no(self.denorm_preserve))
    }
}

/// Rasterises the probe frame in each `f32` mode with `gpu` and with the CPU backend, and
/// says where the first one differs.
pub fn check(mut gpu: impl FnMut(&tileraster_core::Prepared) -> Result<Raster, Error>) -> Result<(), String> {
    let (scene, grid) = f32_probe();
    for mode in [Mode::PlaneF32, Mode::Barycentric] {
        let prepared = prepare(&scene, &Params::new(grid).with_mode(mode), None).map_err(|e| e.to_string())?;
        let on_gpu = gpu(&prepared).map_err(|e| e.to_string())?;
        let on_cpu = tileraster_cpu::rasterise(&prepared).map_err(|e| e.to_string())?;
        let (count, first) = on_cpu.compare_bits(&on_gpu, 1);
        if let Some(d) = first.first() {
            let show = |v: Option<u32>| v.map(|b| format!("{:e} ({b:#010x})", f32::from_bits(b))).unwrap_or_else(|| "none".into());
            return Err(format!(
                "{count} of {} probe cells differ in {} mode; first at ({}, {}): {} on the CPU, {} on the GPU",
                on_cpu.values.len(),
                mode.name(),
                d.i,
                d.j,
                show(d.left),
                show(d.right)
            ));
        }
    }
    Ok(())
}

/// A frame whose `f32` arithmetic exposes a driver's own choices in both float modes: one
/// triangle whose heights, gradients and products are subnormal or straddle the smallest
/// normal (flushed to zero by a device that does not keep subnormals), and one whose products
/// and sums are inexact (rounded differently by a device that does not round to nearest even).
pub fn f32_probe() -> (Scene, Grid) {
    let grid = Grid::new(0.0, 32.0, 0.0, 16.0, 32, 16);
    let (g, h) = (-1.5e-39, 2.5e-40);
    let scene = Scene::new(
        vec![
            [0.0, 0.0, 1.0e-38],
            [16.0, 0.0, 1.0e-38 + 16.0 * g],
            [0.0, 16.0, 1.0e-38 + 16.0 * h],
            [16.0, 0.0, 1_000.123_456_7],
            [32.0, 0.0, 1_234.987_654_3],
            [16.0, 16.0, -777.777_777_7],
        ],
        vec![[0, 1, 2], [3, 4, 5]],
    );
    (scene, grid)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cpu(prepared: &tileraster_core::Prepared) -> Result<Raster, Error> {
        tileraster_cpu::rasterise(prepared)
    }

    /// The probe has what it is meant to expose, in both modes: subnormal cells (a device that
    /// flushes gives zero there) and cells whose value is not the f64 plane's (rounded).
    #[test]
    fn the_probe_frame_has_subnormal_and_rounded_cells_in_both_f32_modes() {
        let (scene, grid) = f32_probe();
        for mode in [Mode::PlaneF32, Mode::Barycentric] {
            let raster = cpu(&prepare(&scene, &Params::new(grid).with_mode(mode), None).unwrap()).unwrap();
            let subnormal = raster.values.iter().filter(|v| v.is_subnormal()).count();
            let large = raster.values.iter().filter(|v| v.abs() > 100.0).count();
            assert!(subnormal >= 16, "{mode:?}: {subnormal} subnormal cells");
            assert!(large >= 16, "{mode:?}: {large} cells on the rounded triangle");
        }
    }

    /// A device that gives the CPU's bits passes; one that flushes subnormal results to zero,
    /// or rounds one cell differently, is caught and named.
    #[test]
    fn the_check_accepts_the_cpus_bits_and_catches_a_flush_or_a_rounding() {
        assert_eq!(check(cpu), Ok(()));
        let flushed = check(|p| {
            let mut r = cpu(p)?;
            r.values.iter_mut().filter(|v| v.is_subnormal()).for_each(|v| *v = 0.0);
            Ok(r)
        });
        assert!(flushed.as_ref().is_err_and(|e| e.contains("plane-f32")), "{flushed:?}");
        let rounded = check(|p| {
            let mut r = cpu(p)?;
            if p.params.mode == Mode::Barycentric {
                let v = r.values.iter_mut().find(|v| v.abs() > 100.0).expect("a large cell");
                *v = f32::from_bits(v.to_bits() + 1);
            }
            Ok(r)
        });
        assert!(rounded.as_ref().is_err_and(|e| e.contains("barycentric") && e.contains("1 of 512")), "{rounded:?}");
    }
}
