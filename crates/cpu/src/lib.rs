//! The CPU backend: a host dispatcher that runs the same stage functions as the GPU entry
//! points, simulating workgroups. It walks the stage table (`tileraster_kernels::pipeline`)
//! and runs each stage's twin (`stages/`, same names): per-triangle stages as rayon parallel
//! loops, fine raster one row of tiles per task and one tile per workgroup.
#![feature(portable_simd)]

mod stages;

pub use stages::{
    FinePath, SmallBins, SmallSeeds, SmallTriangles, assemble_count, assemble_fill, assemble_scan, bin_count, bin_fill, bin_scan, fine_depth, fine_raster,
    fine_samples, fine_small, fine_small_for, light, setup, setup_into, shade, vertex,
};
pub use tileraster_kernels::pipeline::StageBuffers;

use std::sync::Arc;
use tileraster_core::render::{AssembledRecords, AssemblyCount, AssemblyMesh, AssemblyPatches, KeptHanded, KeptInputs, Posing, Positions, VertexTexture};
use tileraster_core::{Error, Layers, Plan, Prepared, Raster};
use tileraster_kernels::abi::{ATTRIBUTES, Counter, ProjectedVertex, ShadeParams, TriangleSetup, VertexParams};
use tileraster_kernels::pipeline::{Layer, Stage, raster_stages};
use tileraster_kernels::programs::vertex::{Builtin, VertexProgram};

/// A prepared scene's triangles set up on this backend, kept for later calls (the CPU
/// twin of the GPU backend's resident buffers).
pub struct Resident {
    setups: Vec<TriangleSetup>,
}

/// Rasterise a prepared scene on the CPU, over the preparation's window.
pub fn rasterise(prepared: &Prepared) -> Result<Raster, Error> {
    rasterise_with(prepared, FinePath::default())
}

/// Memory a call works in, kept between calls of different scenes (the frames of a
/// `PreparedMesh`): the setups and the raster's layers. A call that takes them writes into
/// pages already mapped instead of faulting fresh ones in; its bits are the same.
#[derive(Default)]
pub struct Workspace {
    setups: Vec<TriangleSetup>,
    layers: Layers,
}

impl Workspace {
    /// Keep these layers (of a raster the caller is done with) for the next call, and those
    /// the last call kept here (layers its raster did not return) where they have none.
    pub fn recycle(&mut self, layers: Layers) {
        let kept = std::mem::take(&mut self.layers);
        self.layers = layers.or(kept);
    }
}

/// [`rasterise`] in `workspace`: its setups and layers where it has them.
pub fn rasterise_in(prepared: &Prepared, workspace: &mut Workspace) -> Result<Raster, Error> {
    let plan = prepared.plan(prepared.window, false)?;
    let mut resident = None;
    let raster = rasterise_planned_with(prepared, &plan, &mut resident, FinePath::default(), &mut |_| {}, Some(workspace));
    if let Some(Resident { setups }) = resident {
        workspace.setups = setups;
    }
    raster
}

/// [`rasterise`] with a chosen fine-raster twin (the tests compare the two).
pub fn rasterise_with(prepared: &Prepared, path: FinePath) -> Result<Raster, Error> {
    rasterise_planned_with(prepared, &prepared.plan(prepared.window, false)?, &mut None, path, &mut |_| {}, None)
}

/// Run `plan`, setting the scene up first unless `resident` already holds it.
pub fn rasterise_planned(prepared: &Prepared, plan: &Plan, resident: &mut Option<Resident>) -> Result<Raster, Error> {
    rasterise_planned_with(prepared, plan, resident, FinePath::default(), &mut |_| {}, None)
}

/// [`rasterise_planned`] with no resident scene, calling `observe` as each stage of the table
/// finishes (how `cargo xtask stage-times` splits a call's time by stage).
pub fn rasterise_observed(prepared: &Prepared, plan: &Plan, observe: &mut dyn FnMut(Stage)) -> Result<Raster, Error> {
    rasterise_planned_with(prepared, plan, &mut None, FinePath::default(), observe, None)
}

