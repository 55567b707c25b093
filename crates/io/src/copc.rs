//! COPC, cloud-optimised point clouds: LAZ 1.4 files whose chunks are the nodes of an octree
//! over the points, indexed by a hierarchy of node keys, offsets and counts
//! (<https://copc.io>). A reader that needs only a region reads only the nodes whose cubes
//! meet it.
//!
//! A selection of nodes is decoded as a LAZ file of its own, made in memory of the file's
//! header and VLRs, the selected chunks in file order and a chunk table for them, so that
//! every check and guard of the LAS/LAZ reader applies to it unchanged. Points keep their
//! record numbers in the whole file, which orders them as reading the file through does.
//!
//! (The `copc-rs` crate does not build against the `las` this crate uses, and its point
//! iterator panics on a corrupt chunk; the index is little more than a table to read.)

use crate::IoError;
use crate::chunks::{COUNT, Chunk, HEADER_1_4, VLR_HEADER, decode_chunks, laszip_vlr};
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// One node of a COPC file's octree that holds points: where its chunk lies, its points, and
/// the part of the plane its points lie in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CopcNode {
    /// Level, x, y, z of its key.
    pub key: [i32; 4],
    /// West, south, east and north of its cube (with a margin of a unit of the file's
    /// scaled integers and of rounding, so that it holds its points).
    pub bounds: [f64; 4],
    /// Records before its first in the file.
    pub first: u64,
    /// Its chunk: where it lies, and its points.
    pub(crate) chunk: Chunk,
}

impl CopcNode {
    /// Its points.
    pub fn count(&self) -> u64 {
        self.chunk.count
    }
}

/// Points decoded from chunks of a LAZ file: from a COPC file's nodes ([`Copc::read`]), each
/// with its record number in the whole file.
#[derive(Debug, Clone, PartialEq)]
pub struct NodePoints {
    /// Each kept point's record number and its x, y, z; in file order.
    pub points: Vec<(u64, [f64; 3])>,
    /// The records decoded, kept or not.
    pub decoded: u64,
}

/// A COPC file's index: its header, its nodes in file order.
#[derive(Debug, Clone)]
pub struct Copc {
    path: PathBuf,
    /// Its bytes up to the point data: header and VLRs.
    head: Vec<u8>,
    /// The LASzip VLR's data.
    laszip: Vec<u8>,
    /// Its point records, as its header counts them.
    pub records: u64,
    /// Its nodes with points, in file order.
    pub nodes: Vec<CopcNode>,
}

/// A hierarchy entry: key (4 × i32), offset (u64), byte size (i32), point count (i32).
const ENTRY: usize = 32;
/// Deepest octree level read: 2^40 cells a side is finer than any file's scaled integers.
const MAX_LEVEL: i32 = 40;

/// Numbers of the buffers `Copc::open` has checked the length of (the header and its first
/// VLR, a hierarchy entry): a shorter one is a bug here, not in the file.
fn number<const N: usize>(b: &[u8], at: usize) -> [u8; N] {
    b[at..at + N].try_into().expect("a buffer of checked length")
}

fn f64_at(b: &[u8], at: usize) -> f64 {
    f64::from_le_bytes(number(b, at))
}

fn i32_at(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes(number(b, at))
}

fn u64_of(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(number(b, at))
}

