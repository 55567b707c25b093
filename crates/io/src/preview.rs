use crate::{IoError, write_atomically};
use std::path::Path;
use tileraster_core::Raster;

/// Hypsometric colour ramp: (fraction of the height range, RGB).
const RAMP: [(f32, [f32; 3]); 5] =
    [(0.00, [46.0, 110.0, 60.0]), (0.30, [120.0, 165.0, 85.0]), (0.55, [215.0, 200.0, 130.0]), (0.80, [160.0, 115.0, 80.0]), (1.00, [245.0, 245.0, 245.0])];

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
    // Slopes in height units per ground unit, exaggerated so gentle terrain still reads.
    const EXAGGERATION: f32 = 2.0;
    let (dx, dy) = (raster.grid.dx() as f32, raster.grid.dy() as f32);
    // Light from the north-west (up and left in the image), 45° above the horizon.
    let light = [-0.5f32, -0.5, std::f32::consts::FRAC_1_SQRT_2];
    let mut rgba = vec![0u8; w * h * 4];
    for j in 0..h {
        for i in 0..w {
            if !valid(i, j) {
                continue;
            }
            let here = raster.value(i as u32, j as u32);
            let at = |ii: usize, jj: usize| if valid(ii, jj) { raster.value(ii as u32, jj as u32) } else { here };
            let (il, ir) = (i.saturating_sub(1), (i + 1).min(w - 1));
            let (ju, jd) = (j.saturating_sub(1), (j + 1).min(h - 1));
            // Image axes: x to the right, y down (south).
            let dzdx = EXAGGERATION * (at(ir, j) - at(il, j)) / (((ir - il).max(1)) as f32 * dx);
            let dzdy = EXAGGERATION * (at(i, jd) - at(i, ju)) / (((jd - ju).max(1)) as f32 * dy);
            let normal = [-dzdx, -dzdy, 1.0];
            let len = (normal[0] * normal[0] + normal[1] * normal[1] + 1.0).sqrt();
            let shade = ((normal[0] * light[0] + normal[1] * light[1] + normal[2] * light[2]) / len).clamp(0.0, 1.0);
            let c = ramp((here - lo) / span);
            let k = (j * w + i) * 4;
            for ch in 0..3 {
                rgba[k + ch] = (c[ch] * (0.25 + 0.9 * shade)).clamp(0.0, 255.0) as u8;
            }
            rgba[k + 3] = 255;
        }
    }
    write_atomically(path, |out| {
        image::write_buffer_with_format(out, &rgba, w as u32, h as u32, image::ExtendedColorType::Rgba8, image::ImageFormat::Png).map_err(|e| e.to_string())
    })
}

/// Write an RGBA8 image (`width × height` pixels, row 0 at the top, 4 bytes a pixel).
pub fn write_rgba_png(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), IoError> {
    debug_assert_eq!(rgba.len(), width as usize * height as usize * 4);
    write_atomically(path, |out| {
        image::write_buffer_with_format(out, rgba, width, height, image::ExtendedColorType::Rgba8, image::ImageFormat::Png).map_err(|e| e.to_string())
    })
}
