use crate::{write_atomically, IoError};
use std::path::Path;
use tileraster_core::Raster;

/// Hypsometric colour ramp: (fraction of the height range, RGB).
const RAMP: [(f32, [f32; 3]); 5] = [
    (0.00, [46.0, 110.0, 60.0]),
    (0.30, [120.0, 165.0, 85.0]),
    (0.55, [215.0, 200.0, 130.0]),
    (0.80, [160.0, 115.0, 80.0]),
    (1.00, [245.0, 245.0, 245.0]),
];

fn ramp(t: f32) -> [f32; 3] {
    let t = t.clamp(0.0, 1.0);
    for w in RAMP.windows(2) {
        let ((a, ca), (b, cb)) = (w[0], w[1]);
        if t <= b {
            let f = (t - a) / (b - a);
            return [0, 1, 2].map(|k| ca[k] + f * (cb[k] - ca[k]));
        }
    }
    RAMP[RAMP.len() - 1].1
}

/// Write a PNG preview: heights on a colour ramp, shaded by a hillshade lit from the
/// north-west; nodata cells are transparent.
pub fn write_preview_png(raster: &Raster, path: &Path) -> Result<(), IoError> {
    let (w, h) = (raster.width() as usize, raster.height() as usize);
    let valid = |i: usize, j: usize| !raster.is_nodata(i as u32, j as u32) && raster.value(i as u32, j as u32).is_finite();
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for j in 0..h {
        for i in 0..w {
            if valid(i, j) {
                let v = raster.value(i as u32, j as u32);
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    let span = if hi > lo { hi - lo } else { 1.0 };
    // Horizontal distance per cell in the same units as heights only matters for contrast;
    // scale the slope so the preview reads well whatever the units.
    let z_scale = 4.0 * (w.max(h) as f32) / span;
    let (sx, sy, sz) = (-0.5f32, -0.5f32, 0.7071f32); // light from the north-west, 45° up
    let mut rgba = vec![0u8; w * h * 4];
    for j in 0..h {
        for i in 0..w {
            if !valid(i, j) {
                continue;
            }
            let at = |ii: usize, jj: usize| if valid(ii, jj) { raster.value(ii as u32, jj as u32) } else { raster.value(i as u32, j as u32) };
            let dzdx = (at((i + 1).min(w - 1), j) - at(i.saturating_sub(1), j)) / (2.0 * w as f32) * z_scale;
            let dzdy = (at(i, (j + 1).min(h - 1)) - at(i, j.saturating_sub(1))) / (2.0 * h as f32) * z_scale;
            let n = [-dzdx, dzdy, 1.0];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let shade = ((n[0] * sx + n[1] * -sy + n[2] * sz) / len).clamp(0.0, 1.0);
            let c = ramp((raster.value(i as u32, j as u32) - lo) / span);
            let k = (j * w + i) * 4;
            for ch in 0..3 {
                rgba[k + ch] = (c[ch] * (0.35 + 0.65 * shade)).clamp(0.0, 255.0) as u8;
            }
            rgba[k + 3] = 255;
        }
    }
    write_atomically(path, |out| {
        image::write_buffer_with_format(out, &rgba, w as u32, h as u32, image::ExtendedColorType::Rgba8, image::ImageFormat::Png)
            .map_err(|e| e.to_string())
    })
}
