//! `--jitter N`: a frame as the average of N frames drawn at sub-pixel offsets of a fixed
//! sequence, added in a fixed order in integers. Each sample is an exact frame of the pipeline
//! (its view-projection matrix moved on the host in `f64`, the same matrix for every backend),
//! so the average is the same bits on every backend: an anti-aliased still without
//! multisampling's memory.

use super::{Frame, RenderParams};
use crate::Error;

/// Samples a jittered frame may take.
pub const MAX_JITTER: u32 = 256;

/// The radical inverse of `k` in `base`: the Halton sequence's coordinate.
fn radical_inverse(mut k: u32, base: u32) -> f64 {
    let (mut value, mut scale) = (0.0, 1.0);
    while k > 0 {
        scale /= base as f64;
        value += (k % base) as f64 * scale;
        k /= base;
    }
    value
}

/// The offset of sample `k` (from 0), in pixels within (−½, ½)²: the Halton sequence in bases 2
/// and 3 from its second point, centred on the pixel. The first sample lies on the pixel's
/// vertical midline, a sixth of a pixel up.
pub fn jitter_offset(k: u32) -> [f64; 2] {
    [radical_inverse(k + 1, 2) - 0.5, radical_inverse(k + 1, 3) - 0.5]
}

/// `params` with the image moved by `offset` pixels (x right, y down): clip-space x and y
/// moved in proportion to w, so perspective and orthographic frames move alike.
pub fn jittered(params: &RenderParams, [dx, dy]: [f64; 2]) -> RenderParams {
    let mut moved = params.clone();
    let [x, y, _, w] = &mut moved.view_projection;
    let (sx, sy) = (2.0 * dx / params.width as f64, 2.0 * dy / params.height as f64);
    for ((x, y), w) in x.iter_mut().zip(y.iter_mut()).zip(w.iter()) {
        *x += sx * w;
        *y += sy * w;
    }
    moved
}

/// The average of `samples` frames that `draw` draws at the sequence's offsets: each colour
/// channel the rounded mean of the samples' (added in sample order in integers), the depth,
/// ids, fragments and statistics the first sample's. One sample is the frame itself, unmoved.
pub fn accumulate(params: &RenderParams, samples: u32, draw: &mut dyn FnMut(&RenderParams) -> Result<Frame, Error>) -> Result<Frame, Error> {
    if samples <= 1 {
        return draw(params);
    }
    let mut first = draw(&jittered(params, jitter_offset(0)))?;
    if first.colour.is_empty() {
        return Ok(first);
    }
    let mut sums: Vec<[u32; 4]> = first.colour.iter().map(|c| c.to_le_bytes().map(u32::from)).collect();
    for k in 1..samples {
        let frame = draw(&jittered(params, jitter_offset(k)))?;
        for (sum, c) in sums.iter_mut().zip(&frame.colour) {
            for (s, b) in sum.iter_mut().zip(c.to_le_bytes()) {
                *s += u32::from(b);
            }
        }
    }
    for (out, sum) in first.colour.iter_mut().zip(&sums) {
        *out = u32::from_le_bytes(sum.map(|s| ((s + samples / 2) / samples) as u8));
    }
    Ok(first)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_offsets_are_halton_points_within_the_pixel() {
        assert_eq!(jitter_offset(0), [0.0, 1.0 / 3.0 - 0.5]);
        assert_eq!(jitter_offset(1), [-0.25, 2.0 / 3.0 - 0.5]);
        assert_eq!(jitter_offset(2), [0.25, 1.0 / 9.0 - 0.5]);
        let offsets: Vec<[f64; 2]> = (0..MAX_JITTER).map(jitter_offset).collect();
        assert!(offsets.iter().all(|o| o.iter().all(|v| (-0.5..0.5).contains(v))));
        // Spread over the pixel: every quarter of it holds about a quarter of the points.
        for quarter in 0..4 {
            let inside = offsets.iter().filter(|o| (o[0] >= 0.0) == (quarter & 1 == 1) && (o[1] >= 0.0) == (quarter & 2 == 2)).count();
            assert!((56..=72).contains(&inside), "quarter {quarter}: {inside}");
        }
    }

    #[test]
    fn a_jittered_matrix_moves_the_image_by_the_offset() {
        let mut params = RenderParams::new(200, 100, super::super::IDENTITY);
        // A perspective-like last row: w = z.
        params.view_projection = [[1.5, 0.0, 0.0, 0.1], [0.0, 3.0, 0.0, -0.2], [0.0, 0.0, 1.0, -0.5], [0.0, 0.0, 1.0, 0.0]];
        let moved = jittered(&params, [0.5, -0.25]);
        let project = |m: &[[f64; 4]; 4], p: [f64; 4]| {
            let c: Vec<f64> = (0..4).map(|r| (0..4).map(|k| m[r][k] * p[k]).sum()).collect();
            [(c[0] / c[3] + 1.0) / 2.0 * 200.0, (c[1] / c[3] + 1.0) / 2.0 * 100.0]
        };
        for p in [[0.3, -0.2, 2.0, 1.0], [-1.0, 0.5, 7.0, 1.0]] {
            let (a, b) = (project(&params.view_projection, p), project(&moved.view_projection, p));
            assert!((b[0] - a[0] - 0.5).abs() < 1e-9 && (b[1] - a[1] + 0.25).abs() < 1e-9, "{a:?} → {b:?}");
        }
    }
}
