//! LAS and LAZ point clouds (the `las` crate, with LAZ decompression): every point record's
//! x, y, z with the file's scale and offset applied. Errors name the file and the record.
//!
//! `las` and `laz` take counts, offsets and sizes from the file on trust, to multiply, to
//! index and to allocate by; `vet` checks those against the input's length first.

use crate::IoError;
use crate::chunks::{u16_at, u32_at};
use std::io::{BufReader, Cursor, Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Read the points of a LAS or LAZ file.
pub fn read_las(path: &Path) -> Result<Vec<[f64; 3]>, IoError> {
    read_las_classes(path, &[])
}

/// Read the points of a LAS or LAZ file whose classification is one of `classes` (all points
/// when it is empty): `&[2]` keeps the ground points, the usual step before a bare-earth DEM.
/// A LAZ file of several chunks (a COPC file's nodes among them) is decoded in runs of chunks
/// on all cores: the same points in the same order.
pub fn read_las_classes(path: &Path, classes: &[u8]) -> Result<Vec<[f64; 3]>, IoError> {
    if let Some(copc) = crate::Copc::open(path)? {
        let points = copc.read_all(classes)?;
        if !points.is_empty() {
            return Ok(points);
        }
        // None of the classes asked for: the error below names those the file holds.
    } else if let Some(points) = read_in_chunks(path, classes) {
        return Ok(points);
    }
    read_through(path, classes)
}

/// The points of a chunked LAZ file, its chunks decoded in runs on all cores; `None` for a
/// file of one chunk or none, or one whose chunk table, checks or decoding fail: reading it
/// through then gives its points or its error, as for any file.
fn read_in_chunks(path: &Path, classes: &[u8]) -> Option<Vec<[f64; 3]>> {
    use crate::chunks::{Chunk, decode_chunks, laszip_vlr};
    use rayon::prelude::*;
    let mut file = std::fs::File::open(path).ok()?;
    let len = file.seek(SeekFrom::End(0)).ok()?;
    vet(&mut file, len).ok()?;
    file.seek(SeekFrom::Start(0)).ok()?;
    let raw = las::raw::Header::read_from(&mut file).ok()?;
    let count = match (raw.number_of_point_records, raw.large_file) {
        (0, Some(large)) => large.number_of_point_records,
        (legacy, _) => u64::from(legacy),
    };
    let data = u64::from(raw.offset_to_point_data);
    if raw.point_data_record_format & 0x80 == 0 || data > len {
        return None;
    }
    let mut head = vec![0u8; data as usize];
    file.seek(SeekFrom::Start(0)).ok()?;
    file.read_exact(&mut head).ok()?;
    let laszip = laszip_vlr(&head).ok()?;
    if !matches!(u16_at(&laszip, 0)?, POINT_WISE_CHUNKED | LAYERED_CHUNKED) {
        return None;
    }
    let vlr = laz::LazVlr::read_from(laszip.as_slice()).ok()?;
    file.seek(SeekFrom::Start(data)).ok()?;
    let table = laz::laszip::ChunkTable::read_from(&mut file, &vlr).ok()?;
    // Fixed-size chunks: the table has their sizes only, the last holds what is left.
    let fixed = match vlr.uses_variable_size_chunks() {
        true => None,
        false => Some(u64::from(u32_at(&laszip, 12)?)),
    };
    let (mut chunks, mut offset, mut before) = (Vec::with_capacity(table.len()), data + 8, 0u64);
    for entry in &table {
        let points = fixed.map_or(entry.point_count, |size| size.min(count.saturating_sub(before)));
        chunks.push(Chunk { offset, size: entry.byte_count, count: points });
        offset = offset.checked_add(entry.byte_count)?;
        before += points;
    }
    if chunks.len() < 2 || before != count || offset > len || chunks.iter().any(|c| c.count == 0) {
        return None;
    }
    // Runs of whole chunks, about four a core; only the last run ends with a short chunk.
    let runs = (4 * rayon::current_num_threads()).clamp(1, chunks.len());
    let per_run = chunks.len().div_ceil(runs);
    let parts: Vec<Option<Vec<[f64; 3]>>> = chunks
        .par_chunks(per_run)
        .map(|run| decode_chunks(path, &head, &laszip, run, classes).ok().map(|read| read.points.into_iter().map(|(_, p)| p).collect()))
        .collect();
    let points: Vec<[f64; 3]> = parts.into_iter().collect::<Option<Vec<_>>>()?.concat();
    // A run that starts where no chunk does (a table whose sizes are wrong, which reading
    // through never looks at) decodes noise: every point must lie in the header's bounds.
    let slack = |scale: f64, lo: f64, hi: f64| 2.0 * scale.abs() + 1e-9 * lo.abs().max(hi.abs());
    let box_of = |scale: f64, lo: f64, hi: f64| (lo - slack(scale, lo, hi), hi + slack(scale, lo, hi));
    let [(x0, x1), (y0, y1), (z0, z1)] =
        [box_of(raw.x_scale_factor, raw.min_x, raw.max_x), box_of(raw.y_scale_factor, raw.min_y, raw.max_y), box_of(raw.z_scale_factor, raw.min_z, raw.max_z)];
    let inside = |p: &[f64; 3]| (x0..=x1).contains(&p[0]) && (y0..=y1).contains(&p[1]) && (z0..=z1).contains(&p[2]);
    (!points.is_empty() && points.iter().all(inside)).then_some(points)
}

/// [`read_las_classes`] record by record from the start, on one thread: how any LAS/LAZ file
/// reads, a COPC file included.
pub(crate) fn read_through(path: &Path, classes: &[u8]) -> Result<Vec<[f64; 3]>, IoError> {
    let file = std::fs::File::open(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    read_from(BufReader::new(file), path, classes)
}

/// The number of point records a LAS or LAZ file's header states, read from the header alone.
pub fn las_point_count(path: &Path) -> Result<u64, IoError> {
    let file = std::fs::File::open(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    let raw = las::raw::Header::read_from(BufReader::new(file)).map_err(|e| unreadable(path, e))?;
    Ok(match (raw.number_of_point_records, raw.large_file) {
        (0, Some(large)) => large.number_of_point_records,
        (legacy, _) => u64::from(legacy),
    })
}

/// Parse LAS or LAZ bytes; `origin` only names the source in errors.
pub fn parse_las(bytes: &[u8], origin: &Path) -> Result<Vec<[f64; 3]>, IoError> {
    read_from(Cursor::new(bytes.to_vec()), origin, &[])
}

/// Stack of the thread that decodes, and how deep into it `laz` may be when it reads.
const DECODING_STACK: usize = 256 << 20;
const DECODING_DEPTH: usize = 16 << 20;

fn read_from<R: Read + Seek + Send + Sync + 'static>(source: R, origin: &Path, classes: &[u8]) -> Result<Vec<[f64; 3]>, IoError> {
    let (points, seen) = decode(source, origin, classes, |_, p| p)?;
    let fail = |message: String| IoError::Format { path: origin.to_owned(), message };
    if points.is_empty() && seen.iter().any(|&n| n > 0) {
        let held: Vec<String> = (0..256).filter(|&c| seen[c] > 0).map(|c| format!("class {c}: {} points", seen[c])).collect();
        let asked: Vec<String> = classes.iter().map(u8::to_string).collect();
        return Err(fail(format!(
            "no point is of class {} (the file holds {}); choose other classes or leave --class out",
            asked.join(" or "),
            held.join(", ")
        )));
    }
    if points.is_empty() {
        return Err(fail("the file holds no points".into()));
    }
    Ok(points)
}

/// Points of each classification a decoding saw, kept or not.
pub(crate) type Seen = [u64; 256];

/// Decode the LAS or LAZ file in `source` (`origin` names it in errors): `keep` of each record
/// number and its point (x, y, z with the file's scale and offset) whose classification is one
/// of `classes` (every one when it is empty), in file order; and the points of each class seen.
pub(crate) fn decode<R: Read + Seek + Send + Sync + 'static, T: Send + 'static>(
    mut source: R,
    origin: &Path,
    classes: &[u8],
    keep: fn(u64, [f64; 3]) -> T,
) -> Result<(Vec<T>, Seen), IoError> {
    let io = |source| IoError::Io { path: origin.to_owned(), source };
    let len = source.seek(SeekFrom::End(0)).map_err(io)?;
    let plan = vet(&mut source, len).map_err(|e| unreadable(origin, e))?;
    source.seek(SeekFrom::Start(0)).map_err(io)?;
    // Decoding runs on a thread of its own, whose stack bounds `laz`'s recursion (see `Guard`).
    // Last resort: `laz` indexes its decoding tables with values decoded from the file, and its
    // chunk table by chunk, and panics where corrupt data takes them out of range; nothing
    // short of decoding finds those first, so a panic while decoding, caught where the thread
    // is joined (as `catch_unwind` would), is this file's error. (The fuzz target lets panics
    // located in `laz` unwind.)
    silence_laz_panics();
    let path = origin.to_owned();
    let classes = classes.to_vec();
    let decoding = std::thread::Builder::new()
        .name(DECODER_THREAD.into())
        .stack_size(DECODING_STACK)
        .spawn(move || {
            let fail = |message: String| IoError::Format { path: path.clone(), message };
            let armed = Arc::new(AtomicBool::new(false));
            let guard = Guard { source, at: 0, plan, next: 0, armed: armed.clone(), base: stack_address() };
            let mut reader = las::Reader::new(guard).map_err(|e| unreadable(&path, e))?;
            armed.store(true, Ordering::Relaxed);
            points(&mut reader, len, &classes, &fail, keep)
        })
        .map_err(io)?;
    decoding.join().unwrap_or_else(|panic| {
        let what = panic.downcast_ref::<&str>().copied().or(panic.downcast_ref::<String>().map(String::as_str));
        Err(unreadable(origin, format_args!("decoding failed: {}", what.unwrap_or("no message"))))
    })
}

const DECODER_THREAD: &str = "las-decoder";

/// Panics inside `laz` on the decoding thread become the file's error, so the panic hook need
/// not print them as well: chain a hook, once, that stays silent for exactly those and hands
/// every other panic to the hook it replaces.
fn silence_laz_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let decoding = std::thread::current().name() == Some(DECODER_THREAD);
            let in_laz = info.location().is_some_and(|at| at.file().replace('\\', "/").contains("/laz-"));
            if !(decoding && in_laz) {
                previous(info);
            }
        }));
    });
}

