//! Compiling a crate with rust-gpu into the two checked modules, from a build script.

use crate::{BuildError, Role, check, declare_float_controls, mark_no_contraction};
use rspirv::binary::Assemble;
use rspirv::dr::Module;
use spirv_builder::{Capability, SpirvBuilder};
use std::path::{Path, PathBuf};

/// A crate to compile to SPIR-V from a build script.
pub struct Shader {
    crate_path: PathBuf,
    role: Role,
    prefix: String,
}

impl Shader {
    /// A fragment shader crate at `crate_path` (relative to the build script's crate), its
    /// modules named by the environment variables `TILERASTER_FRAGMENT_SPV` and
    /// `TILERASTER_FRAGMENT_FLOAT_CONTROLS_SPV`.
    pub fn fragment(crate_path: impl AsRef<Path>) -> Shader {
        Shader { crate_path: crate_path.as_ref().to_path_buf(), role: Role::Fragment, prefix: "TILERASTER_FRAGMENT".into() }
    }

    /// A vertex shader crate at `crate_path`, its modules named by `TILERASTER_VERTEX_SPV` and
    /// `TILERASTER_VERTEX_FLOAT_CONTROLS_SPV`.
    pub fn vertex(crate_path: impl AsRef<Path>) -> Shader {
        Shader { crate_path: crate_path.as_ref().to_path_buf(), role: Role::Vertex, prefix: "TILERASTER_VERTEX".into() }
    }

    /// tileraster's kernels at `crate_path`, named by `TILERASTER_KERNELS_SPV` and
    /// `TILERASTER_KERNELS_FLOAT_CONTROLS_SPV`.
    pub fn kernels(crate_path: impl AsRef<Path>) -> Shader {
        Shader { crate_path: crate_path.as_ref().to_path_buf(), role: Role::Kernels, prefix: "TILERASTER_KERNELS".into() }
    }

    /// Name the modules' environment variables `<prefix>_SPV` and
    /// `<prefix>_FLOAT_CONTROLS_SPV` (for a crate that builds several shaders).
    pub fn env_prefix(mut self, prefix: impl Into<String>) -> Shader {
        self.prefix = prefix.into();
        self
    }

    /// Compile, check, and write both modules into `OUT_DIR`, telling cargo where they are.
    pub fn build(self) -> Result<(), BuildError> {
        let manifest = std::env::var("CARGO_MANIFEST_DIR").map_err(|_| BuildError::NotInBuildScript("CARGO_MANIFEST_DIR"))?;
        let out_dir = std::env::var("OUT_DIR").map_err(|_| BuildError::NotInBuildScript("OUT_DIR"))?;
        let crate_path = Path::new(&manifest).join(&self.crate_path);
        let mut module = self.compile(&crate_path)?;
        let name = self.prefix.to_lowercase().replace('_', "-");
        write_module(&module, &out_dir, &format!("{name}.spv"), &format!("{}_SPV", self.prefix))?;
        declare_float_controls(&mut module);
        write_module(&module, &out_dir, &format!("{name}-float-controls.spv"), &format!("{}_FLOAT_CONTROLS_SPV", self.prefix))?;
        Ok(())
    }

    /// The crate's module, marked, optimised and checked.
    fn compile(&self, crate_path: &Path) -> Result<Module, BuildError> {
        // spirv-opt runs below, once the arithmetic is marked: rust-gpu would run it before.
        let mut builder = SpirvBuilder::new(crate_path, "spirv-unknown-vulkan1.2")
            .extra_arg("--no-spirv-opt")
            .capability(Capability::Int64)
            .capability(Capability::Int64Atomics)
            .capability(Capability::GroupNonUniform)
            .capability(Capability::GroupNonUniformVote)
            .capability(Capability::GroupNonUniformBallot)
            .capability(Capability::GroupNonUniformShuffle);
        builder.build_script.defaults = true;
        // rustc's output then reaches cargo as the build script's own, shown where the build
        // fails; forwarded as warnings it would carry rust-gpu's note on every build that
        // `--no-spirv-opt` skipped its optimiser, which `optimise` runs instead.
        builder.build_script.forward_rustc_warnings = Some(false);
        let compile_error = |reason: String| BuildError::Compile { crate_path: crate_path.to_path_buf(), reason };
        let result = {
            let _one_at_a_time = builder_lock();
            builder.build().map_err(|e| compile_error(e.to_string()))?
        };
        let path = result.module.unwrap_single();
        let read_error = |reason: String| BuildError::Read { crate_path: crate_path.to_path_buf(), reason };
        let bytes = std::fs::read(path).map_err(|e| read_error(format!("{}: {e}", path.display())))?;
        let mut module = check::load(&bytes).map_err(read_error)?;
        mark_no_contraction(&mut module);
        let module = optimise(&module).map_err(|reason| BuildError::Optimise { crate_path: crate_path.to_path_buf(), reason })?;
        let problems = check::portable(&module);
        if !problems.is_empty() {
            return Err(BuildError::NotPortable { crate_path: crate_path.to_path_buf(), problems });
        }
        let problems = check::entry_points_of(&module, |info| self.role.has(info), self.role != Role::Kernels);
        if !problems.is_empty() {
            return Err(BuildError::EntryPoints { crate_path: crate_path.to_path_buf(), problems });
        }
        Ok(module)
    }
}

/// `module` through spirv-opt's performance passes, as rust-gpu runs them. The arithmetic is marked `NoContraction` first, and spirv-opt folds no
/// float instruction so marked: it would otherwise merge the constants of a chain
/// (`(x · c₁) · c₂` into `x · (c₁c₂)`), where the CPU, running the same source natively,
/// rounds twice.
fn optimise(module: &Module) -> Result<Module, String> {
    use spirv_tools::opt::Optimizer;
    let mut optimizer = spirv_tools::opt::create(Some(spirv_tools::TargetEnv::Vulkan_1_2));
    optimizer.register_performance_passes();
    let mut messages = Vec::new();
    let optimised = optimizer
        .optimize(module.assemble(), &mut |m: spirv_tools::error::Message| messages.push(m.message), None)
        .map_err(|e| format!("spirv-opt: {e}; {}", messages.join("; ")))?;
    rspirv::dr::load_words(optimised.as_words()).map_err(|e| format!("reading spirv-opt's module: {e}"))
}

fn write_module(module: &Module, out_dir: &str, name: &str, env: &str) -> Result<(), BuildError> {
    let out = Path::new(out_dir).join(name);
    let bytes: Vec<u8> = module.assemble().iter().flat_map(|w| w.to_le_bytes()).collect();
    std::fs::write(&out, bytes).map_err(|e| BuildError::Write { path: out.clone(), reason: e.to_string() })?;
    println!("cargo::rustc-env={env}={}", out.display());
    Ok(())
}

/// A lock held while spirv-builder runs, machine-wide: each build writes its target
/// specification into the target folder that every build script's shaders share, and a build
/// script that reads it while another writes it (the kernels' and an example's shader crate,
/// built at once) fails with "EOF while parsing". `None` where no lock file can be opened: the
/// build then runs unlocked, as it would without this.
fn builder_lock() -> Option<std::fs::File> {
    let file = std::fs::OpenOptions::new().create(true).truncate(false).write(true).open(std::env::temp_dir().join("tileraster-spirv-builder.lock")).ok()?;
    file.lock().ok()?;
    Some(file)
}
