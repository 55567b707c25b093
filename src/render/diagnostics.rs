//! What a frame can tell about its own making, equal on both backends: a checksum of every
//! output layer, and a tile heat map (triangles per tile, overdraw, triangles the tiles' depth
//! bounds hid).

use super::{Frame, NO_FACE};
use crate::Error;
use tileraster_core::kernels::TILE;

/// Per-tile counts of a frame (`RenderParams::count_tiles`), `TILE × TILE` pixels a tile, row
/// by row.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TileCounts {
    pub tiles_x: u32,
    pub tiles_y: u32,
    /// The triangles that reach each tile (its bin's entries).
    pub triangles: Vec<u32>,
    /// How many of them the tile's depth bound hid before their depth tests.
    pub hidden: Vec<u32>,
}

impl TileCounts {
    /// From the raster's tile layer (two words a tile).
    pub(super) fn from_layer(width: u32, height: u32, layer: &[u32]) -> TileCounts {
        let (triangles, hidden) = layer.as_chunks::<2>().0.iter().map(|p| (p[0], p[1])).unzip();
        TileCounts { tiles_x: width.div_ceil(TILE), tiles_y: height.div_ceil(TILE), triangles, hidden }
    }
}

/// CRC-32 (the zlib/PNG polynomial, as Python's `zlib.crc32` computes it) of each output layer's
/// bytes, little-endian, row by row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Checksums {
    pub colour: u32,
    pub depth: u32,
    pub ids: u32,
    /// `None` where fragments were not counted.
    pub fragments: Option<u32>,
}

impl Checksums {
    /// One JSON object, each checksum as eight hex digits.
    pub fn to_json(&self) -> String {
        let fragments = self.fragments.map_or("null".to_string(), |c| format!("\"{c:08x}\""));
        format!("{{\"colour\":\"{:08x}\",\"depth\":\"{:08x}\",\"ids\":\"{:08x}\",\"fragments\":{fragments}}}", self.colour, self.depth, self.ids)
    }
}

fn crc<T: Copy>(words: &[T], bytes: impl Fn(T) -> [u8; 4]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    // In blocks, so that the bytes go to the hasher in large slices.
    let mut block = Vec::with_capacity(4096);
    for chunk in words.chunks(1024) {
        block.clear();
        block.extend(chunk.iter().flat_map(|&w| bytes(w)));
        h.update(&block);
    }
    h.finalize()
}

impl Frame {
    /// The checksums of the frame's layers.
    pub fn checksums(&self) -> Checksums {
        Checksums {
            colour: crc(&self.colour, u32::to_le_bytes),
            depth: crc(&self.depth, |d: f32| d.to_bits().to_le_bytes()),
            ids: crc(&self.ids, u32::to_le_bytes),
            fragments: (!self.fragments.is_empty()).then(|| crc(&self.fragments, u32::to_le_bytes)),
        }
    }

    /// The tile heat map, RGBA8 with its width and height: three panels side by side, each the
    /// frame's size with one block per tile: the triangles that reach the tile (log scale, up to
    /// the most in any tile), the overdraw (fragments per covered pixel, from 1 to the most in any
    /// tile; black where nothing is covered), and the triangles the tile's depth bound hid (on the
    /// first panel's scale). Needs the frame's tile counts and fragments
    /// (`RenderParams::count_tiles` and `count_fragments`).
    pub fn heat_map(&self) -> Result<(u32, u32, Vec<u8>), Error> {
        let tiles = self.tiles.as_ref().ok_or(Error::HeatMapNeeds { layer: "tile counts", flag: "count_tiles" })?;
        if self.fragments.is_empty() {
            return Err(Error::HeatMapNeeds { layer: "fragments", flag: "count_fragments" });
        }
        let (w, h) = (self.width as usize, self.height as usize);
        let tx_n = tiles.tiles_x as usize;
        // Fragments and covered pixels per tile.
        let mut fragments = vec![0u64; tiles.triangles.len()];
        let mut covered = vec![0u64; tiles.triangles.len()];
        for y in 0..h {
            for x in 0..w {
                let t = (y / TILE as usize) * tx_n + x / TILE as usize;
                fragments[t] += self.fragments[y * w + x] as u64;
                covered[t] += u64::from(self.ids[y * w + x] != NO_FACE);
            }
        }
        let overdraw: Vec<f64> = fragments.iter().zip(&covered).map(|(&f, &c)| if c == 0 { 0.0 } else { f as f64 / c as f64 }).collect();
        let most_triangles = tiles.triangles.iter().copied().max().unwrap_or(0).max(1) as f64;
        let most_overdraw = overdraw.iter().copied().fold(1.0f64, f64::max);
        let log_scale = |n: u32| if n == 0 { None } else { Some((n as f64).ln_1p() / most_triangles.ln_1p()) };
        let panels: [Box<dyn Fn(usize) -> Option<f64>>; 3] = [
            Box::new(|t| log_scale(tiles.triangles[t])),
            Box::new(|t| (covered[t] > 0).then(|| if most_overdraw > 1.0 { (overdraw[t] - 1.0) / (most_overdraw - 1.0) } else { 0.0 })),
            Box::new(|t| log_scale(tiles.hidden[t])),
        ];
        const GAP: usize = 4;
        let width = 3 * w + 2 * GAP;
        let mut rgba = vec![0u8; width * h * 4];
        for (k, panel) in panels.iter().enumerate() {
            for y in 0..h {
                for x in 0..w {
                    let t = (y / TILE as usize) * tx_n + x / TILE as usize;
                    let colour = panel(t).map_or([0, 0, 0, 255], ramp);
                    let at = (y * width + k * (w + GAP) + x) * 4;
                    rgba[at..at + 4].copy_from_slice(&colour);
                }
            }
        }
        Ok((width as u32, h as u32, rgba))
    }
}

/// A dark-to-bright colour ramp (blue, purple, orange, yellow) at `v` in [0, 1].
fn ramp(v: f64) -> [u8; 4] {
    const STOPS: [[f64; 3]; 5] = [[20.0, 20.0, 90.0], [110.0, 30.0, 140.0], [200.0, 60.0, 90.0], [245.0, 150.0, 40.0], [250.0, 250.0, 160.0]];
    let v = v.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let k = (v.floor() as usize).min(STOPS.len() - 2);
    let f = v - k as f64;
    let c: [u8; 3] = std::array::from_fn(|a| (STOPS[k][a] + f * (STOPS[k + 1][a] - STOPS[k][a])).round() as u8);
    [c[0], c[1], c[2], 255]
}
