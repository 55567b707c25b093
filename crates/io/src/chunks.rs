//! A LAZ file's chunks decoded apart. LASzip compresses points in chunks that each start
//! afresh, listed by a chunk table; some of them, taken in file order, make a LAZ file of
//! their own: the file's header (counting their points) and VLRs, the chunks, and a chunk
//! table for them. Decoding that file in memory puts every check and guard of the LAS/LAZ
//! reader ([`crate::las`]) on it, so chunks can be read on all cores (a large LAZ file) or
//! only where a region needs them (a COPC file's octree nodes).

use crate::las::{decode, unreadable};
use crate::{IoError, NodePoints};
use std::io::{Cursor, Read, Seek, SeekFrom};
use std::path::Path;

/// One chunk: where it lies in the file and the points it holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Chunk {
    pub offset: u64,
    pub size: u64,
    pub count: u64,
}

/// Header fields (byte offsets) a file of some chunks rewrites: LAS 1.0's counts, and 1.4's.
const LEGACY_COUNT: usize = 107;
const LEGACY_BY_RETURN: std::ops::Range<usize> = 111..131;
const FIRST_EVLR: usize = 235;
const EVLR_COUNT: usize = 243;
pub(crate) const COUNT: usize = 247;
const BY_RETURN: std::ops::Range<usize> = 255..375;
/// LAS 1.4's header size.
pub(crate) const HEADER_1_4: usize = 375;
pub(crate) const VLR_HEADER: usize = 54;

/// Little-endian numbers at byte `at` of `b`, or none where `b` ends first.
pub(crate) fn u16_at(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?))
}

pub(crate) fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

/// The LASzip VLR's data among the VLRs of `head` (a file's bytes up to its point data), or
/// why there is none to use.
pub(crate) fn laszip_vlr(head: &[u8]) -> Result<Vec<u8>, String> {
    let past = || "its VLRs run past the start of its point data".to_string();
    let (mut at, vlrs) = (usize::from(u16_at(head, 94).ok_or_else(past)?), u32_at(head, 100).ok_or_else(past)?);
    for _ in 0..vlrs {
        let (Some(size), Some(record)) = (u16_at(head, at + 20), u16_at(head, at + 18)) else { return Err(past()) };
        let body = at + VLR_HEADER..at + VLR_HEADER + usize::from(size);
        if body.end > head.len() {
            return Err(past());
        }
        if head[at + 2..at + 18].starts_with(b"laszip encoded\0") && record == 22204 {
            return Ok(head[body].to_vec());
        }
        at = body.end;
    }
    Err("it has no LASzip VLR".into())
}

/// `chunks` (in file order) of the LAZ file at `path`, whose bytes up to its point data are
/// `head` and whose LASzip VLR's data is `laszip`: each point of `classes` (all when empty)
/// with its record number among the chunks' points, in order, and the records decoded.
pub(crate) fn decode_chunks(path: &Path, head: &[u8], laszip: &[u8], chunks: &[Chunk], classes: &[u8]) -> Result<NodePoints, IoError> {
    let io = |source| IoError::Io { path: path.to_owned(), source };
    if chunks.windows(2).any(|w| w[0].offset >= w[1].offset) {
        return Err(IoError::Format { path: path.to_owned(), message: "LAZ chunks asked for out of file order".into() });
    }
    if chunks.is_empty() {
        return Ok(NodePoints { points: Vec::new(), decoded: 0 });
    }
    if head.len() < HEADER_1_4.min(usize::from(u16_at(head, 94).unwrap_or(u16::MAX))) {
        return Err(IoError::Format { path: path.to_owned(), message: "its header runs past the start of its point data".into() });
    }
    // The header counting these chunks' points, without EVLRs (LAS 1.4) or returns' counts.
    let mut bytes = head.to_vec();
    let count: u64 = chunks.iter().map(|c| c.count).sum();
    let legacy = if u32_at(head, LEGACY_COUNT) == Some(0) { 0 } else { u32::try_from(count).unwrap_or(0) };
    bytes[LEGACY_COUNT..LEGACY_COUNT + 4].copy_from_slice(&legacy.to_le_bytes());
    bytes[LEGACY_BY_RETURN].fill(0);
    if head[25] >= 4 && head.len() >= HEADER_1_4 && u16_at(head, 94).is_some_and(|size| usize::from(size) >= HEADER_1_4) {
        bytes[FIRST_EVLR..FIRST_EVLR + 8].fill(0);
        bytes[EVLR_COUNT..EVLR_COUNT + 4].fill(0);
        bytes[COUNT..COUNT + 8].copy_from_slice(&count.to_le_bytes());
        bytes[BY_RETURN].fill(0);
    }
    let table_at = bytes.len() as u64 + 8 + chunks.iter().map(|c| c.size).sum::<u64>();
    bytes.extend_from_slice(&table_at.to_le_bytes());
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut table = laz::laszip::ChunkTable::with_capacity(chunks.len());
    for chunk in chunks {
        let start = bytes.len();
        bytes.resize(start + chunk.size as usize, 0);
        file.seek(SeekFrom::Start(chunk.offset)).map_err(io)?;
        file.read_exact(&mut bytes[start..]).map_err(io)?;
        table.push(laz::laszip::ChunkTableEntry { point_count: chunk.count, byte_count: chunk.size });
    }
    let vlr = laz::LazVlr::read_from(laszip).map_err(|e| unreadable(path, e))?;
    table.write_to(&mut bytes, &vlr).map_err(io)?;
    let (points, seen) = decode(Cursor::new(bytes), path, classes, |record, p| (record, p))?;
    Ok(NodePoints { points, decoded: seen.iter().sum() })
}
