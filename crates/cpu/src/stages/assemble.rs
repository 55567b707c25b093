//! Twins of the `assemble_count`, `assemble_scan` and `assemble_fill` entry points: the faces
//! of a placed mesh group by group (`FACE_GROUP` faces, a workgroup's), each group's
//! invocations phase by phase, the groups on all cores. What a group writes does not depend on
//! the others' order: its counts are sums, and its records go to the ranks the scan gives it.

use rayon::prelude::*;
use tileraster_core::render::{AssembledRecords, AssemblyCount, AssemblyMesh, AssemblyPatches};
use tileraster_kernels::SCAN_GROUP;
use tileraster_kernels::abi::{AssembleParams, AssemblyPatch};
use tileraster_kernels::memory::Slots;
use tileraster_kernels::stages::assemble::{
    self, ASSEMBLY_COUNTERS, AssemblyScanShared, CLIPPED_ON_HOST, FACE_GROUP, FaceFate, KEPT, count_face, count_word, face_fate, fill_face, fill_output,
    fill_ranks,
};

/// Groups a task of the twins takes.
const TASK_GROUPS: usize = 64;

/// `assemble_count` over a placed mesh's faces.
pub fn assemble_count(mesh: &AssemblyMesh<'_>) -> AssemblyCount {
    let (params, faces, projected) = (&mesh.params, mesh.faces, mesh.projected);
    let mut group_counts = vec![0u32; 2 * params.groups as usize];
    let tasks: Vec<([u32; ASSEMBLY_COUNTERS], Vec<u32>)> = group_counts
        .par_chunks_mut(2 * TASK_GROUPS)
        .enumerate()
        .map(|(task, counts)| {
            let (mut counters, mut clipped) = ([0u32; ASSEMBLY_COUNTERS], Vec::new());
            let first = (task * TASK_GROUPS) as u32 * FACE_GROUP;
            let end = (first + (counts.len() / 2) as u32 * FACE_GROUP).min(params.faces);
            for f in first..end {
                let (fate, out) = count_face(params, faces, mesh.materials, projected, f);
                match fate {
                    KEPT => counts[count_word(f, out) - 2 * task * TASK_GROUPS] += 1,
                    CLIPPED_ON_HOST => {
                        counters[fate as usize] += 1;
                        clipped.push(f);
                    }
                    _ => counters[fate as usize] += 1,
                }
            }
            (counters, clipped)
        })
        .collect();
    let mut count = AssemblyCount { group_counts: Vec::new(), counters: [0; ASSEMBLY_COUNTERS], clipped: Vec::new() };
    for (counters, clipped) in tasks {
        count.counters.iter_mut().zip(counters).for_each(|(sum, c)| *sum += c);
        count.clipped.extend(clipped);
    }
    count.group_counts = group_counts;
    count
}

/// `assemble_scan`: one workgroup of `SCAN_GROUP` invocations, phase by phase. Two words a
/// group (its first listed and small rank), then the two totals.
pub fn assemble_scan(params: &AssembleParams, group_counts: &[u32], patches: &[AssemblyPatch]) -> Vec<u32> {
    let mut offsets = vec![0u32; 2 * params.groups as usize + 2];
    let mut shared: AssemblyScanShared = [0; 2 * SCAN_GROUP as usize];
    for lid in 0..SCAN_GROUP {
        assemble::assemble_scan_reduce(lid, params, group_counts, patches, &mut shared);
    }
    for lid in 0..SCAN_GROUP {
        assemble::assemble_scan_partials(lid, &mut shared);
    }
    for lid in 0..SCAN_GROUP {
        assemble::assemble_scan_write(lid, params, group_counts, patches, &shared, &mut offsets);
    }
    offsets
}