pub(crate) fn unreadable(path: &Path, e: impl std::fmt::Display) -> IoError {
    IoError::Format { path: path.to_owned(), message: format!("not a readable LAS/LAZ file: {e}") }
}

fn points<T>(
    reader: &mut las::Reader,
    len: u64,
    classes: &[u8],
    fail: &dyn Fn(String) -> IoError,
    keep: fn(u64, [f64; 3]) -> T,
) -> Result<(Vec<T>, Seen), IoError> {
    let header = reader.header();
    // No more than the input's bytes hold uncompressed (a LAZ file's grow past that).
    let record_len = u64::from(header.point_format().len()).max(1);
    let mut points = Vec::with_capacity(header.number_of_points().min(len / record_len) as usize);
    let mut seen = [0u64; 256];
    for (record, point) in reader.points().enumerate() {
        let p = point.map_err(|e| fail(format!("point record {record}: {e}")))?;
        let class = u8::from(p.classification);
        seen[class as usize] += 1;
        if !(classes.is_empty() || classes.contains(&class)) {
            continue;
        }
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            return Err(fail(format!("point record {record}: ({}, {}, {}) is not finite", p.x, p.y, p.z)));
        }
        points.push(keep(record as u64, [p.x, p.y, p.z]));
    }
    Ok((points, seen))
}

