//! `gdal_grid` as an external process.

use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Instant;
use tileraster_core::Grid;

const LAYER: &str = "points";

/// The version line of `gdal_grid --version` (e.g. "GDAL 3.6.2, released 2023/01/02"), or
/// `None` when `gdal_grid` is not installed.
pub fn gdal_grid_version() -> Option<String> {
    let out = Command::new("gdal_grid").arg("--version").output().ok()?;
    let version = String::from_utf8_lossy(&out.stdout).trim().to_string();
    (out.status.success() && !version.is_empty()).then_some(version)
}

/// Run `gdal_grid -a linear` (GDAL's own Delaunay triangulation of `points`, linear inside each
/// triangle, nodata outside the hull) on `grid` and read the result back.
///
/// Writes `points` (x, y, z) to a CSV and an OGR VRT in `workdir`, runs
/// `gdal_grid -q -a linear:radius=0:nodata=<nodata> -zfield Z -txe xmin xmax -tye ymin ymax
/// -outsize w h -ot Float32 -of GTiff -l points <vrt> <out.tif>` and reads the GeoTIFF back:
/// row-major, row 0 at `ymax`. Returns the values and the seconds the `gdal_grid` process took
/// (start to exit, file writing included, the CSV and the reading back excluded).
pub fn gdal_grid_linear(points: &[[f64; 3]], grid: &Grid, nodata: f32, workdir: &Path) -> Result<(Vec<f32>, f64), String> {
    gdal_grid_linear_radius(points, grid, 0.0, nodata, workdir)
}

/// [`gdal_grid_linear`] with `-a linear:radius=<radius>:nodata=<nodata>`: outside the hull,
/// the nearest point's z within `radius` (any distance when negative).
pub fn gdal_grid_linear_radius(points: &[[f64; 3]], grid: &Grid, radius: f64, nodata: f32, workdir: &Path) -> Result<(Vec<f32>, f64), String> {
    grid.validate().map_err(|e| e.to_string())?;
    if let Some((i, p)) = points.iter().enumerate().find(|(_, p)| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("point {i} ({p:?}) has a non-finite coordinate"));
    }
    let io = |what: &str, path: &Path, e: std::io::Error| format!("{what} {}: {e}", path.display());
    std::fs::create_dir_all(workdir).map_err(|e| io("creating", workdir, e))?;
    let csv = workdir.join(format!("{LAYER}.csv"));
    let csvt = workdir.join(format!("{LAYER}.csvt"));
    let vrt = workdir.join(format!("{LAYER}.vrt"));
    let tif = workdir.join("gdal_grid.tif");

    // Rust prints f64 in its shortest round-trip form, so GDAL parses back the very same values.
    let mut w = std::io::BufWriter::new(std::fs::File::create(&csv).map_err(|e| io("creating", &csv, e))?);
    let mut write_csv = || -> std::io::Result<()> {
        writeln!(w, "X,Y,Z")?;
        for [x, y, z] in points {
            writeln!(w, "{x},{y},{z}")?;
        }
        w.flush()
    };
    write_csv().map_err(|e| io("writing", &csv, e))?;
    // Without a .csvt the CSV driver reads every column as a string.
    std::fs::write(&csvt, "Real,Real,Real\n").map_err(|e| io("writing", &csvt, e))?;
    let vrt_text = format!(
        r#"<OGRVRTDataSource>
  <OGRVRTLayer name="{LAYER}">
    <SrcDataSource relativeToVRT="1">{LAYER}.csv</SrcDataSource>
    <SrcLayer>{LAYER}</SrcLayer>
    <GeometryType>wkbPoint25D</GeometryType>
    <GeometryField encoding="PointFromColumns" x="X" y="Y" z="Z"/>
  </OGRVRTLayer>
</OGRVRTDataSource>
"#
    );
    std::fs::write(&vrt, vrt_text).map_err(|e| io("writing", &vrt, e))?;
    // A stale output from an earlier run must never be read back as this run's.
    match std::fs::remove_file(&tif) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io("removing", &tif, e)),
        _ => {}
    }

    let mut command = Command::new("gdal_grid");
    command
        .arg("-q")
        .args(["-a", &format!("linear:radius={radius}:nodata={nodata}")])
        .args(["-zfield", "Z"])
        .args(["-txe", &grid.xmin.to_string(), &grid.xmax.to_string()])
        .args(["-tye", &grid.ymin.to_string(), &grid.ymax.to_string()])
        .args(["-outsize", &grid.width.to_string(), &grid.height.to_string()])
        .args(["-ot", "Float32", "-of", "GTiff", "-l", LAYER])
        .arg(&vrt)
        .arg(&tif);
    let start = Instant::now();
    let out = command.output().map_err(|e| format!("gdal_grid could not be run (is GDAL installed?): {e}"))?;
    let seconds = start.elapsed().as_secs_f64();
    if !out.status.success() {
        return Err(format!("gdal_grid failed ({}): {}", out.status, String::from_utf8_lossy(&out.stderr).trim()));
    }
    let values = read_geotiff(&tif, grid)?;
    Ok((values, seconds))
}

