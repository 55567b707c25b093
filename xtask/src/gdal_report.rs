//! `cargo xtask gdal-report [POINTS] [SIZE]`: the users' comparison, end to end. The same
//! random points (a gently sloping surface) as one CSV; `tileraster rasterise` (release build,
//! CPU backend) and `gdal_grid -a linear:radius=0` each read it and write a Float32 GeoTIFF of
//! the same grid, timed as whole processes, the runs interleaved. Then the two rasters are
//! compared cell by cell in f32 ulps. Prints markdown.

use crate::{measure, median};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use tiff::decoder::{Decoder, DecodingResult};
use tileraster_testkit::scenes::Rng;

const NODATA: f32 = -9999.0;

pub(crate) fn read_values(path: &Path) -> Result<Vec<f32>, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut decoder = Decoder::new(std::io::BufReader::new(file)).map_err(|e| format!("{}: {e}", path.display()))?;
    match decoder.read_image().map_err(|e| format!("{}: {e}", path.display()))? {
        DecodingResult::F32(v) => Ok(v),
        _ => Err(format!("{}: not Float32", path.display())),
    }
}

/// Distance in representable f32 values.
fn ulps(a: f32, b: f32) -> u64 {
    let key = |v: f32| {
        let bits = v.to_bits() as i64;
        if bits < 0x8000_0000 { bits } else { 0x8000_0000 - bits }
    };
    (key(a) - key(b)).unsigned_abs()
}

/// `points` random points of a gently sloping surface as `dir/points.csv`, and their extent
/// (xmin, xmax, ymin, ymax).
pub(crate) fn write_points_csv(dir: &Path, points: usize) -> Result<(PathBuf, [f64; 4]), String> {
    let (x0, y0, extent) = (500_000.0, 5_000_000.0, 10_000.0);
    let mut rng = Rng::new(7);
    let mut csv = String::from("x,y,z\n");
    for _ in 0..points {
        let (u, v) = (rng.range(0.0, 1.0), rng.range(0.0, 1.0));
        let z = 300.0 + 50.0 * u + 30.0 * v + 20.0 * (6.0 * u).sin() * (4.0 * v).cos() + rng.range(0.0, 5.0);
        let _ = writeln!(csv, "{:?},{:?},{z:?}", x0 + u * extent, y0 + v * extent);
    }
    let path = dir.join("points.csv");
    std::fs::write(&path, csv).map_err(|e| e.to_string())?;
    Ok((path, [x0, x0 + extent, y0, y0 + extent]))
}

/// The comparison as markdown, and its goal lines (none where it could not run).
pub struct EndToEnd {
    pub markdown: String,
    pub goals: String,
}

impl EndToEnd {
    fn not_run(why: String) -> EndToEnd {
        EndToEnd { goals: format!("- Points → DEM end to end: not measured ({}).\n", why.trim_end().trim_end_matches('.')), markdown: why }
    }
}

/// Grid side of the smaller run whose difference from `size` gives the marginal cost per cell.
const SMALL: u32 = 512;