fn stack_address() -> usize {
    let here = 0u8;
    std::hint::black_box(&here) as *const u8 as usize
}

/// What reading must hold `laz` to, past the header: where layered LAZ chunks end, and their
/// GPS-time layers, which it is not to see.
#[derive(Default)]
struct Plan {
    end: Option<u64>,
    gps_layers: Vec<GpsLayer>,
}

/// A layered chunk's GPS-time layer: its `len` bytes at byte `at`, its size at byte `size`.
struct GpsLayer {
    size: u64,
    at: u64,
    len: u64,
}

/// `source` as `laz` sees it once `armed` (the header and chunk table read):
/// - it ends where the layered chunks end (`plan.end`): what `laz` would read past them as
///   one more chunk has sizes nothing checked;
/// - the layered chunks' GPS-time layers are left out, their sizes read as 0: `laz` recurses
///   once per sequence switch a corrupt GPS layer codes, without bound and without a read;
/// - a read fails from deeper than `DECODING_DEPTH` into the stack: `laz` recurses so on
///   point-wise GPS times too, reading every few tens of thousands of levels at most.
struct Guard<R> {
    source: R,
    at: u64,
    plan: Plan,
    /// The first GPS layer not behind `at`.
    next: usize,
    armed: Arc<AtomicBool>,
    base: usize,
}

impl<R: Read + Seek> Read for Guard<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if !self.armed.load(Ordering::Relaxed) {
            let n = self.source.read(buf)?;
            self.at += n as u64;
            return Ok(n);
        }
        if self.base.abs_diff(stack_address()) > DECODING_DEPTH {
            return Err(std::io::Error::other("LAZ decoding nests too deep"));
        }
        while let Some(layer) = self.plan.gps_layers.get(self.next).filter(|l| l.at <= self.at) {
            let end = layer.at + layer.len;
            if end > self.at {
                self.at = self.source.seek(SeekFrom::Start(end))?;
            }
            self.next += 1;
        }
        let next = self.plan.gps_layers.get(self.next);
        let stop = next.map_or(u64::MAX, |l| l.at).min(self.plan.end.unwrap_or(u64::MAX));
        let n = buf.len().min(usize::try_from(stop.saturating_sub(self.at)).unwrap_or(usize::MAX));
        let n = self.source.read(&mut buf[..n])?;
        if let Some(layer) = next {
            for k in layer.size.max(self.at)..(layer.size + 4).min(self.at + n as u64) {
                buf[(k - self.at) as usize] = 0;
            }
        }
        self.at += n as u64;
        Ok(n)
    }
}

impl<R: Seek> Seek for Guard<R> {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        self.at = self.source.seek(to)?;
        self.next = self.plan.gps_layers.partition_point(|l| l.at + l.len <= self.at);
        Ok(self.at)
    }
}

/// Size of an extended VLR's header.
const EVLR_HEADER: u64 = 60;

/// `n` bytes at byte `at` of `source`, or none if it ends first.
fn bytes_at<R: Read + Seek>(source: &mut R, at: u64, n: usize) -> Option<Vec<u8>> {
    let mut bytes = vec![0; n];
    source.seek(SeekFrom::Start(at)).ok()?;
    source.read_exact(&mut bytes).ok()?;
    Some(bytes)
}