/// `assemble_fill`, given `assemble_scan`'s `offsets` and the host's `patches`: the mesh's
/// records into `out`, which holds exactly them (from slot `first_listed + first_small` on),
/// and its lists' entries where `out` asks for them.
pub fn assemble_fill(mesh: &AssemblyMesh<'_>, offsets: &[u32], patches: &AssemblyPatches, out: AssembledRecords<'_>) {
    let (params, faces, projected) = (&mesh.params, mesh.faces, mesh.projected);
    let groups = params.groups as usize;
    let first_slot = (params.first_listed + params.first_small) as usize;
    // Each task's records, and list entries, lie between its first group's ranks and the next
    // task's: the outputs split there.
    let bounds: Vec<(usize, usize)> =
        (0..=groups.div_ceil(TASK_GROUPS)).map(|t| (t * TASK_GROUPS).min(groups)).map(|g| (offsets[2 * g] as usize, offsets[2 * g + 1] as usize)).collect();
    let (mut inputs_rest, mut shading_rest) = (out.inputs, out.shading);
    let (mut listed_rest, mut small_rest) = match out.lists {
        Some((l, s)) => (Some(l), Some(s)),
        None => (None, None),
    };
    let mut parts = Vec::with_capacity(bounds.len());
    for w in bounds.windows(2) {
        let (records, listed, small) = (w[1].0 + w[1].1 - w[0].0 - w[0].1, w[1].0 - w[0].0, w[1].1 - w[0].1);
        let (i, rest) = std::mem::take(&mut inputs_rest).split_at_mut(records);
        inputs_rest = rest;
        let (s, rest) = std::mem::take(&mut shading_rest).split_at_mut(records);
        shading_rest = rest;
        let (l, sm) = (take_front(&mut listed_rest, listed), take_front(&mut small_rest, small));
        let slot = first_slot + w[0].0 + w[0].1;
        let listed_base = params.first_listed as usize + w[0].0;
        let small_base = params.first_small as usize + w[0].1;
        parts.push((
            Window { slice: i, base: slot },
            Window { slice: s, base: slot },
            Lists { slice: l, base: listed_base },
            Lists { slice: sm, base: small_base },
        ));
    }
    parts.into_par_iter().enumerate().for_each(|(task, (mut i, mut s, mut l, mut sm))| {
        let first_group = task * TASK_GROUPS;
        for g in first_group..(first_group + TASK_GROUPS).min(groups) {
            let first = g as u32 * FACE_GROUP;
            let fates: [FaceFate; FACE_GROUP as usize] = std::array::from_fn(|lid| face_fate(params, faces, mesh.materials, projected, first + lid as u32));
            let mut shared = [0u32; FACE_GROUP as usize];
            for lid in 0..FACE_GROUP {
                shared[lid as usize] = fill_output(params, &patches.patches, first + lid, &fates[lid as usize]);
            }
            fill_ranks(0, &mut shared);
            for lid in 0..FACE_GROUP {
                let (f, rank, face) = (first + lid, shared[lid as usize], &fates[lid as usize]);
                let (a, normals) = (mesh.attributes, mesh.face_normals);
                let (entries, pieces) = (&patches.patches, (&patches.inputs[..], &patches.shading[..]));
                fill_face(params, a, mesh.lit, normals, mesh.shade, entries, pieces.0, pieces.1, f, face, offsets, rank, &mut i, &mut s, &mut l, &mut sm);
            }
        }
    });
}

/// The first `n` entries of `list` (where there is one), the rest left in it.
fn take_front<'a>(list: &mut Option<&'a mut [u32]>, n: usize) -> Option<&'a mut [u32]> {
    let (head, rest) = list.take()?.split_at_mut(n);
    *list = Some(rest);
    Some(head)
}

/// Part of an output from slot `base` on, stored into by the slots the kernel names.
struct Window<'a, T> {
    slice: &'a mut [T],
    base: usize,
}

impl<T: Copy> Slots<T> for Window<'_, T> {
    fn store(&mut self, index: usize, value: T) {
        self.slice[index - self.base] = value;
    }
}

/// Part of a list from entry `base` on, or nowhere where the lists are not asked for.
struct Lists<'a> {
    slice: Option<&'a mut [u32]>,
    base: usize,
}

impl Slots for Lists<'_> {
    fn store(&mut self, index: usize, value: u32) {
        if let Some(slice) = self.slice.as_deref_mut() {
            slice[index - self.base] = value;
        }
    }
}
