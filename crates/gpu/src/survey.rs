//! Which Vulkan adapters this machine has, learnt without opening a device and remembered
//! between processes.
//!
//! The `auto` backend asks on every call. Loading a Vulkan driver is not free: lavapipe, the
//! CPU implementation `.ci/setup` installs, links all of LLVM, and opening its device costs
//! over a second. So a survey only enumerates the adapters (no device, no pipeline), and what it
//! learnt is kept in a small text file under the user's cache directory, keyed by everything
//! that decides what the Vulkan loader would find: the driver manifests it reads (path, size,
//! modification time), the environment variables that redirect it, the GPU device nodes, and
//! this crate's version and the features its kernels need. A new driver, an uninstalled one or a GPU passed into a container
//! changes the key, and the next survey enumerates again.
//!
//! Where no driver manifest exists at all, there is no adapter, and Vulkan is not loaded.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What kind of device an adapter is, as far as choosing a backend goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdapterKind {
    /// A discrete, integrated or virtual GPU.
    Gpu,
    /// A CPU implementation of Vulkan (lavapipe, SwiftShader): the same cores the CPU backend
    /// uses, through a driver that runs compute shaders far slower than native code.
    Cpu,
    /// Anything else the driver reports.
    Other,
}

impl AdapterKind {
    fn of(device_type: wgpu::DeviceType) -> AdapterKind {
        match device_type {
            wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::IntegratedGpu | wgpu::DeviceType::VirtualGpu => AdapterKind::Gpu,
            wgpu::DeviceType::Cpu => AdapterKind::Cpu,
            wgpu::DeviceType::Other => AdapterKind::Other,
        }
    }

    fn word(self) -> &'static str {
        match self {
            AdapterKind::Gpu => "gpu",
            AdapterKind::Cpu => "cpu",
            AdapterKind::Other => "other",
        }
    }

    fn from_word(word: &str) -> Option<AdapterKind> {
        Some(match word {
            "gpu" => AdapterKind::Gpu,
            "cpu" => AdapterKind::Cpu,
            "other" => AdapterKind::Other,
            _ => return None,
        })
    }
}

/// One adapter the Vulkan loader lists.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SurveyedAdapter {
    pub name: String,
    pub kind: AdapterKind,
    /// Whether it has what the kernels need (64-bit integers, SPIR-V passthrough).
    pub usable: bool,
}

/// Where a survey's answer came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SurveySource {
    /// No Vulkan driver manifest on this machine: Vulkan was not loaded.
    NoDrivers,
    /// The adapters were enumerated now (and remembered where the cache directory allows).
    Enumerated,
    /// A survey of an earlier process, whose key still matches, read from this file.
    Cache(PathBuf),
}

/// The adapters of this machine, in the loader's order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Survey {
    pub adapters: Vec<SurveyedAdapter>,
    pub source: SurveySource,
}

impl Survey {
    /// The adapter the GPU backend would open: the usable one named like `TILERASTER_ADAPTER`
    /// if that is set, else the first usable one of the best kind (GPU before CPU
    /// implementation), as [`crate::adapter`] picks it.
    pub fn preferred(&self) -> Option<&SurveyedAdapter> {
        let wanted = std::env::var("TILERASTER_ADAPTER").ok();
        let rank = |a: &&SurveyedAdapter| match a.kind {
            AdapterKind::Gpu => 0,
            AdapterKind::Cpu => 1,
            AdapterKind::Other => 2,
        };
        self.adapters.iter().filter(|a| a.usable && wanted.as_deref().is_none_or(|w| a.name.contains(w))).min_by_key(rank)
    }
}

/// The features the kernels need of an adapter.
pub(crate) fn needed_features() -> wgpu::Features {
    // Subgroups: the kernels' module declares shuffles (`memory::Lanes`); 64-bit atomic
    // minima: the small triangles' keys (`stages::small`).
    wgpu::Features::SHADER_INT64 | wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX | wgpu::Features::PASSTHROUGH_SHADERS | wgpu::Features::SUBGROUP
}