/// Check what `las::Reader::new` and `laz` trust in the input's `len` bytes; what reading
/// must hold `laz` to.
fn vet<R: Read + Seek>(source: &mut R, len: u64) -> Result<Plan, String> {
    source.seek(SeekFrom::Start(0)).map_err(|e| e.to_string())?;
    let raw = las::raw::Header::read_from(&mut *source).map_err(|e| e.to_string())?;
    let count = match (raw.number_of_point_records, raw.large_file) {
        (0, Some(large)) => large.number_of_point_records,
        (legacy, _) => u64::from(legacy),
    };
    let record = u64::from(raw.point_data_record_length);
    let data = u64::from(raw.offset_to_point_data);
    let end = count
        .checked_mul(record)
        .and_then(|bytes| bytes.checked_add(data))
        .ok_or_else(|| format!("the header's {count} point records of {record} bytes overflow"))?;
    let compressed = raw.point_data_record_format & 0x80 != 0;
    if !compressed && end > len {
        return Err(format!("the header's {count} point records of {record} bytes do not fit in {len} bytes"));
    }
    if let Some(evlr) = raw.evlr {
        let start = evlr.start_of_first_evlr;
        let room = len.checked_sub(start).and_then(|n| n.checked_sub(EVLR_HEADER));
        let size = room.and_then(|_| bytes_at(source, start + 20, 8)).map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")));
        match (room, size) {
            (Some(room), Some(size)) if size <= room => {}
            _ => return Err(format!("the extended VLR at byte {start} does not fit in {len} bytes")),
        }
    }
    if !compressed {
        return Ok(Plan::default());
    }
    source.seek(SeekFrom::Start(0)).map_err(|e| e.to_string())?;
    let header = las::Header::new(&mut *source).map_err(|e| e.to_string())?;
    match header.vlrs().iter().find(|vlr| las::laz::is_laszip_vlr(vlr)) {
        Some(vlr) => vet_laz(source, len, data, count, &vlr.data),
        None => Ok(Plan::default()), // `las` refuses it
    }
}

/// LASzip's compressors (the VLR's first field).
const POINT_WISE: u16 = 1;
const POINT_WISE_CHUNKED: u16 = 2;
const LAYERED_CHUNKED: u16 = 3;

