//! The mosaic-part target's check, shared with `tests/fuzz_parsers.rs`: any bytes, read as a
//! GeoTIFF part by `tileraster mosaic`, must give a typed error naming the file, or a part
//! with a size, a finite north-up corner and positive finite cells, which a one-part mosaic
//! places at its own corner.

#![allow(dead_code)]

use std::path::Path;

pub enum Outcome {
    Refused,
    Part,
}

pub fn check(data: &[u8]) -> Result<Outcome, String> {
    let name = "fuzz.tif";
    match tileraster_io::parse_part(data, Path::new(name)) {
        Err(e) => {
            let message = e.to_string();
            if message.starts_with(name) { Ok(Outcome::Refused) } else { Err(format!("error without the file name: {message}")) }
        }
        Ok(part) => {
            if part.width == 0 || part.height == 0 {
                return Err(format!("accepted a {}×{} part", part.width, part.height));
            }
            if !(part.x0.is_finite() && part.y0.is_finite() && part.dx > 0.0 && part.dy > 0.0 && part.dx.is_finite() && part.dy.is_finite()) {
                return Err(format!("accepted corner ({}, {}) and cells {} × {}", part.x0, part.y0, part.dx, part.dy));
            }
            if !matches!(part.data_type, "Float32" | "UInt32") {
                return Err(format!("accepted samples {}", part.data_type));
            }
            let vrt = std::env::temp_dir().join(format!("tileraster-fuzz-part-{}.vrt", std::process::id()));
            let mosaic = tileraster_io::write_mosaic_vrt(&vrt, std::slice::from_ref(&part)).map_err(|e| format!("a one-part mosaic failed: {e}"))?;
            let _ = std::fs::remove_file(&vrt);
            if (mosaic.width, mosaic.height, mosaic.offsets.as_slice(), mosaic.uncovered) != (part.width, part.height, &[(0, 0)][..], 0) {
                return Err(format!("a one-part mosaic is {}×{} with offsets {:?}", mosaic.width, mosaic.height, mosaic.offsets));
            }
            Ok(Outcome::Part)
        }
    }
}