/// This machine's Vulkan adapters: from the cache when its key matches, else enumerated (no
/// device is opened) and remembered.
pub fn survey() -> Survey {
    let key = fingerprint();
    if !key.has_drivers {
        return Survey { adapters: Vec::new(), source: SurveySource::NoDrivers };
    }
    let file = cache_dir().map(|d| d.join("vulkan-adapters"));
    if let Some(adapters) = file.as_deref().and_then(|f| read_cache(f, &key.text)) {
        return Survey { adapters, source: SurveySource::Cache(file.expect("read from it")) };
    }
    let adapters = enumerate();
    if let Some(file) = &file {
        // A cache that cannot be written only costs the next process a survey.
        let _ = write_cache(file, &key.text, &adapters);
    }
    Survey { adapters, source: SurveySource::Enumerated }
}

/// The adapters the loader lists, without opening any.
fn enumerate() -> Vec<SurveyedAdapter> {
    crate::device::with_instance(|instance| pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN)))
        .into_iter()
        .map(|a| {
            let info = a.get_info();
            SurveyedAdapter { name: info.name, kind: AdapterKind::of(info.device_type), usable: a.features().contains(needed_features()) }
        })
        .collect()
}

/// Where tileraster keeps what it learnt of this machine: `TILERASTER_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/tileraster`, else `~/.cache/tileraster`.
pub fn cache_dir() -> Option<PathBuf> {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("TILERASTER_CACHE_DIR")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("tileraster")))
        .or_else(|| var("HOME").map(|d| d.join(".cache").join("tileraster")))
}

/// What decides which adapters the Vulkan loader finds, as text (one fact a line).
struct Fingerprint {
    text: String,
    /// Whether any driver manifest exists (or the environment names one).
    has_drivers: bool,
}

/// The environment variables that change which drivers the Vulkan loader reads.
const LOADER_VARIABLES: [&str; 5] = ["VK_DRIVER_FILES", "VK_ICD_FILENAMES", "VK_ADD_DRIVER_FILES", "VK_LOADER_DRIVERS_SELECT", "VK_LOADER_DRIVERS_DISABLE"];

fn fingerprint() -> Fingerprint {
    // What the kernels need decides which adapters are usable.
    let mut text = format!("tileraster-gpu {}\nneeds {:?}\n", env!("CARGO_PKG_VERSION"), needed_features());
    let mut has_drivers = false;
    for name in LOADER_VARIABLES {
        let Some(value) = std::env::var_os(name) else {
            continue;
        };
        let _ = writeln!(text, "env {name}={}", value.to_string_lossy());
        // The first three name manifests (or directories of them); the others filter drivers.
        if name.ends_with("_FILES") || name == "VK_ICD_FILENAMES" {
            for path in std::env::split_paths(&value) {
                has_drivers |= describe_file(&mut text, &path);
            }
        }
    }
    for dir in manifest_dirs() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
        paths.sort();
        for path in paths {
            has_drivers |= describe_file(&mut text, &path);
        }
    }
    // A GPU given to the machine (or a container) later shows as a device node.
    for (dir, prefixes) in [("/dev/dri", &["renderD", "card"][..]), ("/dev", &["nvidia", "kfd"][..])] {
        let Ok(entries) = std::fs::read_dir(dir) else {
            continue;
        };
        let mut names: Vec<String> = entries
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| prefixes.iter().any(|p| n.starts_with(p)))
            .collect();
        names.sort();
        for name in names {
            let _ = writeln!(text, "device {dir}/{name}");
        }
    }
    Fingerprint { text, has_drivers }
}

/// One line for a file (or directory): its path, size and modification time (nanoseconds);
/// whether it exists.
fn describe_file(text: &mut String, path: &Path) -> bool {
    let Ok(meta) = std::fs::metadata(path) else {
        return false;
    };
    let modified = meta.modified().ok().and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok()).map_or(0, |d| d.as_nanos());
    let _ = writeln!(text, "file {} {} {modified}", path.display(), meta.len());
    true
}