/// The buffers the stages before fine raster leave for the preparation's window, as the GPU
/// backend's `stage_buffers` reads them back (the stage-by-stage comparison of the backends).
/// `None` when no triangle reaches the window.
pub fn stage_buffers(prepared: &Prepared) -> Result<Option<StageBuffers>, Error> {
    let plan = prepared.plan(prepared.window, false)?;
    let Some(active) = plan.active else { return Ok(None) };
    let frame = plan.frame(prepared, active);
    let setups = setup(prepared, &frame);
    let counts = bin_count(&frame, &setups, &plan.listed);
    let offsets = bin_scan(&frame, &counts);
    let bins = bin_fill(&frame, &setups, &plan.listed, &offsets);
    Ok(Some(StageBuffers { setups, counts, offsets, bins }))
}

/// The buffers one window's stages pass along (the GPU's storage buffers of the same names).
#[derive(Default)]
struct WindowBuffers {
    counts: Vec<u32>,
    offsets: Vec<u32>,
    bins: Vec<u32>,
    small: SmallTriangles,
}

/// The vertex texture a stage was handed last, and the key of the kept positions it posed
/// (`Positions::kept`; `None` for positions handed with the frame).
pub type HeldTexture = Option<(Arc<VertexTexture>, Option<u64>)>;

/// The texels of `posing`'s vertex texture a stage that was handed `held` last must be handed
/// with `positions`, as the GPU keeps one on the device: none where it is the same texture;
/// where a prepared mesh's frame hands another of the same size than its last frame, those
/// from the first that differ to the last (a new pose of `VertexStage::DEFORM` changes only its
/// joints and weights, at the texture's start); else all of them. `held` then holds it. `None`:
/// nothing to hand over. (Only a prepared mesh's frames compare texels: what a one-shot call
/// hands over never depends on what an unrelated call held.)
pub fn texture_update(posing: Option<&Posing<'_>>, positions: &Positions<'_>, held: &mut HeldTexture) -> Option<std::ops::Range<usize>> {
    let texture = posing.and_then(|p| p.texture)?;
    let last = held.replace((texture.clone(), positions.kept));
    match last {
        Some((last, _)) if Arc::ptr_eq(&last, texture) => None,
        Some((last, Some(key))) if positions.kept == Some(key) && last.texels.len() == texture.texels.len() => {
            let (old, new): (&[u32], &[u32]) = (bytemuck::cast_slice(&last.texels), bytemuck::cast_slice(&texture.texels));
            let first = old.iter().zip(new).position(|(a, b)| a != b)?;
            let end = old.iter().zip(new).rposition(|(a, b)| a != b).map_or(first, |k| k + 1);
            Some(first..end)
        }
        _ => Some(0..texture.texels.len()),
    }
}

/// The geometry stages' twins, which the host's preparation of a frame runs
/// (`tileraster_core::render::GeometryKernels`). They read a mesh's kept positions, faces and
/// attributes where the host keeps them, and count them handed over once, as the GPU does;
/// their records are written where the raster stages read them.
#[derive(Debug, Clone, Default)]
pub struct GeometryTwins {
    /// The key of the kept positions handed over last.
    held: Option<u64>,
    /// The vertex texture handed over last.
    held_texture: HeldTexture,
    /// The keys of the kept assembly inputs handed over last.
    held_inputs: KeptInputs,
}

impl tileraster_core::render::GeometryKernels for GeometryTwins {
    fn vertex(
        &mut self,
        params: &VertexParams,
        positions: Positions<'_>,
        posing: Option<&Posing<'_>>,
        projected: &mut Vec<ProjectedVertex>,
    ) -> Result<u64, Error> {
        let program: &(dyn VertexProgram + Sync) = posing.map_or(&Builtin, |p| p.stage.program());
        vertex(program, params, posing.map_or(&[], |p| p.texels()), positions.pairs, projected);
        let handed = positions.kept.is_none_or(|key| self.held.replace(key) != Some(key));
        let texels = texture_update(posing, &positions, &mut self.held_texture);
        Ok(positions.bytes(handed) + texels.map_or(0, |t| (t.len() * std::mem::size_of::<f32>()) as u64))
    }