impl Copc {
    /// The index of `path` if it is a COPC file (a LAS 1.4 file whose first VLR is COPC's
    /// info), `None` for any other LAS/LAZ file. A COPC file whose index contradicts itself
    /// (node chunks overlapping or leaving gaps, counts that do not add up to the header's)
    /// is an error.
    pub fn open(path: &Path) -> Result<Option<Copc>, IoError> {
        let io = |source| IoError::Io { path: path.to_owned(), source };
        let mut file = std::fs::File::open(path).map_err(io)?;
        let len = file.seek(SeekFrom::End(0)).map_err(io)?;
        let mut first = vec![0u8; (HEADER_1_4 + VLR_HEADER + 160).min(len as usize)];
        file.seek(SeekFrom::Start(0)).map_err(io)?;
        file.read_exact(&mut first).map_err(io)?;
        let is_copc = first.len() == HEADER_1_4 + VLR_HEADER + 160
            && &first[..4] == b"LASF"
            && first[24..26] == [1, 4]
            && u16::from_le_bytes(number(&first, 94)) as usize == HEADER_1_4
            && first[HEADER_1_4 + 2..HEADER_1_4 + 18].starts_with(b"copc\0")
            && u16::from_le_bytes(number(&first, HEADER_1_4 + 18)) == 1;
        if !is_copc {
            return Ok(None);
        }
        let bad = |message: String| IoError::Format { path: path.to_owned(), message: format!("not a readable COPC file: {message}") };
        let data = u64::from(u32::from_le_bytes(number(&first, 96)));
        if data > len || data < (HEADER_1_4 + VLR_HEADER + 160) as u64 {
            return Err(bad(format!("its point data starts at byte {data}, outside its {len} bytes")));
        }
        let mut head = vec![0u8; data as usize];
        file.seek(SeekFrom::Start(0)).map_err(io)?;
        file.read_exact(&mut head).map_err(io)?;
        let records = u64_of(&head, COUNT);
        let info = &head[HEADER_1_4 + VLR_HEADER..];
        let [cx, cy, _cz, halfsize] = [0, 8, 16, 24].map(|at| f64_at(info, at));
        let (root_offset, root_size) = (u64_of(info, 40), u64_of(info, 48));
        if !(cx.is_finite() && cy.is_finite() && halfsize.is_finite() && halfsize > 0.0) {
            return Err(bad(format!("its octree's cube (centre {cx}, {cy}, half size {halfsize}) is not finite")));
        }
        let laszip = laszip_vlr(&head).map_err(bad)?;
        // The hierarchy: pages of entries, an entry of count -1 naming a further page.
        let (scale_x, scale_y) = (f64_at(&head, 131), f64_at(&head, 139));
        let margin = scale_x.abs().max(scale_y.abs()) + 1e-9 * (cx.abs().max(cy.abs()) + halfsize);
        let mut nodes = Vec::new();
        let mut pages = vec![(root_offset, root_size)];
        let mut page_bytes = 0u64;
        while let Some((offset, size)) = pages.pop() {
            page_bytes = page_bytes.saturating_add(size);
            if offset.checked_add(size).is_none_or(|end| end > len) || size % ENTRY as u64 != 0 || page_bytes > len {
                return Err(bad(format!("its hierarchy page of {size} bytes at byte {offset} does not fit in its {len} bytes")));
            }
            let mut page = vec![0u8; size as usize];
            file.seek(SeekFrom::Start(offset)).map_err(io)?;
            file.read_exact(&mut page).map_err(io)?;
            for entry in page.as_chunks::<ENTRY>().0 {
                let key = [0, 4, 8, 12].map(|at| i32_at(entry, at));
                let (offset, size, count) = (u64_of(entry, 16), i32_at(entry, 24), i32_at(entry, 28));
                let [level, x, y, z] = key;
                if !(0..=MAX_LEVEL).contains(&level) || [x, y, z].iter().any(|&c| c < 0 || i64::from(c) >= 1i64 << level) || size < 0 || count < -1 {
                    return Err(bad(format!("its hierarchy has an entry it cannot use: key {key:?}, {size} bytes, {count} points")));
                }
                match count {
                    -1 => pages.push((offset, size as u64)),
                    0 => {}
                    _ => {
                        let side = 2.0 * halfsize * 0.5f64.powi(level);
                        let (x0, y0) = (cx - halfsize + f64::from(x) * side, cy - halfsize + f64::from(y) * side);
                        let bounds = [x0 - margin, y0 - margin, x0 + side + margin, y0 + side + margin];
                        nodes.push(CopcNode { key, bounds, first: 0, chunk: Chunk { offset, size: size as u64, count: count as u64 } });
                    }
                }
            }
        }
        // Chunks follow one another from the point data's chunk-table offset on, as reading
        // the file through finds them.
        nodes.sort_by_key(|n| n.chunk.offset);
        let (mut next, mut first) = (data + 8, 0u64);
        for node in &mut nodes {
            let Chunk { offset, size, count } = node.chunk;
            if offset != next || next > len {
                return Err(bad(format!("the chunk of node {:?} starts at byte {offset}, where the chunks before end at {next}", node.key)));
            }
            node.first = first;
            first = first.saturating_add(count);
            next = offset.saturating_add(size);
        }
        if next > len || first != records {
            return Err(bad(format!("its hierarchy's nodes hold {first} points in bytes up to {next}; its header counts {records} points in {len} bytes")));
        }
        Ok(Some(Copc { path: path.to_owned(), head, laszip, records, nodes }))
    }