/// The directories the Vulkan loader reads driver manifests from on Linux, in its order.
fn manifest_dirs() -> Vec<PathBuf> {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
    let home = var("HOME").map(PathBuf::from);
    let mut bases: Vec<PathBuf> = Vec::new();
    bases.extend(var("XDG_CONFIG_HOME").map(PathBuf::from).or_else(|| home.as_ref().map(|h| h.join(".config"))));
    bases.extend(std::env::split_paths(&var("XDG_CONFIG_DIRS").unwrap_or_else(|| "/etc/xdg".into())));
    bases.push("/etc".into());
    bases.extend(var("XDG_DATA_HOME").map(PathBuf::from).or_else(|| home.as_ref().map(|h| h.join(".local/share"))));
    bases.extend(std::env::split_paths(&var("XDG_DATA_DIRS").unwrap_or_else(|| "/usr/local/share:/usr/share".into())));
    bases.into_iter().map(|b| b.join("vulkan").join("icd.d")).collect()
}

const CACHE_HEADER: &str = "tileraster vulkan adapters 1";

/// The adapters a cache file holds, if its key is `key`.
fn read_cache(file: &Path, key: &str) -> Option<Vec<SurveyedAdapter>> {
    let text = std::fs::read_to_string(file).ok()?;
    let rest = text.strip_prefix(CACHE_HEADER)?.strip_prefix('\n')?;
    let adapters = rest.strip_prefix(key)?;
    adapters
        .lines()
        .map(|line| {
            let mut fields = line.strip_prefix("adapter ")?.splitn(3, ' ');
            let kind = AdapterKind::from_word(fields.next()?)?;
            let usable = match fields.next()? {
                "usable" => true,
                "unusable" => false,
                _ => return None,
            };
            Some(SurveyedAdapter { name: fields.next()?.to_string(), kind, usable })
        })
        .collect()
}

/// Write the cache: to a file of this process's own, then renamed over the old one, so that a
/// reader never sees half a file.
fn write_cache(file: &Path, key: &str, adapters: &[SurveyedAdapter]) -> std::io::Result<()> {
    let mut text = format!("{CACHE_HEADER}\n{key}");
    for a in adapters {
        let _ = writeln!(text, "adapter {} {} {}", a.kind.word(), if a.usable { "usable" } else { "unusable" }, a.name.replace('\n', " "));
    }
    let dir = file.parent().expect("the cache file is in a directory");
    std::fs::create_dir_all(dir)?;
    let partial = dir.join(format!(".vulkan-adapters.{}", std::process::id()));
    std::fs::write(&partial, text)?;
    std::fs::rename(&partial, file).inspect_err(|_| {
        let _ = std::fs::remove_file(&partial);
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cache_round_trips_and_refuses_another_key() {
        let dir = std::env::temp_dir().join(format!("tileraster-survey-test-{}", std::process::id()));
        let file = dir.join("vulkan-adapters");
        let adapters = vec![
            SurveyedAdapter { name: "llvmpipe (LLVM 15.0.6, 256 bits)".into(), kind: AdapterKind::Cpu, usable: true },
            SurveyedAdapter { name: "NVIDIA H100 80GB HBM3".into(), kind: AdapterKind::Gpu, usable: false },
        ];
        write_cache(&file, "file /a 1 2\n", &adapters).unwrap();
        assert_eq!(read_cache(&file, "file /a 1 2\n"), Some(adapters));
        assert_eq!(read_cache(&file, "file /a 1 3\n"), None, "a changed driver file is a new key");
        std::fs::write(&file, format!("{CACHE_HEADER}\nfile /a 1 2\nadapter gpu maybe X\n")).unwrap();
        assert_eq!(read_cache(&file, "file /a 1 2\n"), None, "a damaged line is no answer");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_preferred_adapter_is_a_usable_gpu_before_a_cpu_implementation() {
        let cpu = SurveyedAdapter { name: "llvmpipe".into(), kind: AdapterKind::Cpu, usable: true };
        let gpu = SurveyedAdapter { name: "GPU".into(), kind: AdapterKind::Gpu, usable: true };
        let old = SurveyedAdapter { name: "old GPU".into(), kind: AdapterKind::Gpu, usable: false };
        let survey = |adapters: Vec<SurveyedAdapter>| Survey { adapters, source: SurveySource::Enumerated };
        assert_eq!(survey(vec![cpu.clone(), gpu.clone()]).preferred(), Some(&gpu));
        assert_eq!(survey(vec![old.clone(), cpu.clone()]).preferred(), Some(&cpu));
        assert_eq!(survey(vec![old]).preferred(), None);
    }
}
