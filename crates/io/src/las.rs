//! LAS and LAZ point clouds (the `las` crate, with LAZ decompression): every point record's
//! x, y, z with the file's scale and offset applied. Errors name the file and the record.

use crate::IoError;
use std::path::Path;

/// Read the points of a LAS or LAZ file.
pub fn read_las(path: &Path) -> Result<Vec<[f64; 3]>, IoError> {
    let fail = |message: String| IoError::Format { path: path.to_owned(), message };
    let mut reader = las::Reader::from_path(path).map_err(|e| fail(format!("not a readable LAS/LAZ file: {e}")))?;
    let mut points = Vec::with_capacity(reader.header().number_of_points().min(1 << 28) as usize);
    for (record, point) in reader.points().enumerate() {
        let p = point.map_err(|e| fail(format!("point record {record}: {e}")))?;
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            return Err(fail(format!("point record {record}: ({}, {}, {}) is not finite", p.x, p.y, p.z)));
        }
        points.push([p.x, p.y, p.z]);
    }
    if points.is_empty() {
        return Err(fail("the file holds no points".into()));
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn las_and_laz_give_back_the_points() {
        let dir = std::env::temp_dir().join(format!("tileraster-las-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // Values on the default 0.001 grid of LAS's scaled integers.
        let points: Vec<[f64; 3]> = (0..500).map(|k| [500_000.0 + (k % 25) as f64 * 1.5, 5_000_000.0 + (k / 25) as f64 * 2.25, 100.0 + k as f64 * 0.125]).collect();
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
        }
        let garbage = dir.join("g.las");
        std::fs::write(&garbage, b"LASF but not really").unwrap();
        assert!(read_las(&garbage).unwrap_err().to_string().starts_with(&format!("{}: not a readable LAS/LAZ file", garbage.display())));
        std::fs::remove_dir_all(&dir).ok();
    }
}