pub fn run(points: usize, size: u32) -> Result<EndToEnd, String> {
    let Some(version) = tileraster_peers::gdal_grid_version() else {
        return Ok(EndToEnd::not_run("gdal_grid is not installed here, so there is no comparison (Debian: apt install gdal-bin).\n".into()));
    };
    let bin = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/release/tileraster");
    if !bin.exists() {
        return Ok(EndToEnd::not_run(format!("{} is missing (`cargo build --release --bin tileraster` builds it).\n", bin.display())));
    }
    let dir = std::env::temp_dir().join(format!("tileraster-gdal-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let (csv_path, [x0, x1, y0, y1]) = write_points_csv(&dir, points)?;
    let vrt = dir.join("points.vrt");
    std::fs::write(
        &vrt,
        format!(
            "<OGRVRTDataSource><OGRVRTLayer name=\"points\"><SrcDataSource>{}</SrcDataSource><GeometryType>wkbPoint</GeometryType>\
             <GeometryField encoding=\"PointFromColumns\" x=\"x\" y=\"y\" z=\"z\"/></OGRVRTLayer></OGRVRTDataSource>",
            csv_path.display()
        ),
    )
    .map_err(|e| e.to_string())?;
    let (ours, theirs) = (dir.join("tileraster.tif"), dir.join("gdal.tif"));
    let (txe, tye) = ([x0.to_string(), x1.to_string()], [y0.to_string(), y1.to_string()]);
    let commands = |n: u32, ours: &Path, theirs: &Path| {
        let n = n.to_string();
        let mut tileraster = Command::new(&bin);
        tileraster.args(["rasterise", csv_path.to_str().unwrap(), "-o", ours.to_str().unwrap(), "--backend", "cpu", "-q", "--nodata", "-9999"]);
        tileraster.args(["--txe", &txe[0], &txe[1], "--tye", &tye[0], &tye[1], "--outsize", &n, &n]);
        let mut gdal = Command::new("gdal_grid");
        gdal.args(["-q", "-a", "linear:radius=0:nodata=-9999", "-of", "GTiff", "-ot", "Float32", "-l", "points"]);
        gdal.args(["-txe", &txe[0], &txe[1], "-tye", &tye[0], &tye[1], "-outsize", &n, &n, vrt.to_str().unwrap(), theirs.to_str().unwrap()]);
        (tileraster, gdal)
    };
    let (mut tileraster, mut gdal) = commands(size, &ours, &theirs);
    let (small_ours, small_theirs) = (dir.join("small-tileraster.tif"), dir.join("small-gdal.tif"));
    let (mut tileraster_small, mut gdal_small) = commands(SMALL, &small_ours, &small_theirs);
    // The disk's limit for the extra cells: writing their bytes and syncing them.
    let extra_bytes = 4 * (size as u64 * size as u64).saturating_sub(SMALL as u64 * SMALL as u64);
    let write_limit = || -> Result<f64, String> {
        let path = dir.join("write-limit.bin");
        let start = std::time::Instant::now();
        let mut file = std::fs::File::create(&path).map_err(|e| e.to_string())?;
        std::io::Write::write_all(&mut file, &vec![0x5au8; extra_bytes as usize]).map_err(|e| e.to_string())?;
        file.sync_all().map_err(|e| e.to_string())?;
        let seconds = start.elapsed().as_secs_f64();
        std::fs::remove_file(&path).map_err(|e| e.to_string())?;
        Ok(seconds)
    };
    let (mut t_ours, mut t_gdal, mut t_ours_small, mut t_gdal_small, mut t_write) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    measure(&mut tileraster)?; // warm-up: the file cache, the binary
    for _ in 0..3 {
        eprintln!("gdal-report: tileraster, gdal_grid, at {size}² and {SMALL}², and the write limit ...");
        t_ours.push(measure(&mut tileraster)?.seconds);
        t_gdal.push(measure(&mut gdal)?.seconds);
        t_ours_small.push(measure(&mut tileraster_small)?.seconds);
        t_gdal_small.push(measure(&mut gdal_small)?.seconds);
        t_write.push(write_limit()?);
    }
    let (a, b) = (read_values(&ours)?, read_values(&theirs)?);
    if a.len() != b.len() {
        return Err(format!("{} cells against {}", a.len(), b.len()));
    }
    let (mut both, mut within, mut exact, mut max, mut coverage) = (0u64, 0u64, 0u64, 0u64, 0u64);
    for (&x, &y) in a.iter().zip(&b) {
        match (x == NODATA, y == NODATA) {
            (false, false) => {
                both += 1;
                let d = ulps(x, y);
                within += (d <= 1) as u64;
                exact += (d == 0) as u64;
                max = max.max(d);
            }
            (true, true) => {}
            _ => coverage += 1,
        }
    }
    let cog = cog_comparison(&mut tileraster, &ours, &dir);
    let _ = std::fs::remove_dir_all(&dir);
    let cog = cog?;
    let (ours_s, gdal_s) = (median(t_ours), median(t_gdal));
    let (ours_extra, gdal_extra, write_s) = (ours_s - median(t_ours_small), gdal_s - median(t_gdal_small), median(t_write));
    let mut s = format!(
        "{points} random points (CSV) onto {size}² cells, {version}; whole processes, points in and GeoTIFF out, medians of 3 interleaved runs.\n\n\
         | | time | cells covered by both | within 1 ulp of gdal_grid | equal | largest difference | covered by only one |\n| --- | ---: | ---: | ---: | ---: | ---: | ---: |\n"
    );
    let _ = writeln!(
        s,
        "| tileraster (CPU) against gdal_grid -a linear:radius=0 | {:.0} ms against {:.0} ms: {:.1}× faster | {both} | {:.4} % | {:.4} % | {max} ulp | {coverage} |",
        ours_s * 1e3,
        gdal_s * 1e3,
        gdal_s / ours_s,
        100.0 * within as f64 / both.max(1) as f64,
        100.0 * exact as f64 / both.max(1) as f64
    );
    let _ = writeln!(
        s,
        "\nThe extra cells ({size}² − {SMALL}², {:.0} MB of Float32): tileraster {:.0} ms, gdal_grid {:.0} ms (each the difference of the medians at the two sizes); writing and syncing that many bytes to a file in the same folder, the disk's limit: {:.0} ms (median of 3).",
        extra_bytes as f64 / 1e6,
        ours_extra * 1e3,
        gdal_extra * 1e3,
        write_s * 1e3
    );
    s += &cog;
    let met = |ok: bool| if ok { "met" } else { "not met" };
    let mut goals = String::new();
    let _ = writeln!(
        goals,
        "- Points → DEM end to end ({points} CSV points, {size}²): **{:.1}×** faster than gdal_grid ({:.0} ms against {:.0} ms; goal ≥ 5×: {}).",
        gdal_s / ours_s,
        ours_s * 1e3,
        gdal_s * 1e3,
        met(gdal_s / ours_s >= 5.0)
    );
    let _ = writeln!(
        goals,
        "- The command line's cost of the extra cells ({size}² − {SMALL}²): **{:.0} ms**, {:.2}× the disk's write-and-sync limit of {:.0} ms (goal ≤ 1.5×: {}); gdal_grid's: {:.0} ms.",
        ours_extra * 1e3,
        ours_extra / write_s,
        write_s * 1e3,
        met(ours_extra <= 1.5 * write_s),
        gdal_extra * 1e3
    );
    Ok(EndToEnd { markdown: s, goals })
}

/// The options both COGs are written with: deflate, with the predictor GDAL picks for
/// `PREDICTOR=YES` (floating point for Float32).
const COG_OPTIONS: [&str; 4] = ["COMPRESS=DEFLATE", "PREDICTOR=YES", "BIGTIFF=IF_NEEDED", "BLOCKSIZE=256"];

/// A cloud-optimised GeoTIFF of the same raster two ways: `tileraster rasterise --of COG`
/// (points in, COG out; its cost over the plain run is the COG's) and `gdal_translate -of COG`
/// of the plain GeoTIFF (`RESAMPLING=AVERAGE`, as tileraster's overviews), timed as whole
/// processes, interleaved; sizes, GDAL's validator on both, and the full-resolution cells
/// compared bit for bit. Markdown.
fn cog_comparison(plain_run: &mut Command, plain: &Path, dir: &Path) -> Result<String, String> {
    let (ours, theirs) = (dir.join("tileraster-cog.tif"), dir.join("gdal-cog.tif"));
    let mut tileraster = Command::new(plain_run.get_program());
    let args: Vec<String> = plain_run.get_args().map(|a| a.to_string_lossy().into_owned()).collect();
    let output_at = args.iter().position(|a| a == "-o").ok_or("the plain run has no -o")? + 1;
    for (k, arg) in args.iter().enumerate() {
        tileraster.arg(if k == output_at { ours.to_str().unwrap() } else { arg });
    }
    tileraster.args(["--of", "COG"]);
    for option in &COG_OPTIONS[..2] {
        tileraster.args(["--co", option]);
    }
    let mut gdal = Command::new("gdal_translate");
    gdal.args(["-q", "-of", "COG", "-co", "RESAMPLING=AVERAGE", "-co", "NUM_THREADS=ALL_CPUS"]);
    for option in COG_OPTIONS {
        gdal.args(["-co", option]);
    }
    gdal.args([plain.to_str().unwrap(), theirs.to_str().unwrap()]);
    let (mut t_plain, mut t_ours, mut t_gdal) = (Vec::new(), Vec::new(), Vec::new());
    measure(&mut tileraster)?; // warm-up
    for _ in 0..3 {
        eprintln!("gdal-report: the plain GeoTIFF, tileraster's COG, gdal_translate's COG ...");
        t_plain.push(measure(plain_run)?.seconds);
        t_ours.push(measure(&mut tileraster)?.seconds);
        t_gdal.push(measure(&mut gdal)?.seconds);
    }
    let size = |path: &Path| std::fs::metadata(path).map(|m| m.len()).map_err(|e| format!("{}: {e}", path.display()));
    let validate = |path: &Path| -> String {
        match Command::new("/usr/bin/python3").args(["-m", "osgeo_utils.samples.validate_cloud_optimized_geotiff", "--full-check=yes"]).arg(path).output() {
            Ok(out) if out.status.success() && String::from_utf8_lossy(&out.stdout).contains("is a valid cloud optimized GeoTIFF") => "valid".into(),
            Ok(out) => format!("**not valid**: {}", String::from_utf8_lossy(&out.stdout).trim().replace('\n', " ")),
            Err(e) => format!("not checked ({e})"),
        }
    };
    let same = read_values(&ours)?.iter().map(|v| v.to_bits()).eq(read_values(&theirs)?.iter().map(|v| v.to_bits()));
    let (plain_s, ours_s, gdal_s) = (median(t_plain), median(t_ours), median(t_gdal));
    let mut s = String::from(
        "\n**Cloud-optimised GeoTIFF** of the same raster, deflate with the floating-point predictor, averaged overviews, medians of 3 interleaved runs:\n\n\
         | | time | size | GDAL's validator |\n| --- | ---: | ---: | --- |\n",
    );
    let _ = writeln!(s, "| tileraster rasterise, plain GeoTIFF (for reference) | {:.0} ms | {:.1} MB | |", plain_s * 1e3, size(plain)? as f64 / 1e6);
    let _ = writeln!(
        s,
        "| tileraster rasterise --of COG | {:.0} ms ({:.0} ms more than the plain run) | {:.1} MB | {} |",
        ours_s * 1e3,
        (ours_s - plain_s) * 1e3,
        size(&ours)? as f64 / 1e6,
        validate(&ours)
    );
    let _ =
        writeln!(s, "| gdal_translate -of COG of the plain GeoTIFF | {:.0} ms | {:.1} MB | {} |", gdal_s * 1e3, size(&theirs)? as f64 / 1e6, validate(&theirs));
    let _ = writeln!(
        s,
        "\nFull-resolution cells of the two COGs: {}. Their overviews differ: GDAL's COG driver rounds each level's size down and may make one level fewer.",
        if same { "identical, bit for bit" } else { "**different**" }
    );
    Ok(s)
}
