//! Points in NumPy's `.npy` format (the `npyz` crate): a 2-D array in C order of `float64` or
//! `float32`, a row a point, as `numpy.save` writes an array of shape `(n, 3)` (or more
//! columns). Values are taken exactly; errors name the file and the row.

use crate::{Column, IoError, PointColumns};
use std::io::{BufReader, Seek, SeekFrom};
use std::path::Path;

/// Read the points of a `.npy` array: x, y, z from the columns `columns` chooses by position
/// (the first three by default; names need a header, which arrays have not).
pub fn read_npy(path: &Path, columns: &PointColumns) -> Result<Vec<[f64; 3]>, IoError> {
    let fail = |message: String| IoError::Format { path: path.to_owned(), message };
    let io = |source| IoError::Io { path: path.to_owned(), source };
    let mut file = BufReader::new(std::fs::File::open(path).map_err(io)?);
    let len = file.seek(SeekFrom::End(0)).map_err(io)?;
    file.seek(SeekFrom::Start(0)).map_err(io)?;
    let array = npyz::NpyFile::new(file).map_err(|e| fail(format!("not a readable .npy array: {e}")))?;
    let &[rows, width] = array.shape() else {
        return Err(fail(format!("an array of points has 2 dimensions, a row a point; this one has shape {:?}", array.shape())));
    };
    if array.order() != npyz::Order::C {
        return Err(fail("the array is in Fortran order; save numpy.ascontiguousarray(points)".into()));
    }
    let mut at = [0usize; 3];
    for (axis, (slot, choice)) in at.iter_mut().zip([&columns.x, &columns.y, &columns.z]).enumerate() {
        *slot = match choice {
            None => axis,
            Some(Column::Position(p)) => p - 1,
            Some(Column::Name(name)) => {
                return Err(fail(format!("column '{name}' is chosen by name, but an array has no header; choose it by position (1, 2, ...)")));
            }
        };
    }
    let needed = at.iter().max().expect("three columns") + 1;
    if (width as usize) < needed {
        return Err(fail(format!("the array has {width} columns; x, y and z need {needed}")));
    }
    let kind = array.dtype().descr();
    let size: u64 = match kind.trim_matches('\'') {
        "<f8" | ">f8" => 8,
        "<f4" | ">f4" => 4,
        other => return Err(fail(format!("the array's values are of type {other}; save them as float64 (numpy.asarray(points, dtype='f8'))"))),
    };
    // What the shape claims must be in the file before anything is allocated for it.
    if rows.checked_mul(width).and_then(|n| n.checked_mul(size)).is_none_or(|bytes| bytes > len) {
        return Err(fail(format!("its shape ({rows}, {width}) does not fit in its {len} bytes")));
    }
    let values: Vec<f64> = match size {
        8 => array.into_vec::<f64>(),
        _ => array.into_vec::<f32>().map(|v| v.into_iter().map(f64::from).collect()),
    }
    .map_err(|e| fail(format!("not a readable .npy array: {e}")))?;
    let mut points = Vec::with_capacity(rows as usize);
    for (row, values) in values.chunks_exact(width as usize).enumerate() {
        let p = at.map(|k| values[k]);
        if !p.iter().all(|v| v.is_finite()) {
            return Err(fail(format!("row {row}: ({}, {}, {}) is not finite", p[0], p[1], p[2])));
        }
        points.push(p);
    }
    if points.is_empty() {
        return Err(fail("no points: the array has no rows".into()));
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An `.npy` file of `values` as `numpy.save` writes them: `descr`, C order, `shape`.
    fn npy(descr: &str, shape: &str, values: &[u8]) -> Vec<u8> {
        let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
        while (10 + header.len() + 1) % 64 != 0 {
            header.push(' ');
        }
        header.push('\n');
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend((header.len() as u16).to_le_bytes());
        bytes.extend(header.as_bytes());
        bytes.extend(values);
        bytes
    }

    #[test]
    fn arrays_of_points_read_exactly_and_bad_ones_are_refused() {
        let dir = std::env::temp_dir().join(format!("tileraster-npy-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = |name: &str, bytes: Vec<u8>| {
            let path = dir.join(name);
            std::fs::write(&path, bytes).unwrap();
            path
        };
        let rows: [[f64; 4]; 2] = [[500_000.125, 5_000_000.1, 101.3, 7.0], [500_001.0 + 1e-9, 4_999_999.9, -2.5, 8.0]];
        let f8: Vec<u8> = rows.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        let path = file("p.npy", npy("<f8", "(2, 4)", &f8));
        let none = PointColumns::default();
        assert_eq!(read_npy(&path, &none).unwrap(), rows.map(|r| [r[0], r[1], r[2]]));
        let fourth = PointColumns { z: Some(Column::Position(4)), ..Default::default() };
        assert_eq!(read_npy(&path, &fourth).unwrap(), rows.map(|r| [r[0], r[1], r[3]]));
        let f4: Vec<u8> = [1.5f32, 2.25, 3.0].iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(read_npy(&file("f.npy", npy("<f4", "(1, 3)", &f4)), &none).unwrap(), [[1.5, 2.25, 3.0]]);
        let refused = |name: &str, bytes: Vec<u8>, columns: &PointColumns| read_npy(&file(name, bytes), columns).unwrap_err().to_string();
        assert!(refused("flat.npy", npy("<f8", "(8,)", &f8), &none).contains("2 dimensions"));
        assert!(refused("narrow.npy", npy("<f8", "(4, 2)", &f8), &none).contains("x, y and z need 3"));
        assert!(refused("ints.npy", npy("<i8", "(2, 4)", &f8), &none).contains("save them as float64"));
        assert!(refused("long.npy", npy("<f8", "(2000000000, 4)", &f8), &none).contains("does not fit"));
        assert!(refused("garbage.npy", b"not an array".to_vec(), &none).contains("not a readable .npy array"));
        let named = PointColumns { z: Some(Column::Name("h".into())), ..Default::default() };
        assert!(refused("named.npy", npy("<f8", "(2, 4)", &f8), &named).contains("no header"));
        let nan: Vec<u8> = [1.0f64, f64::NAN, 3.0].iter().flat_map(|v| v.to_le_bytes()).collect();
        assert!(refused("nan.npy", npy("<f8", "(1, 3)", &nan), &none).contains("row 0"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