/// Read a single-band Float32 GeoTIFF of `grid`'s size, row 0 at `ymax`.
fn read_geotiff(path: &Path, grid: &Grid) -> Result<Vec<f32>, String> {
    use tiff::decoder::{Decoder, DecodingResult};
    use tiff::tags::Tag;
    let err = |e: tiff::TiffError| format!("reading {}: {e}", path.display());
    let file = std::fs::File::open(path).map_err(|e| format!("opening {}: {e}", path.display()))?;
    let mut decoder = Decoder::new(std::io::BufReader::new(file)).map_err(err)?;
    let (width, height) = decoder.dimensions().map_err(err)?;
    if (width, height) != (grid.width, grid.height) {
        return Err(format!("{} is {width}×{height}, not the {}×{} asked for", path.display(), grid.width, grid.height));
    }
    // GDAL writes a south-up raster (positive y pixel size, row 0 at ymin) with a full
    // transformation matrix instead of a pixel scale; flip it so row 0 is at ymax.
    let south_up = match decoder.find_tag(Tag::ModelTransformationTag).map_err(err)? {
        Some(value) => value.into_f64_vec().map_err(err)?.get(5).is_some_and(|&dy| dy > 0.0),
        None => false,
    };
    let mut values = match decoder.read_image().map_err(err)? {
        DecodingResult::F32(values) => values,
        _ => return Err(format!("{} is not a Float32 raster", path.display())),
    };
    if values.len() != grid.pixel_count() as usize {
        return Err(format!("{} holds {} values, not one band of {width}×{height}", path.display(), values.len()));
    }
    if south_up {
        let w = width as usize;
        values = values.chunks_exact(w).rev().flatten().copied().collect();
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5×5 lattice on [0, 4]² carrying the plane z = 10 + 2x − 3y; the grid reaches one unit
    /// beyond the hull on every side. Skipped (with a note) when gdal_grid is not installed.
    #[test]
    fn linear_reproduces_a_plane_inside_the_hull() {
        let Some(version) = gdal_grid_version() else {
            eprintln!("gdal_grid is not installed: skipping");
            return;
        };
        let plane = |x: f64, y: f64| 10.0 + 2.0 * x - 3.0 * y;
        let points: Vec<[f64; 3]> = (0..25).map(|k| ((k % 5) as f64, (k / 5) as f64)).map(|(x, y)| [x, y, plane(x, y)]).collect();
        let grid = Grid::new(-1.0, 5.0, -1.0, 5.0, 24, 24);
        let workdir = std::env::temp_dir().join(format!("tileraster-peers-gdal-{}", std::process::id()));
        for nodata in [-9999.0, f32::NAN] {
            let (values, seconds) = gdal_grid_linear(&points, &grid, nodata, &workdir).expect(&version);
            assert!(seconds > 0.0);
            assert_eq!(values.len(), 24 * 24);
            for j in 0..24 {
                for i in 0..24 {
                    let (x, y) = grid.cell_centre(i, j);
                    let got = values[(j * 24 + i) as usize];
                    if (0.0..=4.0).contains(&x) && (0.0..=4.0).contains(&y) {
                        let want = plane(x, y);
                        assert!((got as f64 - want).abs() <= 1e-4, "cell ({i}, {j}) at ({x}, {y}): {got}, want {want}");
                    } else {
                        assert_eq!(got.to_bits(), nodata.to_bits(), "cell ({i}, {j}) at ({x}, {y}) is outside the hull");
                    }
                }
            }
        }
        let _ = std::fs::remove_dir_all(&workdir);
    }

    #[test]
    fn non_finite_points_are_an_error() {
        let grid = Grid::new(0.0, 1.0, 0.0, 1.0, 2, 2);
        let dir = std::env::temp_dir();
        assert!(gdal_grid_linear(&[[0.0, f64::NAN, 1.0]], &grid, 0.0, &dir).is_err());
    }
}