/// Check the LASzip VLR (`vlr`), the chunk table and, for layered compression, the chunks'
/// layer sizes, which `laz` allocates before reading; the point data starts at byte `data`,
/// the header counts `count` records. For layered LAZ, where its chunks end and their GPS-time
/// layers.
fn vet_laz<R: Read + Seek>(source: &mut R, len: u64, data: u64, count: u64, vlr: &[u8]) -> Result<Plan, String> {
    let (Some(compressor), Some(chunk_size), Some(items)) = (u16_at(vlr, 0), u32_at(vlr, 12), u16_at(vlr, 32)) else {
        return Ok(Plan::default()); // too short: `laz` refuses it
    };
    let variable = matches!(chunk_size, 0 | u32::MAX);
    if compressor == POINT_WISE && variable {
        return Err("point-wise LASzip compression with variable-size chunks".into());
    }
    // Each item: type, size, version. Layered ones (version 3): its raw first point's bytes
    // and its number of layers.
    let items: Option<Vec<[u16; 3]>> =
        (0..usize::from(items)).map(|k| Some([u16_at(vlr, 34 + 6 * k)?, u16_at(vlr, 36 + 6 * k)?, u16_at(vlr, 38 + 6 * k)?])).collect();
    let Some(items) = items else {
        return Ok(Plan::default()); // too short: `laz` refuses it
    };
    if items.is_empty() {
        return Err("the LASzip VLR lists no items".into());
    }
    let layered: Option<Vec<(u64, u64)>> = items
        .iter()
        .map(|&[kind, size, version]| match (kind, version) {
            (10, 3) => Some((30, 9)),
            (11, 3) => Some((6, 1)),
            (12, 3) => Some((8, 2)),
            (13, 3) => Some((29, 1)),
            (14, 3) => Some((u64::from(size), u64::from(size))),
            _ => None,
        })
        .collect();
    // The chunk table, where `laz` looks for it: at the offset that opens the point data,
    // else at the one in the file's last 8 bytes.
    let table = match compressor {
        POINT_WISE_CHUNKED | LAYERED_CHUNKED => {
            let mut offset_at = |at: u64| bytes_at(source, at, 8).map(|b| i64::from_le_bytes(b.try_into().expect("8 bytes")));
            let after = |offset: i64| (offset > data as i64).then_some(offset as u64);
            offset_at(data).and_then(after).or_else(|| offset_at(len.checked_sub(8)?).and_then(after))
        }
        _ => None,
    };
    // `laz` reserves an entry per chunk the table counts; each chunk takes input bytes.
    if let Some(chunks) = table.and_then(|at| bytes_at(source, at.checked_add(4)?, 4)).map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")))
        && u64::from(chunks) > len
    {
        return Err(format!("the LAZ chunk table counts {chunks} chunks in {len} bytes"));
    }
    let Some(layered) = layered else {
        return Ok(Plan::default()); // point-wise items (or items `laz` refuses)
    };
    // Layered chunks follow one another from the point data on (past the chunk table's
    // offset): a raw point, a point count, each layer's size, the layers. `laz` reads them in
    // turn, as many as its chunk sizes take for the header's count.
    let fence = table.unwrap_or(len);
    let chunks = match (variable, table) {
        (false, _) if compressor == POINT_WISE => count.div_ceil(u32::MAX.into()),
        (false, _) => count.div_ceil(u64::from(chunk_size)),
        (true, Some(_)) => u64::MAX, // up to the fence
        (true, None) => 1,
    };
    let (raw, layers) = layered.iter().fold((0, 0), |(r, l), &(raw, layers)| (r + raw, l + layers));
    // Each point-14 item's GPS-time layer is the last of its 9.
    let (mut gps, mut first) = (Vec::new(), 0);
    for (&[kind, ..], &(_, layers)) in items.iter().zip(&layered) {
        if kind == 10 {
            gps.push(first + 8);
        }
        first += layers as usize;
    }
    let head = raw + 4 + 4 * layers;
    let mut at = data + if compressor == POINT_WISE { 0 } else { 8 };
    let mut gps_layers = Vec::new();
    for chunk in 0..chunks {
        let Some(sizes) = at.checked_add(head).filter(|&end| end <= fence).and_then(|_| bytes_at(source, at + raw + 4, 4 * layers as usize)) else {
            break; // `laz` stops here, short of bytes
        };
        let sizes: Vec<u64> = sizes.as_chunks::<4>().0.iter().map(|&b| u64::from(u32::from_le_bytes(b))).collect();
        let body: u64 = sizes.iter().sum();
        if body > fence - (at + head) {
            return Err(format!("LAZ chunk {chunk} at byte {at} has {body} bytes of layers, past byte {fence}"));
        }
        for &layer in &gps {
            let len = sizes[layer];
            if len > 0 {
                gps_layers.push(GpsLayer { size: at + raw + 4 + 4 * layer as u64, at: at + head + sizes[..layer].iter().sum::<u64>(), len });
            }
        }
        at += head + body;
    }
    Ok(Plan { end: Some(fence), gps_layers })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a 0.01 grid, as LAS's scaled integers hold them.
    fn grid_points(n: usize) -> Vec<[f64; 3]> {
        (0..n).map(|k| [1000.0 + (k % 7) as f64 * 1.25, 2000.0 + (k / 7) as f64 * 0.75, (k * 37 % 101) as f64 * 0.01]).collect()
    }

    /// LAS 1.`minor` bytes of `points` in point `format`; compressed with LASzip chunks of
    /// `chunk` points (`Some(0)`: variable-size chunks, one here) where `chunk` is given.
    fn file(minor: u8, format: u8, chunk: Option<u32>, points: &[[f64; 3]]) -> Vec<u8> {
        let write = |vlrs: Vec<las::Vlr>| {
            let mut builder = las::Builder::from((1, minor));
            builder.point_format = las::point::Format::new(format).unwrap();
            builder.point_format.is_compressed = chunk.is_some();
            builder.transforms = las::Vector {
                x: las::Transform { scale: 0.01, offset: 1000.0 },
                y: las::Transform { scale: 0.01, offset: 2000.0 },
                z: las::Transform { scale: 0.01, offset: 0.0 },
            };
            builder.vlrs = vlrs;
            let mut writer = las::Writer::new(Cursor::new(Vec::new()), builder.into_header().unwrap()).unwrap();
            let format = *writer.header().point_format();
            for &[x, y, z] in points {
                let (gps_time, color, nir) =
                    (format.has_gps_time.then_some(x), format.has_color.then_some(las::Color::new(1, 2, 3)), format.has_nir.then_some(4));
                writer.write_point(las::Point { x, y, z, gps_time, color, nir, ..Default::default() }).unwrap();
            }
            writer.into_inner().unwrap().into_inner()
        };
        let bytes = write(Vec::new());
        match chunk {
            Some(size) if size != 50_000 => {
                // The writer keeps a LASzip VLR of the header's ahead of its own.
                let header = las::Reader::new(Cursor::new(bytes)).unwrap().header().clone();
                let mut vlr = header.vlrs().iter().find(|v| las::laz::is_laszip_vlr(v)).unwrap().clone();
                vlr.data[12..16].copy_from_slice(&size.to_le_bytes());
                write(vec![vlr])
            }
            _ => bytes,
        }
    }

    fn parse(bytes: &[u8]) -> Result<Vec<[f64; 3]>, String> {
        parse_las(bytes, Path::new("t.las")).map_err(|e| e.to_string())
    }

    fn put(bytes: &mut [u8], at: usize, value: &[u8]) {
        bytes[at..at + value.len()].copy_from_slice(value);
    }

    #[test]
    fn las_and_laz_give_back_the_points() {
        let dir = std::env::temp_dir().join(format!("tileraster-las-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // Values on the default 0.001 grid of LAS's scaled integers.
        let points: Vec<[f64; 3]> =
            (0..500).map(|k| [500_000.0 + (k % 25) as f64 * 1.5, 5_000_000.0 + (k / 25) as f64 * 2.25, 100.0 + k as f64 * 0.125]).collect();
        for (name, compressed) in [("p.las", false), ("p.laz", true)] {
            let path = dir.join(name);
            let mut builder = las::Builder::from((1, 2));
            builder.point_format.is_compressed = compressed;
            builder.transforms.x.offset = 500_000.0;
            builder.transforms.y.offset = 5_000_000.0;
            let mut writer = las::Writer::from_path(&path, builder.into_header().unwrap()).unwrap();
            for p in &points {
                writer.write_point(las::Point { x: p[0], y: p[1], z: p[2], ..Default::default() }).unwrap();
            }
            writer.close().unwrap();
            drop(writer);
            assert_eq!(read_las(&path).unwrap(), points, "{name}");
            assert_eq!(parse_las(&std::fs::read(&path).unwrap(), Path::new(name)).unwrap(), points, "{name}");
        }
        let garbage = dir.join("g.las");
        std::fs::write(&garbage, b"LASF but not really").unwrap();
        assert!(read_las(&garbage).unwrap_err().to_string().starts_with(&format!("{}: not a readable LAS/LAZ file", garbage.display())));
        std::fs::remove_dir_all(&dir).ok();
    }

    /// `--class`: only the points of the classes asked for, in file order; none of them is an
    /// error that lists the classes the file holds.
    #[test]
    fn classes_filter_the_points() {
        let dir = std::env::temp_dir().join(format!("tileraster-las-classes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let points = grid_points(60);
        let class = |k: usize| [1u8, 2, 2, 9][k % 4];
        for name in ["c.las", "c.laz"] {
            let path = dir.join(name);
            let mut builder = las::Builder::from((1, 4));
            builder.point_format.is_compressed = name.ends_with('z');
            builder.transforms = las::Vector {
                x: las::Transform { scale: 0.01, offset: 1000.0 },
                y: las::Transform { scale: 0.01, offset: 2000.0 },
                z: las::Transform { scale: 0.01, offset: 0.0 },
            };
            let mut writer = las::Writer::from_path(&path, builder.into_header().unwrap()).unwrap();
            for (k, p) in points.iter().enumerate() {
                let classification = las::point::Classification::new(class(k)).unwrap();
                writer.write_point(las::Point { x: p[0], y: p[1], z: p[2], classification, ..Default::default() }).unwrap();
            }
            writer.close().unwrap();
            drop(writer);
            let of = |classes: &[u8]| points.iter().enumerate().filter(|(k, _)| classes.contains(&class(*k))).map(|(_, p)| *p).collect::<Vec<_>>();
            assert_eq!(read_las_classes(&path, &[2]).unwrap(), of(&[2]), "{name}");
            assert_eq!(read_las_classes(&path, &[9, 2]).unwrap(), of(&[2, 9]), "{name}");
            assert_eq!(read_las_classes(&path, &[]).unwrap(), points, "{name}");
            let e = read_las_classes(&path, &[6, 7]).unwrap_err().to_string();
            assert!(e.contains("no point is of class 6 or 7 (the file holds class 1: 15 points, class 2: 30 points, class 9: 15 points)"), "{e}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn every_version_format_and_chunking_reads_back() {
        let points = grid_points(40);
        for (minor, format) in [(2, 0), (2, 1), (2, 3), (4, 0), (4, 1), (4, 3), (4, 6), (4, 7), (4, 8)] {
            // Point-wise (formats 0-5) and layered (6-10) LASzip; fixed 7-point chunks and
            // variable-size ones run the chunk checks over several chunks and up to the table.
            for chunk in [None, Some(50_000), Some(7), Some(0)] {
                assert_eq!(parse(&file(minor, format, chunk, &points)), Ok(points.clone()), "LAS 1.{minor}, format {format}, chunks {chunk:?}");
            }
        }
    }

    /// A file of several chunks is decoded in runs of chunks on all cores, with the points
    /// and order of reading it through; with `--class` too.
    #[test]
    fn chunks_decoded_apart_give_the_points_read_through() {
        let dir = std::env::temp_dir().join(format!("tileraster-las-chunks-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let points = grid_points(4000);
        for (minor, format) in [(2, 1), (4, 6), (4, 8)] {
            for chunk in [Some(7), Some(500), Some(50_000), None] {
                let path = dir.join(format!("c-{minor}-{format}-{chunk:?}.laz"));
                std::fs::write(&path, file(minor, format, chunk, &points)).unwrap();
                let what = format!("LAS 1.{minor}, format {format}, chunks {chunk:?}");
                let apart = read_in_chunks(&path, &[]);
                assert_eq!(apart.is_some(), matches!(chunk, Some(7 | 500)), "{what}");
                assert_eq!(read_las(&path).unwrap(), points, "{what}");
                assert_eq!(read_through(&path, &[]).unwrap(), points, "{what}");
                assert_eq!(read_las_classes(&path, &[0]).unwrap(), points, "{what}");
                assert!(read_las_classes(&path, &[2]).unwrap_err().to_string().contains("no point is of class 2"), "{what}");
            }
        }
        // A chunk table whose sizes are wrong (a boundary moved), which reading through ignores:
        // the runs start where no chunk does, and the points are still those read through.
        for format in [1, 6] {
            let mut bytes = file(if format == 1 { 2 } else { 4 }, format, Some(7), &points);
            let data = u32::from_le_bytes(bytes[96..100].try_into().unwrap()) as usize;
            let at = i64::from_le_bytes(bytes[data..data + 8].try_into().unwrap()) as usize;
            let header = las::Reader::new(Cursor::new(bytes.clone())).unwrap().header().clone();
            let vlr = laz::LazVlr::read_from(header.vlrs().iter().find(|v| las::laz::is_laszip_vlr(v)).unwrap().data.as_slice()).unwrap();
            let mut cursor = Cursor::new(bytes.clone());
            cursor.set_position(data as u64);
            let table = laz::laszip::ChunkTable::read_from(&mut cursor, &vlr).unwrap();
            let mut entries: Vec<laz::laszip::ChunkTableEntry> = table.as_ref().to_vec();
            entries[0].byte_count += 5;
            entries[1].byte_count -= 5;
            let mut swapped = laz::laszip::ChunkTable::with_capacity(entries.len());
            entries.into_iter().for_each(|e| swapped.push(e));
            bytes.truncate(at);
            swapped.write_to(&mut bytes, &vlr).unwrap();
            let path = dir.join(format!("swapped-{format}.laz"));
            std::fs::write(&path, &bytes).unwrap();
            assert_eq!(read_through(&path, &[]).unwrap(), points, "format {format}");
            assert_eq!(read_las(&path).unwrap(), points, "format {format}: a wrong chunk table");
        }
        // A byte changed anywhere (header, VLRs, chunks, table): decoding apart gives what
        // reading through gives, points or an error, and never panics.
        for format in [1, 6] {
            let bytes = file(if format == 1 { 2 } else { 4 }, format, Some(500), &points);
            let path = dir.join(format!("flipped-{format}.laz"));
            for at in (0..bytes.len()).step_by(bytes.len() / 150) {
                let mut flipped = bytes.clone();
                flipped[at] ^= 0x5a;
                std::fs::write(&path, &flipped).unwrap();
                let (apart, through) = (read_las(&path).map_err(|e| e.to_string()), read_through(&path, &[]).map_err(|e| e.to_string()));
                assert_eq!(apart, through, "format {format}, byte {at} changed");
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn counts_and_sizes_beyond_the_input_are_refused_before_allocating() {
        let refused = |bytes: &[u8], why: &str| {
            let message = parse(bytes).unwrap_err();
            assert!(message.starts_with("t.las: not a readable LAS/LAZ file: ") && message.contains(why), "{message}");
        };
        // 4 Gi point records of 20 bytes in a 400-byte LAS 1.2 file.
        let mut las12 = file(2, 0, None, &grid_points(8));
        put(&mut las12, 107, &u32::MAX.to_le_bytes());
        refused(&las12, "do not fit");
        // LAS 1.4: 2^40 records (legacy count 0); 2^62 records, whose bytes overflow u64.
        let mut las14 = file(4, 0, None, &grid_points(8));
        put(&mut las14, 107, &0u32.to_le_bytes());
        put(&mut las14, 247, &(1u64 << 40).to_le_bytes());
        refused(&las14, "do not fit");
        put(&mut las14, 247, &(1u64 << 62).to_le_bytes());
        refused(&las14, "overflow");
        // An extended VLR of 2^62 bytes at the end of the file.
        let mut evlr = file(4, 0, None, &grid_points(8));
        let at = evlr.len() as u64;
        evlr.extend([0u8; 60]);
        put(&mut evlr, at as usize + 20, &(1u64 << 62).to_le_bytes());
        put(&mut evlr, 235, &at.to_le_bytes());
        put(&mut evlr, 243, &1u32.to_le_bytes());
        refused(&evlr, "extended VLR");
        // A LAZ chunk table counting 2^32 - 1 chunks.
        let laz = file(2, 1, Some(50_000), &grid_points(8));
        let data = u32::from_le_bytes(laz[96..100].try_into().unwrap()) as usize;
        let table = i64::from_le_bytes(laz[data..data + 8].try_into().unwrap()) as usize;
        let mut chunks = laz.clone();
        put(&mut chunks, table + 4, &u32::MAX.to_le_bytes());
        refused(&chunks, "chunk table");
        // A layered LAZ chunk whose first layer claims 4 GiB.
        let mut layered = file(4, 6, Some(50_000), &grid_points(8));
        let data = u32::from_le_bytes(layered[96..100].try_into().unwrap()) as usize;
        put(&mut layered, data + 8 + 30 + 4, &u32::MAX.to_le_bytes());
        refused(&layered, "layers");
        // Point-wise compression, which has no chunk table, with variable-size chunks.
        let mut pointwise = laz.clone();
        let vlr = data_of_laszip_vlr(&pointwise);
        put(&mut pointwise, vlr, &1u16.to_le_bytes());
        put(&mut pointwise, vlr + 12, &0u32.to_le_bytes());
        refused(&pointwise, "variable-size");
    }

    /// Where the LASzip VLR's data starts (the first VLR, as the writer puts it).
    fn data_of_laszip_vlr(bytes: &[u8]) -> usize {
        let header = u16::from_le_bytes(bytes[94..96].try_into().unwrap()) as usize;
        assert_eq!(&bytes[header + 2..header + 16], b"laszip encoded");
        header + 54
    }

    #[test]
    fn laz_claiming_more_points_than_it_holds_is_refused() {
        // 2^40 points claimed by a LAZ file of 8 (LAS 1.4): room is reserved for what its bytes
        // could hold, and decoding stops where they end.
        let mut laz = file(4, 1, Some(50_000), &grid_points(8));
        put(&mut laz, 107, &0u32.to_le_bytes());
        put(&mut laz, 247, &(1u64 << 40).to_le_bytes());
        assert!(parse(&laz).unwrap_err().starts_with("t.las: point record 8: "));
        // Variable-size layered chunks, one more point claimed than the one chunk holds:
        // `laz` would read the chunk table and what follows as the next chunk, allocating its
        // first layer's 4 GiB; it stops at the table instead.
        let mut layered = file(4, 6, Some(0), &grid_points(8));
        put(&mut layered, 247, &9u64.to_le_bytes());
        put(&mut layered, 107, &9u32.to_le_bytes());
        let data = u32::from_le_bytes(layered[96..100].try_into().unwrap()) as usize;
        let table = i64::from_le_bytes(layered[data..data + 8].try_into().unwrap()) as usize;
        layered.resize(layered.len().max(table + 70), 0);
        put(&mut layered, table + 30 + 4, &u32::MAX.to_le_bytes());
        let message = parse(&layered).unwrap_err();
        assert!(message.starts_with("t.las: point record 8: "), "{message}");
        // The same point-wise, with bytes enough after the table for a first point: `laz` reads
        // them as a chunk the table lacks, and panics looking it up.
        let mut pointwise = file(4, 1, Some(0), &grid_points(8));
        put(&mut pointwise, 247, &9u64.to_le_bytes());
        put(&mut pointwise, 107, &9u32.to_le_bytes());
        pointwise.extend([0; 64]);
        let message = parse(&pointwise).unwrap_err();
        assert!(message.starts_with("t.las: not a readable LAS/LAZ file: decoding failed: "), "{message}");
    }

    /// `bytes` with `with` in place of `range`, and the chunk table offset (at the start of
    /// the point data) moved to match.
    fn splice(bytes: &[u8], range: std::ops::Range<usize>, with: &[u8]) -> Vec<u8> {
        let data = u32::from_le_bytes(bytes[96..100].try_into().unwrap()) as usize;
        let table = i64::from_le_bytes(bytes[data..data + 8].try_into().unwrap());
        let mut spliced = [&bytes[..range.start], with, &bytes[range.end..]].concat();
        put(&mut spliced, data, &(table + with.len() as i64 - range.len() as i64).to_le_bytes());
        spliced
    }

    #[test]
    fn corrupt_gps_times_end_in_an_error_or_are_not_decoded() {
        // Point-wise: 1 MiB of ones after the first point (format 1: 28 raw bytes), 1000 points
        // claimed; a few points on, they decode as GPS sequence switches without end, each a
        // level of recursion in `laz`.
        let laz = file(2, 1, Some(50_000), &grid_points(2));
        let data = u32::from_le_bytes(laz[96..100].try_into().unwrap()) as usize;
        let table = i64::from_le_bytes(laz[data..data + 8].try_into().unwrap()) as usize;
        let mut hostile = splice(&laz, data + 8 + 28..table, &[0xff; 1 << 20]);
        put(&mut hostile, 107, &1000u32.to_le_bytes());
        let message = parse(&hostile).unwrap_err();
        assert!(message.starts_with("t.las: point record ") && message.ends_with("LAZ decoding nests too deep"), "{message}");
        // Layered (format 6): the same in the GPS-time layer, which is left undecoded.
        let points = grid_points(2);
        let laz = file(4, 6, Some(50_000), &points);
        let data = u32::from_le_bytes(laz[96..100].try_into().unwrap()) as usize;
        let sizes: Vec<usize> = (0..9).map(|k| u32::from_le_bytes(laz[data + 42 + 4 * k..data + 46 + 4 * k].try_into().unwrap()) as usize).collect();
        let gps = data + 8 + 30 + 4 + 36 + sizes[..8].iter().sum::<usize>();
        assert!(sizes[8] > 0);
        let mut hostile = splice(&laz, gps..gps + sizes[8], &[0xff; 1 << 20]);
        put(&mut hostile, data + 42 + 32, &(1u32 << 20).to_le_bytes());
        assert_eq!(parse(&hostile), Ok(points));
    }
}