    fn assemble_count(&mut self, mesh: &AssemblyMesh<'_>) -> Result<AssemblyCount, Error> {
        Ok(assemble_count(mesh))
    }

    fn assemble_fill(&mut self, mesh: &AssemblyMesh<'_>, count: &AssemblyCount, patches: &AssemblyPatches, out: AssembledRecords<'_>) -> Result<u64, Error> {
        let offsets = assemble_scan(&mesh.params, &count.group_counts, &patches.patches);
        assemble_fill(mesh, &offsets, patches, out);
        Ok(mesh.bytes(patches, KeptHanded::of(&mesh.kept, &mut self.held_inputs)))
    }

    fn light(&mut self, shade: &ShadeParams, attributes: &[[f32; ATTRIBUTES]], _kept: Option<u64>, lit: &mut Vec<[f32; 4]>) -> Result<u64, Error> {
        light(shade, attributes, lit);
        Ok(tileraster_core::render::light_bytes())
    }

    /// The records are written into the host's arrays, where setup reads them.
    fn hold_records(&mut self, _records: u64, _listed: u64, _small: u64) -> Result<Option<u64>, Error> {
        Ok(Some(0))
    }
}

/// The stages of `plan` in the table's order. With a `workspace`, the raster takes its layers
/// and the setup stage its memory (`resident` must then start empty).
fn rasterise_planned_with(
    prepared: &Prepared,
    plan: &Plan,
    resident: &mut Option<Resident>,
    path: FinePath,
    observe: &mut dyn FnMut(Stage),
    mut workspace: Option<&mut Workspace>,
) -> Result<Raster, Error> {
    let mut raster = plan.allocate_raster_reusing(prepared, workspace.as_mut().map(|w| std::mem::take(&mut w.layers)).unwrap_or_default(), true)?;
    let mut counters = [0u64; Counter::COUNT];
    if let Some(active) = plan.active {
        let frame = plan.frame(prepared, active);
        let entries = plan.bin_capacity(prepared, &frame);
        if entries > u32::MAX as u64 {
            return Err(Error::RasterTooLarge {
                width: frame.win_w as u64,
                height: frame.win_h as u64,
                reason: format!("{entries} triangle–tile pairs exceed the 2^32 a window can bin"),
            });
        }
        // The small triangles' form the fine path takes, empty until `fine_small` runs (a frame
        // with none never runs it).
        let mut b = WindowBuffers { small: SmallTriangles::empty_for(path.bins_small(&frame)), ..WindowBuffers::default() };
        // The stage table's order, the pipeline's rows; each stage's twin. The scene stage runs
        // once per scene.
        for info in raster_stages(prepared.pipeline()).filter(|s| s.runs_for(frame.flags)) {
            let setups = resident.as_ref().map(|r| r.setups.as_slice()).unwrap_or_default();
            match info.stage {
                Stage::Vertex | Stage::Light | Stage::AssembleCount | Stage::AssembleScan | Stage::AssembleFill => {
                    unreachable!("the geometry stages run as the host prepares the frame")
                }
                Stage::Setup => {
                    if resident.is_none() {
                        let mut setups = workspace.as_mut().map(|w| std::mem::take(&mut w.setups)).unwrap_or_default();
                        setup_into(prepared, &frame, &mut setups);
                        *resident = Some(Resident { setups });
                    }
                }
                Stage::BinCount => b.counts = bin_count(&frame, setups, &plan.listed),
                Stage::BinScan => b.offsets = bin_scan(&frame, &b.counts),
                Stage::BinFill => {
                    debug_assert!(b.offsets[frame.tile_count() as usize] as u64 <= entries);
                    b.bins = bin_fill(&frame, setups, &plan.listed, &b.offsets);
                }
                Stage::FineRaster => {
                    let stats = fine_raster(path, &frame, setups, &b.offsets, &b.bins, &mut raster);
                    counters = stats.map(|c| c.into_inner() as u64);
                }
                Stage::FineSmall => b.small = fine_small_for(path.bins_small(&frame), &frame, setups, &plan.small),
                Stage::FineDepth => {
                    let stats = fine_depth(path, &frame, setups, &b.offsets, &b.bins, &b.small, &mut raster);
                    counters = stats.map(|c| c.into_inner() as u64);
                }
                Stage::FineSamples => {
                    let inputs = prepared.render.as_ref().expect("the render pipeline has shading");
                    let stats = fine_samples(&frame, inputs, setups, &b.offsets, &b.bins, &mut raster);
                    counters = stats.map(|c| c.into_inner() as u64);
                }
                Stage::Shade => {
                    let shading = prepared.render.as_ref().expect("the render pipeline has shading");
                    shade(&frame, shading, setups, &b.offsets, &b.bins, &b.small, &mut raster);
                }
            }
            observe(info.stage);
        }
    }
    raster.stats = plan.stats(&counters);
    // The layers the stages wrote that the call does not return stay in the workspace.
    let unreturned = Layer::ALL.into_iter().filter(|&l| !prepared.returns(l)).fold(Layers::default(), |kept, l| kept.with(l, raster.take_layer(l)));
    if let Some(w) = workspace {
        w.recycle(unreturned);
    }
    Ok(raster)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tileraster_core::render::VertexStage;
    use tileraster_kernels::abi::VertexUniforms;

    /// A texture is handed over whole the first time, not again while it is the same (or holds
    /// the same texels), and from its first changed texel to its last where a prepared mesh's
    /// frame hands another of the same size.
    #[test]
    fn a_texture_hands_over_what_changed() {
        let texture = |texels: Vec<f32>| Arc::new(VertexTexture { width: texels.len() as u32, height: 1, texels });
        let (prepared, other, one_shot) = ([7], [8], []);
        let update = |t: &Arc<VertexTexture>, kept: &[u64], held: &mut HeldTexture| {
            let posing = Posing { stage: &VertexStage::DEFORM, uniforms: VertexUniforms::default(), texture: Some(t) };
            texture_update(Some(&posing), &Positions { pairs: &[], kept: kept.first().copied() }, held)
        };
        let mut held = None;
        let first = texture(vec![0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(update(&first, &prepared, &mut held), Some(0..5));
        assert_eq!(update(&first, &prepared, &mut held), None);
        assert_eq!(update(&texture(vec![0.0, 1.0, 2.0, 3.0, 4.0]), &prepared, &mut held), None);
        assert_eq!(update(&texture(vec![0.0, 7.0, 2.0, 8.0, 4.0]), &prepared, &mut held), Some(1..4));
        assert_eq!(update(&texture(vec![0.0, 7.0, 2.0, 8.0, -0.0]), &prepared, &mut held), Some(4..5), "bits, not values");
        assert_eq!(update(&texture(vec![1.0; 3]), &prepared, &mut held), Some(0..3));
        assert_eq!(texture_update(None, &Positions { pairs: &[], kept: Some(7) }, &mut held), None);
        // Another mesh's frame, or a one-shot call's, takes the texture whole.
        assert_eq!(update(&texture(vec![1.0, 2.0, 1.0]), &other, &mut held), Some(0..3));
        assert_eq!(update(&texture(vec![1.0, 2.0, 2.0]), &one_shot, &mut held), Some(0..3));
        assert_eq!(update(&texture(vec![1.0, 2.0, 3.0]), &one_shot, &mut held), Some(0..3));
    }
}