    /// Every point whose classification is one of `classes` (all when empty), in file order:
    /// the nodes decoded in runs of about equal counts, four a core, on all cores.
    pub fn read_all(&self, classes: &[u8]) -> Result<Vec<[f64; 3]>, IoError> {
        use rayon::prelude::*;
        let runs = (4 * rayon::current_num_threads()).max(1) as u64;
        let per_run = self.records.div_ceil(runs).max(1);
        let groups: Vec<Vec<usize>> = (0..self.nodes.len())
            .collect::<Vec<_>>()
            .chunk_by(|&a, &b| self.nodes[a].first / per_run == self.nodes[b].first / per_run)
            .map(<[usize]>::to_vec)
            .collect();
        let parts = groups.par_iter().map(|nodes| self.read(nodes, classes)).collect::<Result<Vec<_>, _>>()?;
        Ok(parts.into_iter().flat_map(|part| part.points.into_iter().map(|(_, p)| p)).collect())
    }

    /// The points of `nodes` (indices into [`Copc::nodes`], in increasing order) whose
    /// classification is one of `classes` (every one when empty), each with its record number
    /// in the file, in file order. A point outside its node's cube is an error: a region would
    /// miss it.
    pub fn read(&self, nodes: &[usize], classes: &[u8]) -> Result<NodePoints, IoError> {
        let path = &self.path;
        let chosen: Vec<&CopcNode> = nodes.iter().map(|&k| &self.nodes[k]).collect();
        let chunks: Vec<Chunk> = chosen.iter().map(|n| n.chunk).collect();
        let NodePoints { mut points, decoded } = decode_chunks(path, &self.head, &self.laszip, &chunks, classes)?;
        // Record numbers in the selection's file, to the whole file's; each point in its cube.
        let (mut k, mut before) = (0, 0u64);
        for (record, p) in &mut points {
            while *record >= before + chosen[k].chunk.count {
                before += chosen[k].chunk.count;
                k += 1;
            }
            let node = chosen[k];
            let [x0, y0, x1, y1] = node.bounds;
            if !(x0..=x1).contains(&p[0]) || !(y0..=y1).contains(&p[1]) {
                return Err(IoError::Format {
                    path: path.clone(),
                    message: format!("COPC node {:?} holds point record {} at ({}, {}), outside its cube", node.key, node.first + *record - before, p[0], p[1]),
                });
            }
            *record = node.first + *record - before;
        }
        Ok(NodePoints { points, decoded })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(name)
    }

    /// Every node read gives the file's points as reading it through as LAZ does, in its
    /// order; some nodes give those of their record ranges; `--class` filters alike. (Two
    /// COPC files from laspy's tests, one with its hierarchy in two pages.)
    #[test]
    fn nodes_read_as_the_whole_file_reads() {
        for name in ["simple.copc.laz", "simple_with_page.copc.laz"] {
            let path = data(name);
            let copc = Copc::open(&path).unwrap().expect("a COPC file");
            let whole = crate::las::read_through(&path, &[]).unwrap();
            assert_eq!(crate::read_las(&path).unwrap(), whole, "{name}: its nodes decoded on all cores");
            assert_eq!(copc.records, whole.len() as u64);
            assert!(copc.nodes.len() > 4, "{name}: {} nodes", copc.nodes.len());
            let all: Vec<usize> = (0..copc.nodes.len()).collect();
            let points = copc.read(&all, &[]).unwrap().points;
            assert_eq!(points.iter().map(|&(_, p)| p).collect::<Vec<_>>(), whole, "{name}");
            assert!(points.iter().enumerate().all(|(k, &(record, _))| record == k as u64));
            let some: Vec<usize> = all.iter().copied().filter(|k| k % 3 != 1).collect();
            let points = copc.read(&some, &[]).unwrap().points;
            let expected: Vec<(u64, [f64; 3])> = some
                .iter()
                .flat_map(|&k| {
                    let n = copc.nodes[k];
                    (n.first..n.first + n.count()).map(|r| (r, whole[r as usize]))
                })
                .collect();
            assert_eq!(points, expected, "{name}");
            for class in [1u8, 2] {
                let read = copc.read(&all, &[class]).unwrap();
                assert_eq!(read.points.iter().map(|&(_, p)| p).collect::<Vec<_>>(), crate::las::read_through(&path, &[class]).unwrap(), "{name}");
                assert_eq!(crate::read_las_classes(&path, &[class]).unwrap(), crate::las::read_through(&path, &[class]).unwrap());
                assert_eq!(read.decoded, copc.records);
            }
        }
        assert!(Copc::open(&data("autzen_trim.laz")).unwrap().is_none(), "a plain LAZ file");
    }

    /// A corrupt index or chunk is the file's error, never a panic nor points of another node.
    #[test]
    fn a_corrupt_index_or_chunk_is_an_error() {
        let path = data("simple_with_page.copc.laz");
        let bytes = std::fs::read(&path).unwrap();
        let copc = Copc::open(&path).unwrap().unwrap();
        let dir = std::env::temp_dir().join(format!("tileraster-copc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let info = HEADER_1_4 + VLR_HEADER;
        let root = u64_of(&bytes, info + 40) as usize;
        let written = |name: &str, edit: &dyn Fn(&mut Vec<u8>)| {
            let mut b = bytes.clone();
            edit(&mut b);
            let p = dir.join(name);
            std::fs::write(&p, b).unwrap();
            p
        };
        // A root entry's count one more: the nodes no longer add up to the header.
        let p = written("count.copc.laz", &|b| {
            let n = i32_at(b, root + 28);
            b[root + 28..root + 32].copy_from_slice(&(n + 1).to_le_bytes());
        });
        assert!(Copc::open(&p).unwrap_err().to_string().contains("hold"), "count");
        // A page past the end of the file.
        let p = written("page.copc.laz", &|b| b[info + 40..info + 48].copy_from_slice(&(1u64 << 40).to_le_bytes()));
        assert!(Copc::open(&p).unwrap_err().to_string().contains("does not fit"), "page");
        let p = written("size.copc.laz", &|b| b[info + 48..info + 56].copy_from_slice(&u64::MAX.to_le_bytes()));
        assert!(Copc::open(&p).unwrap_err().to_string().contains("does not fit"), "page size");
        // A key deeper than its level allows.
        let p = written("key.copc.laz", &|b| b[root + 4..root + 8].copy_from_slice(&5i32.to_le_bytes()));
        assert!(Copc::open(&p).unwrap_err().to_string().contains("cannot use"), "key");
        // Garbage in every node's chunk: each read fails or gives its records' count, in its cube.
        let p = written("chunk.copc.laz", &|b| {
            for n in &copc.nodes {
                for k in (n.chunk.offset as usize + 40..(n.chunk.offset + n.chunk.size) as usize).step_by(7) {
                    b[k] ^= 0x5a;
                }
            }
        });
        let broken = Copc::open(&p).unwrap().unwrap();
        for k in 0..broken.nodes.len() {
            if let Ok(read) = broken.read(&[k], &[]) {
                assert_eq!(read.points.len() as u64, broken.nodes[k].count());
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
