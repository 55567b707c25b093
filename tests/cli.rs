//! The `tileraster` command line, end to end: OBJ in, GeoTIFF out, as gdal_grid would write it.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;
use tileraster::{Backend, Grid, Params, Scene, rasterise};
use tileraster_testkit::scenes;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_tileraster"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tileraster-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `tileraster rasterise MESH -o OUT --backend cpu` plus `args`.
fn rasterise_cli(obj: &Path, tif: &Path, args: &[&str]) -> std::process::Output {
    bin().args(["rasterise", obj.to_str().unwrap(), "-o", tif.to_str().unwrap(), "--backend", "cpu"]).args(args).output().unwrap()
}

/// `scene` as `m.obj` in a scratch folder of its own: the folder and the file.
fn mesh_file(name: &str, scene: &Scene) -> (PathBuf, PathBuf) {
    let dir = scratch(name);
    let obj = dir.join("m.obj");
    write_obj(scene, &obj);
    (dir, obj)
}

fn write_obj(scene: &Scene, path: &Path) {
    let mut text = String::from("# test mesh\n");
    for v in &scene.vertices {
        text += &format!("v {:?} {:?} {:?}\n", v[0], v[1], v[2]);
    }
    for t in &scene.triangles {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn rasterise_writes_a_gdal_grid_compatible_geotiff() {
    let dir = scratch("geotiff");
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let scene = scenes::terrain(x0, y0, 600.0, 400.0, 20, 14, 4);
    let (obj, tif) = (dir.join("mesh.obj"), dir.join("out.tif"));
    write_obj(&scene, &obj);
    let out = rasterise_cli(&obj, &tif, &["--nodata", "-32768", "--txe", "499990", "500590", "--tye", "4999980", "5000410", "--outsize", "120", "86"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    let mut decoder = Decoder::new(std::io::BufReader::new(std::fs::File::open(&tif).unwrap())).unwrap();
    assert_eq!(decoder.dimensions().unwrap(), (120, 86));
    let scale = decoder.get_tag_f64_vec(Tag::ModelPixelScaleTag).unwrap();
    let tie = decoder.get_tag_f64_vec(Tag::ModelTiepointTag).unwrap();
    // gdal_grid's geotransform for these flags: (xmin, (xmax-xmin)/w, 0, ymax, 0, -(ymax-ymin)/h).
    assert_eq!(scale[..2], [600.0 / 120.0, 430.0 / 86.0]);
    assert_eq!(tie, vec![0.0, 0.0, 0.0, 499_990.0, 5_000_410.0, 0.0]);
    assert_eq!(decoder.get_tag_ascii_string(Tag::GdalNodata).unwrap().trim_end_matches('\0'), "-32768");
    let DecodingResult::F32(values) = decoder.read_image().unwrap() else { panic!("not Float32") };

    let grid = Grid::new(499_990.0, 500_590.0, 4_999_980.0, 5_000_410.0, 120, 86);
    let expected = rasterise(&scene, &Params::new(grid).with_nodata(-32768.0), Backend::Cpu).unwrap();
    let same = values.iter().zip(&expected.values).all(|(a, b)| a.to_bits() == b.to_bits());
    assert!(same && values.len() == expected.values.len(), "file differs from the library's raster");
    assert!(values.contains(&-32768.0), "cells outside the mesh are nodata");
    std::fs::remove_dir_all(dir).ok();
}

/// Run `rasterise` on `obj_text` and expect a failure whose message has every piece of
/// `expected`, with no output file left behind.
fn expect_failure(name: &str, obj_text: &str, outsize: [&str; 2], expected: &[&str]) {
    let dir = scratch(name);
    let (obj, tif) = (dir.join(format!("{name}.obj")), dir.join("out.tif"));
    std::fs::write(&obj, obj_text).unwrap();
    let out = rasterise_cli(&obj, &tif, &["--txe", "0", "1", "--tye", "0", "1", "--outsize", outsize[0], outsize[1]]);
    assert!(!out.status.success(), "{name}: expected a failure");
    let err = String::from_utf8_lossy(&out.stderr);
    for piece in expected {
        assert!(err.contains(piece), "{name}: {piece:?} missing from {err}");
    }
    assert!(!tif.exists(), "{name}: no output file after a failure");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_input_is_reported_with_file_and_line_and_leaves_no_output() {
    expect_failure("bad", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", ["4", "4"], &["bad.obj:4:", "out of range"]);
}

#[test]
fn zero_sized_grid_is_a_clear_error() {
    expect_failure("zero", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", ["0", "4"], &["width and height must both be at least 1"]);
}

#[test]
fn mode_flag_selects_the_value_mode_and_rejects_unknown_ones() {
    let dir = scratch("mode");
    let grid = Grid::new(0.0, 600.0, 0.0, 400.0, 90, 60);
    let scene = scenes::terrain(0.0, 0.0, 600.0, 400.0, 3, 2, 6);
    let (obj, tif) = (dir.join("mesh.obj"), dir.join("out.tif"));
    write_obj(&scene, &obj);
    let grid_args = ["--txe", "0", "600", "--tye", "0", "400", "--outsize", "90", "60"];
    let out = rasterise_cli(&obj, &tif, &[&grid_args[..], &["--mode", "barycentric"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut decoder = Decoder::new(std::io::BufReader::new(std::fs::File::open(&tif).unwrap())).unwrap();
    let DecodingResult::F32(values) = decoder.read_image().unwrap() else { panic!("not Float32") };
    let params = Params::new(grid).with_nodata(-9999.0).with_mode(tileraster::Mode::Barycentric);
    let expected = rasterise(&scene, &params, Backend::Cpu).unwrap();
    assert!(values.iter().zip(&expected.values).all(|(a, b)| a.to_bits() == b.to_bits()), "file differs from the barycentric raster");

    let out = rasterise_cli(&obj, &dir.join("never.tif"), &[&grid_args[..], &["--mode", "cubic"]].concat());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("unknown mode 'cubic'") && err.contains("exact, plane-f32, barycentric"), "{err}");
    assert!(!dir.join("never.tif").exists());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn stats_flag_prints_one_json_object_on_stderr() {
    let dir = scratch("stats");
    let scene = scenes::terrain(0.0, 0.0, 600.0, 400.0, 3, 2, 6);
    let (obj, tif) = (dir.join("mesh.obj"), dir.join("out.tif"));
    write_obj(&scene, &obj);
    let grid = ["--txe", "-100", "700", "--tye", "-50", "450", "--outsize", "160", "100"];
    let out = rasterise_cli(&obj, &tif, &[&grid[..], &["--stats"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stderr = String::from_utf8(out.stderr).unwrap();
    let line = stderr.lines().last().unwrap();
    let stats: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("not JSON ({e}): {line}"));
    let expected = rasterise(&scene, &Params::new(Grid::new(-100.0, 700.0, -50.0, 450.0, 160, 100)).with_nodata(-9999.0), Backend::Cpu).unwrap().stats;
    assert_eq!(stats["tiles_total"], expected.tiles_total, "{line}");
    assert_eq!(stats["tiles_empty_skipped"], expected.tiles_empty_skipped, "{line}");
    assert_eq!(stats["tiles_full"], expected.tiles_full, "{line}");
    assert_eq!(stats["triangles_culled"], expected.triangles_culled, "{line}");
    assert_eq!(stats["bytes_uploaded"], expected.bytes_uploaded, "{line}");
    assert_eq!(stats["passes"], serde_json::json!(expected.passes.iter().map(|p| p.name()).collect::<Vec<_>>()), "{line}");
    assert!(expected.tiles_empty_skipped > 0 && expected.tiles_full > 0, "{line}");

    // Turning a skip off changes the statistics, not the raster; an unknown name is refused.
    let tif_off = dir.join("off.tif");
    let out = rasterise_cli(&obj, &tif_off, &[&grid[..], &["--stats", "--no-skip", "empty_tiles"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("\"tiles_empty_skipped\":0,"));
    assert_eq!(std::fs::read(&tif).unwrap(), std::fs::read(&tif_off).unwrap());
    let out = rasterise_cli(&obj, &dir.join("never.tif"), &[&grid[..], &["--no-skip", "everything"]].concat());
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("cull_window, empty_tiles, full_tiles, overlap_free"));
    assert!(!dir.join("never.tif").exists());
    std::fs::remove_dir_all(&dir).ok();
}

fn read_tif_values(tif: &Path) -> Vec<f32> {
    let mut decoder = Decoder::new(std::io::BufReader::new(std::fs::File::open(tif).unwrap())).unwrap();
    let DecodingResult::F32(values) = decoder.read_image().unwrap() else { panic!("not Float32") };
    values
}

/// Points in, GeoTIFF out: the points of a jittered lattice, shuffled into a CSV with a
/// header, repeated points among them, give the raster of the lattice's own Delaunay mesh.
#[test]
fn points_are_triangulated_and_give_the_delaunay_meshs_raster() {
    let dir = scratch("points");
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let mesh = scenes::delaunay_terrain(x0, y0, 600.0, 400.0, 30, 20, 8);
    let mut order: Vec<usize> = (0..mesh.vertices.len()).collect();
    let mut rng = scenes::Rng::new(3);
    for k in (1..order.len()).rev() {
        order.swap(k, (rng.range(0.0, (k + 1) as f64) as usize).min(k));
    }
    let mut text = String::from("id,height,easting,northing\n");
    for (n, &k) in order.iter().enumerate() {
        let v = mesh.vertices[k];
        text += &format!("{n},{:?},{:?},{:?}\n", v[2], v[0], v[1]);
        if n % 50 == 0 {
            // The same position again, later in the file: the first one stays.
            text += &format!("{n}b,{:?},{:?},{:?}\n", v[2] + 1000.0, v[0], v[1]);
        }
    }
    let (csv, tif) = (dir.join("points.csv"), dir.join("out.tif"));
    std::fs::write(&csv, text).unwrap();
    let grid_args = ["--txe", "500000", "500600", "--tye", "5000000", "5000400", "--outsize", "150", "100"];
    let out = rasterise_cli(&csv, &tif, &grid_args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("repeating an earlier point's x, y"), "{stderr}");
    let grid = Grid::new(x0, x0 + 600.0, y0, y0 + 400.0, 150, 100);
    let expected = rasterise(&mesh, &Params::new(grid).with_nodata(-9999.0), Backend::Cpu).unwrap();
    let values = read_tif_values(&tif);
    let differing = values.iter().zip(&expected.values).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!((values.len(), differing), (expected.values.len(), 0), "the TIN of the points rasterises differently from the mesh");

    // Columns by position or name; bad points are reported by file and line, and leave nothing.
    let out = rasterise_cli(&csv, &dir.join("by-position.tif"), &[&grid_args[..], &["--columns", "3,4,height"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(read_tif_values(&dir.join("by-position.tif")), values);
    let bad = dir.join("bad.xyz");
    std::fs::write(&bad, "0 0 1\n10 0 2\n0 ten 3\n").unwrap();
    let out = rasterise_cli(&bad, &dir.join("bad.tif"), &grid_args);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("bad.xyz:3: y (column 2) is 'ten', not a number"), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!dir.join("bad.tif").exists());
    let line = dir.join("line.csv");
    std::fs::write(&line, "0,0,1\n1,1,1\n2,2,1\n").unwrap();
    let out = rasterise_cli(&line, &dir.join("line.tif"), &grid_args);
    assert!(String::from_utf8_lossy(&out.stderr).contains("lie on one line"), "{}", String::from_utf8_lossy(&out.stderr));
    let unknown = dir.join("mesh.e57");
    std::fs::write(&unknown, "ASTM-E57").unwrap();
    let out = rasterise_cli(&unknown, &dir.join("e57.tif"), &grid_args);
    assert!(String::from_utf8_lossy(&out.stderr).contains("unsupported input type 'e57'"), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::remove_dir_all(&dir).ok();
}

/// The same mesh as OBJ, ASCII PLY and binary STL gives the same GeoTIFF (coordinates chosen
/// exact in f32, which binary STL stores).
#[test]
fn obj_ply_and_stl_give_the_same_raster() {
    let dir = scratch("formats");
    let mut scene = scenes::terrain(0.0, 0.0, 600.0, 400.0, 12, 8, 5);
    for v in &mut scene.vertices {
        *v = v.map(|c| c as f32 as f64);
    }
    let (obj, ply, stl) = (dir.join("m.obj"), dir.join("m.ply"), dir.join("m.stl"));
    write_obj(&scene, &obj);
    let mut text = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        scene.vertices.len(),
        scene.triangles.len()
    );
    for v in &scene.vertices {
        text += &format!("{:?} {:?} {:?}\n", v[0], v[1], v[2]);
    }
    for t in &scene.triangles {
        text += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    std::fs::write(&ply, text).unwrap();
    let mut bytes = vec![0u8; 80];
    bytes.extend((scene.triangles.len() as u32).to_le_bytes());
    for t in &scene.triangles {
        bytes.extend([0u8; 12]);
        for &k in t {
            for c in scene.vertices[k as usize] {
                bytes.extend((c as f32).to_le_bytes());
            }
        }
        bytes.extend([0u8; 2]);
    }
    std::fs::write(&stl, bytes).unwrap();
    let grid = ["--txe", "0", "600", "--tye", "0", "400", "--outsize", "120", "80"];
    assert_same_rasters(&[obj, ply, stl], &grid);
    std::fs::remove_dir_all(&dir).ok();
}

/// `--a_srs EPSG:n` writes the CRS as GeoKeys; `--co TILED=YES --co COMPRESS=DEFLATE` writes
/// deflated 256² tiles; the values stay the same; bad options are refused before any work.
#[test]
fn crs_tiles_and_compression_on_request() {
    let scene = scenes::terrain(0.0, 0.0, 600.0, 400.0, 12, 8, 5);
    let (dir, obj) = mesh_file("co", &scene);
    let grid = ["--txe", "0", "600", "--tye", "0", "400", "--outsize", "300", "290"];
    let (plain, tiled) = (dir.join("plain.tif"), dir.join("tiled.tif"));
    assert!(rasterise_cli(&obj, &plain, &grid).status.success());
    let out = rasterise_cli(&obj, &tiled, &[&grid[..], &["--a_srs", "EPSG:32633", "--co", "TILED=YES", "--co", "COMPRESS=DEFLATE"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(read_tif_values(&plain), read_tif_values(&tiled));
    let mut decoder = Decoder::new(std::io::BufReader::new(std::fs::File::open(&tiled).unwrap())).unwrap();
    assert_eq!(decoder.get_tag_u32(Tag::TileWidth).unwrap(), 256);
    assert_eq!(decoder.get_tag_u32(Tag::Compression).unwrap(), 8);
    let keys = decoder.get_tag_u16_vec(Tag::GeoKeyDirectoryTag).unwrap();
    assert!(keys.windows(4).any(|k| k == [3072, 0, 1, 32633]), "no ProjectedCSTypeGeoKey 32633 in {keys:?}");
    for (flag, value, message) in [("--a_srs", "+proj=utm", "only EPSG codes"), ("--co", "COMPRESS=JPEG", "unsupported creation option")] {
        let never = dir.join("never.tif");
        let out = rasterise_cli(&obj, &never, &[&grid[..], &[flag, value]].concat());
        assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains(message), "{}", String::from_utf8_lossy(&out.stderr));
        assert!(!never.exists());
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// gdal_grid's sizing for `-tr` (what GDAL 3.6 does: round the cell count, keep the extent),
/// windows that tile the whole run cell for cell and carry their own georeference, and `-q`.
#[test]
fn cell_size_windows_and_quiet() {
    let scene = scenes::terrain(0.0, 0.0, 10.0, 7.0, 5, 4, 2);
    let (dir, obj) = mesh_file("tr-window", &scene);
    let dims = |tif: &Path| Decoder::new(std::io::BufReader::new(std::fs::File::open(tif).unwrap())).unwrap().dimensions().unwrap();
    for (tr, expected) in [(["3", "2"], (3, 4)), (["4", "4"], (3, 2))] {
        let tif = dir.join("tr.tif");
        let out = rasterise_cli(&obj, &tif, &["--txe", "0", "10", "--tye", "0", "7", "--tr", tr[0], tr[1]]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        assert_eq!(dims(&tif), expected, "-tr {tr:?}");
    }
    let out = rasterise_cli(&obj, &dir.join("x.tif"), &["--txe", "0", "10", "--tye", "0", "7"]);
    assert!(!out.status.success());

    let grid = ["--txe", "0", "10", "--tye", "0", "7", "--outsize", "53", "41"];
    let whole_tif = dir.join("whole.tif");
    let out = rasterise_cli(&obj, &whole_tif, &[&grid[..], &["-q"]].concat());
    assert!(out.status.success() && out.stderr.is_empty(), "-q printed: {}", String::from_utf8_lossy(&out.stderr));
    let whole = read_tif_values(&whole_tif);
    for (x0, y0, w, h) in [(0, 0, 30, 20), (30, 0, 23, 20), (0, 20, 53, 21)] {
        let tif = dir.join(format!("w{x0}-{y0}.tif"));
        let window = [x0.to_string(), y0.to_string(), w.to_string(), h.to_string()];
        let args: Vec<&str> = grid.iter().copied().chain(["--window"]).chain(window.iter().map(String::as_str)).collect();
        let out = rasterise_cli(&obj, &tif, &args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let part = read_tif_values(&tif);
        for j in 0..h {
            for i in 0..w {
                assert_eq!(part[j * w + i].to_bits(), whole[(y0 + j) * 53 + x0 + i].to_bits(), "window at ({x0}, {y0}), pixel ({i}, {j})");
            }
        }
        let mut decoder = Decoder::new(std::io::BufReader::new(std::fs::File::open(&tif).unwrap())).unwrap();
        let tie = decoder.get_tag_f64_vec(Tag::ModelTiepointTag).unwrap();
        // As GDAL georeferences a source window: origin + offset × cell size.
        assert_eq!((tie[3], tie[4]), (x0 as f64 * (10.0 / 53.0), 7.0 - y0 as f64 * (7.0 / 41.0)), "the window's own top-left corner");
    }
    let out = rasterise_cli(&obj, &dir.join("bad.tif"), &[&grid[..], &["--window", "50", "0", "10", "10"]].concat());
    assert!(!out.status.success() && !dir.join("bad.tif").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// The same points as CSV, LAS and LAZ give the same GeoTIFF (coordinates on the LAS files'
/// 0.001 scale, so all three hold the same numbers).
#[test]
fn las_and_laz_points_give_the_csv_raster() {
    let dir = scratch("las");
    let mut rng = scenes::Rng::new(11);
    let points: Vec<[f64; 3]> = (0..2000)
        .map(|_| [rng.range(0.0, 600_000.0).round() / 1000.0, rng.range(0.0, 400_000.0).round() / 1000.0, rng.range(0.0, 50_000.0).round() / 1000.0])
        .collect();
    let csv = dir.join("p.csv");
    std::fs::write(&csv, points.iter().map(|p| format!("{:?} {:?} {:?}\n", p[0], p[1], p[2])).collect::<String>()).unwrap();
    let grid = ["--txe", "0", "600", "--tye", "0", "400", "--outsize", "150", "100"];
    let (las, laz) = (dir.join("p.las"), dir.join("p.laz"));
    for input in [&las, &laz] {
        let mut builder = las::Builder::from((1, 2));
        builder.point_format.is_compressed = input == &laz;
        let mut writer = las::Writer::from_path(input, builder.into_header().unwrap()).unwrap();
        for p in &points {
            writer.write_point(las::Point { x: p[0], y: p[1], z: p[2], ..Default::default() }).unwrap();
        }
        writer.close().unwrap();
    }
    assert_same_rasters(&[csv, las, laz], &grid);
    std::fs::remove_dir_all(&dir).ok();
}

/// Several point inputs are triangulated together as if their points were one file's: the
/// points of one CSV file split into a LAS tile, a LAZ tile and a CSV tile (with duplicates of
/// points in earlier tiles), given as files, as their directory and as a quoted glob pattern,
/// give the single file's raster and TIN; inputs that name nothing, a mesh among them, a file
/// named twice and `--class` on a text file among them are refused before anything is written.
#[test]
fn several_point_inputs_give_the_single_files_raster() {
    let dir = scratch("many");
    let tiles = dir.join("tiles");
    std::fs::create_dir_all(&tiles).unwrap();
    // Coordinates in eighths, which the LAS tiles' scale of 1/8 and the text hold exactly.
    let mut rng = scenes::Rng::new(29);
    let mut points: Vec<[f64; 3]> =
        (0..3000).map(|_| [rng.range(0.0, 4800.0).round() / 8.0, rng.range(0.0, 3200.0).round() / 8.0, rng.range(0.0, 400.0).round() / 8.0]).collect();
    // Repeats across tiles: the first of each is kept, as in one file.
    points.extend_from_within(100..110);
    let text = |points: &[[f64; 3]]| points.iter().map(|p| format!("{:?} {:?} {:?}\n", p[0], p[1], p[2])).collect::<String>();
    let whole = dir.join("all.csv");
    std::fs::write(&whole, text(&points)).unwrap();
    let (a, b, c) = (tiles.join("a.las"), tiles.join("b.laz"), tiles.join("c.csv"));
    for (path, part) in [(&a, &points[..1200]), (&b, &points[1200..2500])] {
        let mut builder = las::Builder::from((1, 2));
        builder.point_format.is_compressed = path == &b;
        let eighth = las::Transform { scale: 0.125, offset: 0.0 };
        builder.transforms = las::Vector { x: eighth, y: eighth, z: eighth };
        let mut writer = las::Writer::from_path(path, builder.into_header().unwrap()).unwrap();
        for p in part {
            writer.write_point(las::Point { x: p[0], y: p[1], z: p[2], ..Default::default() }).unwrap();
        }
        writer.close().unwrap();
    }
    std::fs::write(&c, text(&points[2500..])).unwrap();
    std::fs::write(tiles.join("notes.md"), "not points").unwrap();
    let grid = ["--txe", "0", "600", "--tye", "0", "400", "--outsize", "150", "100"];
    let run = |inputs: &[&str], out: &Path, extra: &[&str]| {
        bin().arg("rasterise").args(inputs).args(["-o", out.to_str().unwrap(), "--backend", "cpu"]).args(grid).args(extra).output().unwrap()
    };
    let (one, one_tin) = (dir.join("one.tif"), dir.join("one.obj"));
    let out = run(&[whole.to_str().unwrap()], &one, &["--tin", one_tin.to_str().unwrap()]);
    let said = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{said}");
    let repeats = said.split(" repeating").next().and_then(|s| s.rsplit('(').next()).expect("repeated points").to_string();
    let single = read_tif_values(&one);
    assert!(single.iter().any(|&v| v != -9999.0));
    let pattern = format!("{}/*.la[sz]", tiles.display());
    let listed = [a.to_str().unwrap(), b.to_str().unwrap(), c.to_str().unwrap()];
    let given: [(&str, Vec<&str>); 3] =
        [("files", listed.to_vec()), ("directory", vec![tiles.to_str().unwrap()]), ("pattern", vec![&pattern, c.to_str().unwrap()])];
    for (how, inputs) in &given {
        let (tif, tin) = (dir.join(format!("{how}.tif")), dir.join(format!("{how}.obj")));
        let out = run(inputs, &tif, &["--tin", tin.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{how}: {stderr}");
        assert!(
            stderr.contains("3010 points from") && stderr.contains("and 2 more files") && stderr.contains(&format!("({repeats} repeating")),
            "{how}: {stderr}"
        );
        assert_same_bits(&read_tif_values(&tif), &single, how);
        assert_eq!(std::fs::read(&tin).unwrap(), std::fs::read(&one_tin).unwrap(), "{how}: the TIN");
    }
    let obj = dir.join("m.obj");
    write_obj(&scenes::terrain(0.0, 0.0, 600.0, 400.0, 3, 3, 1), &obj);
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let missing = format!("{}/*.laz", dir.join("nowhere").display());
    let refused: [(Vec<&str>, &[&str], &str); 5] = [
        (vec![empty.to_str().unwrap()], &[], "no point files"),
        (vec![&missing], &[], "no file matches it"),
        (vec![tiles.to_str().unwrap(), obj.to_str().unwrap()], &[], "a mesh among 4 inputs"),
        (vec![tiles.to_str().unwrap(), a.to_str().unwrap()], &[], "among the inputs twice"),
        (vec![a.to_str().unwrap(), c.to_str().unwrap()], &["--class", "2"], "--class filters LAS/LAZ"),
    ];
    for (inputs, extra, says) in &refused {
        let tif = dir.join("refused.tif");
        let out = run(inputs, &tif, extra);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(says), "{inputs:?}: {stderr}");
        assert!(!tif.exists(), "{inputs:?}: a file was left");
    }
    std::fs::remove_dir_all(&dir).ok();
}

fn read_tif_u32(tif: &Path) -> Vec<u32> {
    let mut decoder = Decoder::new(std::io::BufReader::new(std::fs::File::open(tif).unwrap())).unwrap();
    let DecodingResult::U32(values) = decoder.read_image().unwrap() else { panic!("not UInt32") };
    values
}

/// Every input rasterised with `grid` gives the first one's raster, which covers something.
fn assert_same_rasters(inputs: &[PathBuf], grid: &[&str]) {
    let rasters: Vec<Vec<f32>> = inputs
        .iter()
        .map(|input| {
            let tif = input.with_extension(format!("{}.tif", input.extension().unwrap().to_str().unwrap()));
            let out = rasterise_cli(input, &tif, grid);
            assert!(out.status.success(), "{}: {}", input.display(), String::from_utf8_lossy(&out.stderr));
            read_tif_values(&tif)
        })
        .collect();
    assert!(rasters[0].iter().any(|&v| v != -9999.0));
    for (input, raster) in inputs.iter().zip(&rasters).skip(1) {
        assert_same_bits(raster, &rasters[0], &format!("{} against {}", input.display(), inputs[0].display()));
    }
}

fn assert_same_bits(a: &[f32], b: &[f32], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: cell counts");
    if let Some(k) = (0..a.len()).find(|&k| a[k].to_bits() != b[k].to_bits()) {
        panic!("{what}: cell {k} is {} against {}", a[k], b[k]);
    }
}

/// A grid too large for `--memory` is rasterised in bands and streamed to a tiled file with
/// the single run's cells; the owner raster is the library's.
#[test]
fn bands_streamed_within_a_memory_budget_give_the_single_runs_cells() {
    let scene = scenes::terrain(0.0, 0.0, 600.0, 900.0, 9, 13, 8);
    let (dir, obj) = mesh_file("bands", &scene);
    let grid = ["--txe", "-20", "610", "--tye", "-5", "905", "--outsize", "700", "1100"];
    let (single, banded, owner) = (dir.join("single.tif"), dir.join("banded.tif"), dir.join("owner.tif"));
    let out = rasterise_cli(&obj, &single, &grid);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // 1 MiB holds 187 rows of 700 cells with their owners: bands of one tile row, 256.
    let args = [&grid[..], &["--memory", "1", "--owner", owner.to_str().unwrap(), "--stats"]].concat();
    let out = rasterise_cli(&obj, &banded, &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("rasterising bands of 256 rows, streamed to a tiled GeoTIFF") && stderr.contains("5 bands"), "{stderr}");
    assert_eq!(stderr.lines().filter(|l| l.starts_with('{')).count(), 5, "one statistics object per band: {stderr}");
    let tile = Decoder::new(std::io::BufReader::new(std::fs::File::open(&banded).unwrap())).unwrap().find_tag(Tag::TileWidth).unwrap();
    assert_eq!(tile.map(|v| v.into_u32().unwrap()), Some(256), "streamed output is tiled");
    assert_same_bits(&read_tif_values(&banded), &read_tif_values(&single), "banded against single");

    let params = Params::new(Grid::new(-20.0, 610.0, -5.0, 905.0, 700, 1100)).with_nodata(-9999.0).with_outputs(tileraster::Outputs {
        owner: true,
        coverage: false,
        tiles: false,
    });
    let expected = rasterise(&scene, &params, Backend::Cpu).unwrap();
    let owners = read_tif_u32(&owner);
    assert_eq!(&owners, expected.owner.as_ref().unwrap(), "the owner raster is the library's");
    assert!(owners.contains(&u32::MAX) && owners.iter().all(|&t| t == u32::MAX || (t as usize) < scene.triangles.len()));
    std::fs::remove_dir_all(&dir).ok();
}

/// The cluster recipe, locally: each `--part K/N` as its own process, all at once, mosaicked
/// by `tileraster mosaic` into a VRT whose cells are the single run's. GDAL reads the VRT
/// when it is installed.
#[test]
fn parts_run_as_separate_processes_mosaic_to_the_single_run() {
    let scene = scenes::terrain(500_000.0, 5_000_000.0, 3000.0, 2000.0, 12, 8, 3);
    let (dir, obj) = mesh_file("parts", &scene);
    let grid = ["--txe", "500000", "503000", "--tye", "5000000", "5002000", "--outsize", "333", "500", "--a_srs", "EPSG:32633", "-q"];
    let single = dir.join("single.tif");
    assert!(rasterise_cli(&obj, &single, &grid).status.success());
    const N: u32 = 3;
    let parts: Vec<PathBuf> = (0..N).map(|k| dir.join(format!("part-{k}.tif"))).collect();
    let jobs: Vec<_> = (0..N)
        .map(|k| {
            let part = format!("{k}/{N}");
            bin()
                .args(["rasterise", obj.to_str().unwrap(), "-o", parts[k as usize].to_str().unwrap(), "--backend", "cpu", "--part", &part])
                .args(grid)
                .spawn()
                .unwrap()
        })
        .collect();
    for mut job in jobs {
        assert!(job.wait().unwrap().success());
    }
    let vrt = dir.join("mosaic.vrt");
    // Listed backwards: each part is placed by its own georeferencing.
    let out = bin().args(["mosaic", "-o", vrt.to_str().unwrap()]).args(parts.iter().rev()).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let xml = std::fs::read_to_string(&vrt).unwrap();
    assert!(xml.contains("rasterXSize=\"333\" rasterYSize=\"500\"") && xml.contains("<SRS>EPSG:32633</SRS>"), "{xml}");

    // The mosaic as the VRT says: each part's cells at its DstRect.
    let whole = read_tif_values(&single);
    let mut mosaic = vec![f32::NAN; whole.len()];
    for source in xml.split("<SimpleSource>").skip(1) {
        let name = source.split("\">").nth(1).unwrap().split('<').next().unwrap();
        let attr = |key: &str| -> usize {
            source.split("<DstRect").nth(1).unwrap().split(&format!("{key}=\"")).nth(1).unwrap().split('"').next().unwrap().parse().unwrap()
        };
        let (x, y, w) = (attr("xOff"), attr("yOff"), attr("xSize"));
        for (k, v) in read_tif_values(&dir.join(name)).into_iter().enumerate() {
            mosaic[(y + k / w) * 333 + x + k % w] = v;
        }
    }
    assert_same_bits(&mosaic, &whole, "the VRT's parts against the single run");

    match Command::new("gdal_translate").arg("--version").output() {
        Ok(version) if version.status.success() => {
            let through_gdal = dir.join("mosaic.tif");
            let out = Command::new("gdal_translate").args(["-q", vrt.to_str().unwrap(), through_gdal.to_str().unwrap()]).output().unwrap();
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            assert_same_bits(&read_tif_values(&through_gdal), &whole, "GDAL's reading of the VRT against the single run");
        }
        _ => eprintln!("NOTE: gdal_translate is not installed; the VRT was checked by its own rectangles only"),
    }

    let out = rasterise_cli(&obj, &dir.join("none.tif"), &[&grid[..], &["--part", "3/3"]].concat());
    assert!(String::from_utf8_lossy(&out.stderr).contains("counted from 0, so K must be less than N"));
    let out = rasterise_cli(&obj, &dir.join("none.tif"), &[&grid[..], &["--part", "499/500"]].concat());
    assert!(out.status.success(), "500 parts of one row each");
    let out = rasterise_cli(&obj, &dir.join("none.tif"), &[&grid[..], &["--part", "300/400"]].concat());
    assert!(String::from_utf8_lossy(&out.stderr).contains("give fewer parts"), "{}", String::from_utf8_lossy(&out.stderr));
    let out = bin().args(["mosaic", "-o", dir.join("bad.vrt").to_str().unwrap(), single.to_str().unwrap(), obj.to_str().unwrap()]).output().unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("m.obj: not a readable TIFF"));
    assert!(!dir.join("bad.vrt").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// `--part K/N` of a point file triangulates the points around its band (grown until they
/// prove its triangles; on this tile, whose hull has long edges beside every band, that is
/// all of them), and its bands together are the single run's cells bit for bit (a real
/// airborne LiDAR tile). `tests/seams.rs` checks blocks that need fewer.
#[test]
fn parts_of_a_point_file_triangulate_their_bands_and_give_the_single_run() {
    let dir = scratch("point-parts");
    let laz = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/autzen_trim.laz");
    let grid = ["--tr", "2", "2"];
    let single = dir.join("single.tif");
    let out = rasterise_cli(&laz, &single, &grid);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    const N: u32 = 4;
    let mut bands = Vec::new();
    for k in 0..N {
        let part = dir.join(format!("part-{k}.tif"));
        let out = rasterise_cli(&laz, &part, &[&grid[..], &["--part", &format!("{k}/{N}")]].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        assert!(stderr.contains(&format!("part {k}/{N} triangulated ")), "{stderr}");
        bands.extend(read_tif_values(&part));
    }
    assert_same_bits(&bands, &read_tif_values(&single), "the parts' bands against the single run");
    // What needs the whole TIN's numbering triangulates every point.
    let out = rasterise_cli(&laz, &dir.join("p.tif"), &[&grid[..], &["--part", "1/4", "--owner", dir.join("o.tif").to_str().unwrap()]].concat());
    assert!(out.status.success() && !String::from_utf8_lossy(&out.stderr).contains("around its band"));
    std::fs::remove_dir_all(&dir).ok();
}

/// Parts of several point files read only the files their band needs (after a pass for each
/// file's count, bounds and hull), and still give the single run of all of them; so does a
/// run whose points exceed its memory budget, made in blocks.
#[test]
fn parts_of_many_point_files_read_what_their_bands_need_and_give_the_single_run() {
    let dir = scratch("tile-parts");
    let laz = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/autzen_trim.laz");
    let points = tileraster::dem::read_points(std::slice::from_ref(&laz), &Default::default()).unwrap();
    let bounds = tileraster_tin::Rect::around(&points).unwrap();
    // 3 × 3 tiles of the LiDAR tile, as CSV (coordinates written to round-trip exactly).
    let tiles = dir.join("tiles");
    std::fs::create_dir_all(&tiles).unwrap();
    let mut texts = vec![String::from("x,y,z\n"); 9];
    for p in &points {
        let at = |v: f64, lo: f64, hi: f64| (((v - lo) / (hi - lo) * 3.0) as usize).min(2);
        texts[at(p[0], bounds.x0, bounds.x1) + 3 * at(p[1], bounds.y0, bounds.y1)] += &format!("{:?},{:?},{:?}\n", p[0], p[1], p[2]);
    }
    for (t, text) in texts.iter().enumerate() {
        std::fs::write(tiles.join(format!("tile-{t}.csv")), text).unwrap();
    }
    let grid = ["--tr", "2", "2"];
    let single = dir.join("single.tif");
    let out = rasterise_cli(&tiles, &single, &grid);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    const N: u32 = 6;
    let (mut bands, mut fewer) = (Vec::new(), 0);
    for k in 0..N {
        let part = dir.join(format!("part-{k}.tif"));
        let out = rasterise_cli(&tiles, &part, &[&grid[..], &["--part", &format!("{k}/{N}")]].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        assert!(stderr.contains(" of the 9 files"), "{stderr}");
        fewer += usize::from(!stderr.contains("9 of the 9 files"));
        bands.extend(read_tif_values(&part));
    }
    assert_same_bits(&bands, &read_tif_values(&single), "the parts' bands of 9 files against the single run");
    assert!(fewer > 0, "some part reads fewer files than all");
    // Points whose TIN exceeds the memory budget: the whole grid in blocks, the same cells.
    for (what, input) in [("9 files", tiles.as_path()), ("one file", laz.as_path())] {
        let blocks = dir.join("blocks.tif");
        let out = rasterise_cli(input, &blocks, &[&grid[..], &["--memory", "20"]].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success() && stderr.contains("each band of the grid triangulates the points around it"), "{stderr}");
        assert!(stderr.contains("blocks in bands of 256 rows"), "{stderr}");
        assert_same_bits(&read_tif_values(&blocks), &read_tif_values(&single), &format!("{what} in blocks against the single run"));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A COPC file: `--part K/N` summarises it from its octree and decodes the nodes its band
/// needs, the parts and a run in blocks give the single run's cells, and with `--class` too.
#[test]
fn a_copc_file_in_parts_and_in_blocks_gives_its_single_run() {
    let dir = scratch("copc-parts");
    let copc = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/autzen_trim.copc.laz");
    for class in [None, Some("2")] {
        let grid: Vec<&str> = ["--tr", "2", "2"].into_iter().chain(class.map(|c| ["--class", c]).into_iter().flatten()).collect();
        let single = dir.join("single.tif");
        let out = rasterise_cli(&copc, &single, &grid);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let (mut bands, mut fewer) = (Vec::new(), 0);
        for k in 0..4 {
            let part = dir.join(format!("part-{k}.tif"));
            let out = rasterise_cli(&copc, &part, &[&grid[..], &["--part", &format!("{k}/4")]].concat());
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(out.status.success(), "{stderr}");
            let decoded: usize = stderr.split(", decoding ").nth(1).and_then(|rest| rest.split(' ').next()).and_then(|n| n.parse().ok()).expect(&stderr);
            fewer += usize::from(decoded < 110_000);
            bands.extend(read_tif_values(&part));
        }
        assert!(fewer > 0, "some part decodes fewer points than the file holds");
        assert_same_bits(&bands, &read_tif_values(&single), &format!("the COPC file's parts (class {class:?}) against its single run"));
        let blocks = dir.join("blocks.tif");
        let out = rasterise_cli(&copc, &blocks, &[&grid[..], &["--memory", "20"]].concat());
        assert!(out.status.success() && String::from_utf8_lossy(&out.stderr).contains("blocks in bands"), "{}", String::from_utf8_lossy(&out.stderr));
        assert_same_bits(&read_tif_values(&blocks), &read_tif_values(&single), &format!("the COPC file in blocks (class {class:?})"));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `--tin` writes the triangulation a point file was rasterised through; rasterising that
/// OBJ gives the same cells, and `--owner`'s indices are its faces.
#[test]
fn the_tin_written_is_the_one_rasterised_and_owners_index_its_faces() {
    let dir = scratch("tin");
    let mut csv = String::from("x,y,z\n");
    let mut state = 0x1234_5678_9abc_def1u64;
    for _ in 0..300 {
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        csv += &format!("{:?},{:?},{:?}\n", 100.0 * next(), 80.0 * next(), 10.0 * next());
    }
    let (points, tif, owner, tin) = (dir.join("p.csv"), dir.join("h.tif"), dir.join("o.tif"), dir.join("tin.obj"));
    std::fs::write(&points, csv).unwrap();
    let out = rasterise_cli(
        &points,
        &tif,
        &["--txe", "0", "100", "--tye", "0", "80", "--outsize", "150", "120", "--owner", owner.to_str().unwrap(), "--tin", tin.to_str().unwrap()],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mesh = tileraster_io::read_obj(&tin).unwrap();
    let params = Params::new(Grid::new(0.0, 100.0, 0.0, 80.0, 150, 120)).with_nodata(-9999.0).with_outputs(tileraster::Outputs {
        owner: true,
        coverage: false,
        tiles: false,
    });
    let expected = rasterise(&mesh, &params, Backend::Cpu).unwrap();
    assert_same_bits(&read_tif_values(&tif), &expected.values, "the points' raster against their written TIN's");
    assert_eq!(&read_tif_u32(&owner), expected.owner.as_ref().unwrap(), "owners index the written TIN's faces");
    std::fs::remove_dir_all(&dir).ok();
}

/// `tileraster render --heat-map` writes the frame's heat map, and `--stats` the checksums of
/// the layers the library's frame gives.
#[test]
fn render_writes_the_heat_map_and_checksums() {
    use tileraster::render::{Camera, Eye, Mesh, Projection, RenderParams, render};
    let dir = scratch("render-diagnostics");
    let sphere = tileraster_testkit::meshes::sphere([0.0, 0.0, 0.0], 1.0, 10, 16);
    let scene = Scene::new(sphere.positions.clone(), sphere.triangles.clone());
    let obj = dir.join("sphere.obj");
    write_obj(&scene, &obj);
    let (png, heat) = (dir.join("f.png"), dir.join("heat.png"));
    let out = bin()
        .args(["render", obj.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "70", "50", "--camera", "3,-3,2,0,0,0,0,0,1"])
        .args(["--heat-map", heat.to_str().unwrap(), "--backend", "cpu", "--stats", "-q"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let mesh = Mesh { positions: scene.vertices.clone(), triangles: scene.triangles.clone(), ..Default::default() };
    let camera = Camera::look_at([3.0, -3.0, 2.0], [0.0; 3], [0.0, 0.0, 1.0], Projection::Perspective { fov_deg: 45.0 }, &mesh);
    let params =
        RenderParams { eye: Some(Eye::Point([3.0, -3.0, 2.0])), count_tiles: true, ..RenderParams::new(70, 50, camera.view_projection(70, 50).unwrap()) };
    let frame = render(&mesh, &params, Backend::Cpu).unwrap();
    let (w, h, rgba) = frame.heat_map().unwrap();
    let decoded = image::open(&heat).unwrap().to_rgba8();
    assert_eq!((decoded.dimensions(), decoded.as_raw()), ((w, h), &rgba), "the heat map PNG is the library's");
    let json: serde_json::Value = serde_json::from_str(stderr.trim()).unwrap_or_else(|e| panic!("--stats is not JSON ({e}): {stderr}"));
    let sums = frame.checksums();
    assert_eq!(json["checksums"]["colour"], format!("{:08x}", sums.colour), "{stderr}");
    assert_eq!(json["checksums"]["ids"], format!("{:08x}", sums.ids), "{stderr}");
    assert_eq!(json["checksums"]["fragments"], format!("{:08x}", sums.fragments.unwrap()), "{stderr}");
    assert_eq!(json["raster"]["triangles_hidden"], frame.stats.raster.triangles_hidden, "{stderr}");
}

/// `tileraster render --instances`: the mesh once per transform of the file, the frame the
/// library renders for that world, the culled instances in `--stats`; a bad line is an error
/// that names it.
#[test]
fn render_draws_instances_from_a_file_of_transforms() {
    use tileraster::render::{Camera, Eye, Projection, RenderParams, World, render_world};
    let dir = scratch("render-instances");
    let sphere = tileraster_testkit::meshes::sphere([0.0, 0.0, 0.0], 0.5, 8, 12);
    let scene = Scene::new(sphere.positions.clone(), sphere.triangles.clone());
    let obj = dir.join("ball.obj");
    write_obj(&scene, &obj);
    let transforms: Vec<[[f64; 4]; 4]> = [(0.0, 0.0), (1.5, 0.0), (0.0, 1.5), (40.0, 0.0)]
        .iter()
        .map(|&(x, y)| [[1.0, 0.0, 0.0, x], [0.0, 1.0, 0.0, y], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
        .collect();
    let text: String = transforms.iter().map(|m| m.iter().flatten().map(|v| v.to_string()).collect::<Vec<_>>().join(" ") + "  # a ball\n").collect();
    let file = dir.join("placements.txt");
    std::fs::write(&file, format!("# x y z\n{text}")).unwrap();
    let png = dir.join("balls.png");
    let camera = "0.7,-4,3,0.7,0.7,0,0,0,1";
    let out = bin()
        .args(["render", obj.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "80", "60", "--camera", camera, "--instances", file.to_str().unwrap()])
        .args(["--backend", "cpu", "--stats", "-q"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("\"instances_drawn\":3,\"instances_culled\":1,"), "--stats: {stderr}");
    let mesh = tileraster::render::Mesh { positions: scene.vertices.clone(), triangles: scene.triangles.clone(), ..Default::default() };
    let world = World::instanced(mesh, &transforms);
    let [lo, hi] = world.bounds().unwrap();
    let corners: Vec<[f64; 3]> = (0..8).map(|k: usize| std::array::from_fn(|a| if k >> a & 1 == 0 { lo[a] } else { hi[a] })).collect();
    let proxy = tileraster::render::Mesh { positions: corners, triangles: vec![[0, 1, 2]], ..Default::default() };
    let camera = Camera::look_at([0.7, -4.0, 3.0], [0.7, 0.7, 0.0], [0.0, 0.0, 1.0], Projection::Perspective { fov_deg: 45.0 }, &proxy);
    let params = RenderParams { eye: Some(Eye::Point([0.7, -4.0, 3.0])), ..RenderParams::new(80, 60, camera.view_projection(80, 60).unwrap()) };
    let frame = render_world(&world, &params, Backend::Cpu).unwrap();
    assert_eq!(image::open(&png).unwrap().to_rgba8().as_raw(), &frame.rgba8(), "the PNG is the library's frame");

    std::fs::write(&file, "1 0 0 0  0 1 0 0  0 0 1 0  0 0 0 1\n1 0 0 0 0 1 0 0 0 0 1\n").unwrap();
    let bad = dir.join("bad.png");
    let out =
        bin().args(["render", obj.to_str().unwrap(), "-o", bad.to_str().unwrap(), "--instances", file.to_str().unwrap(), "--backend", "cpu"]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("line 2") && stderr.contains("11 numbers") && !bad.exists(), "{stderr}");
}

/// `tileraster render`: a PNG, depth and ids rasters the library's frame gives (ids counting
/// the OBJ's faces in file order), `--stats` as JSON; bad input is an error that leaves no file.
#[test]
fn render_writes_the_frame_the_library_renders() {
    use tileraster::render::{Mesh, RenderParams, Shading, render};
    let dir = scratch("render");
    let sphere = tileraster_testkit::meshes::sphere([1.0, 2.0, 3.0], 1.5, 10, 16);
    let scene = Scene::new(sphere.positions.clone(), sphere.triangles.clone());
    let obj = dir.join("sphere.obj");
    write_obj(&scene, &obj);
    let (png, depth, ids) = (dir.join("f.png"), dir.join("depth.tif"), dir.join("ids.tif"));
    let camera = "5,-4,6,1,2,3,0,0,1";
    let out = bin()
        .args(["render", obj.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "96", "64", "--camera", camera, "--fov", "40"])
        .args(["--shading", "ids", "--cull", "none", "--depth", depth.to_str().unwrap(), "--ids", ids.to_str().unwrap(), "--backend", "cpu", "--stats", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.trim().starts_with("{\"instances_drawn\":1,") && stderr.contains("\"fragments\":"), "--stats: {stderr}");

    let mesh = Mesh { positions: scene.vertices.clone(), triangles: scene.triangles.clone(), ..Default::default() };
    let camera = tileraster::render::Camera::look_at(
        [5.0, -4.0, 6.0],
        [1.0, 2.0, 3.0],
        [0.0, 0.0, 1.0],
        tileraster::render::Projection::Perspective { fov_deg: 40.0 },
        &mesh,
    );
    let mut params = RenderParams::new(96, 64, camera.view_projection(96, 64).unwrap());
    (params.shading, params.cull, params.eye) = (Shading::Ids, tileraster::render::Cull::None, Some(tileraster::render::Eye::Point([5.0, -4.0, 6.0])));
    let frame = render(&mesh, &params, Backend::Cpu).unwrap();
    let decoded = image::open(&png).unwrap().to_rgba8();
    assert_eq!(decoded.dimensions(), (96, 64));
    assert_eq!(decoded.as_raw(), &frame.rgba8(), "the PNG is the library's frame");
    let written_ids = read_tif_u32(&ids);
    assert_eq!(written_ids, frame.ids);
    assert!(written_ids.contains(&u32::MAX) && written_ids.iter().any(|&id| (id as usize) < scene.triangles.len()));
    let depths = read_tif_values(&depth);
    assert!(depths.iter().zip(&frame.depth).all(|(a, b)| a.to_bits() == b.to_bits()));

    // Bad input: no file written.
    let bad = dir.join("bad.png");
    let out = bin().args(["render", obj.to_str().unwrap(), "-o", bad.to_str().unwrap(), "--size", "0", "10", "--backend", "cpu"]).output().unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("empty"), "{}", String::from_utf8_lossy(&out.stderr));
    let out = bin()
        .args(["render", obj.to_str().unwrap(), "-o", bad.to_str().unwrap(), "--mvp", "1,0,0,0,0,1,0,0,0,0,1,0,0,0,nan,1", "--backend", "cpu"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("row 3, column 2"), "{stderr}");
    assert!(!bad.exists() && !dir.join("bad.png.tileraster-partial").exists());
}

/// Ctrl-C (SIGINT), SIGTERM or SIGHUP mid-band stops the run at once: every partial file is
/// removed, the destinations are left as they were, one line says so, and the process ends by
/// the signal itself (a shell reports 130, 143, 129 and stops a script's loop).
#[test]
fn an_interrupted_run_leaves_nothing_behind() {
    use std::os::unix::process::ExitStatusExt;
    use std::time::{Duration, Instant};
    let scene = scenes::terrain(0.0, 0.0, 1000.0, 1000.0, 60, 60, 5);
    let (dir, obj) = mesh_file("interrupted", &scene);
    let (tif, owner) = (dir.join("dem.tif"), dir.join("owner.tif"));
    std::fs::write(&owner, b"an earlier run's file").unwrap();
    for (signal, name) in [(libc::SIGINT, "SIGINT"), (libc::SIGTERM, "SIGTERM"), (libc::SIGHUP, "SIGHUP")] {
        // 16384² cells in bands of 64 MiB: 1 GiB of heights and as much of owners.
        let mut child = bin()
            .args(["rasterise", obj.to_str().unwrap(), "-o", tif.to_str().unwrap(), "--backend", "cpu", "--memory", "64"])
            .args(["--owner", owner.to_str().unwrap(), "--txe", "0", "1000", "--tye", "0", "1000", "--outsize", "16384", "16384"])
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let partial = dir.join("dem.tif.tileraster-partial");
        let start = Instant::now();
        // Mid-band: some of the heights written, not all.
        while std::fs::metadata(&partial).map_or(true, |m| m.len() < 64 << 20) {
            assert!(child.try_wait().unwrap().is_none(), "the run ended before it could be interrupted");
            assert!(start.elapsed() < Duration::from_secs(120), "no partial file appeared");
            std::thread::sleep(Duration::from_millis(5));
        }
        // SAFETY: a plain kill(2) of our own child.
        assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
        let exited = Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if exited.elapsed() > Duration::from_secs(30) {
                child.kill().ok();
                panic!("{name}: the run did not stop within 30 s");
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let stderr = std::io::read_to_string(child.stderr.take().unwrap()).unwrap();
        assert_eq!((status.code(), status.signal()), (None, Some(signal)), "{name}: {stderr}");
        let last = stderr.lines().last().unwrap_or_default();
        assert!(last.starts_with(&format!("tileraster: interrupted by {name}: stopped, removed ")), "{last}");
        assert!(last.contains("dem.tif.tileraster-partial") && last.contains("owner.tif.tileraster-partial"), "{last}");
        let mut left: Vec<String> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        left.sort();
        assert_eq!(left, ["m.obj", "owner.tif"], "{name}: only the input and the untouched destination remain");
        assert_eq!(std::fs::read(&owner).unwrap(), b"an earlier run's file", "{name}: the destination is untouched");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// One run may not write one file twice, nor two runs one destination at once: the second
/// writer finds the first one's partial file locked, and says so.
#[test]
fn a_destination_is_written_by_one_writer_at_a_time() {
    let (dir, obj) = mesh_file("one-writer", &scenes::terrain(0.0, 0.0, 100.0, 100.0, 4, 4, 1));
    let tif = dir.join("dem.tif");
    let grid = ["--txe", "0", "100", "--tye", "0", "100", "--outsize", "64", "64"];
    let out = rasterise_cli(&obj, &tif, &[&grid[..], &["--owner", tif.to_str().unwrap()]].concat());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("--owner") && stderr.contains("is also"), "{stderr}");
    // A run still writing: its partial file is locked.
    let partial = dir.join("dem.tif.tileraster-partial");
    let held = std::fs::File::create(&partial).unwrap();
    held.lock().unwrap();
    let out = rasterise_cli(&obj, &tif, &grid);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("another run is writing this file"), "{stderr}");
    assert!(partial.exists() && !tif.exists(), "the other run's partial file is left to it");
    drop(held);
    let out = rasterise_cli(&obj, &tif, &grid);
    assert!(out.status.success() && tif.exists() && !partial.exists(), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::remove_dir_all(&dir).ok();
}

/// A partial file orphaned by SIGKILL or a power cut carries tileraster's suffix, and the next
/// run to the same destination replaces it.
#[test]
fn an_orphaned_partial_file_is_replaced_by_the_next_run() {
    let (dir, obj) = mesh_file("orphan", &scenes::terrain(0.0, 0.0, 100.0, 100.0, 4, 4, 1));
    let tif = dir.join("dem.tif");
    let orphan = dir.join("dem.tif.tileraster-partial");
    std::fs::write(&orphan, vec![7u8; 1 << 20]).unwrap();
    let out = rasterise_cli(&obj, &tif, &["--txe", "0", "100", "--tye", "0", "100", "--outsize", "64", "64"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!orphan.exists() && tif.exists());
    assert_eq!(read_tif_values(&tif).len(), 64 * 64);
    std::fs::remove_dir_all(&dir).ok();
}

fn tif_layout(tif: &Path) -> (u32, u32, Vec<f64>, Vec<f64>) {
    let mut d = Decoder::new(std::io::BufReader::new(std::fs::File::open(tif).unwrap())).unwrap();
    let (w, h) = d.dimensions().unwrap();
    (w, h, d.get_tag_f64_vec(Tag::ModelTiepointTag).unwrap(), d.get_tag_f64_vec(Tag::ModelPixelScaleTag).unwrap())
}

/// `tileraster rasterise ground.laz -o dem.tif --tr 1 1`: the extent is the input's (of the
/// points kept), cells exactly 1 × 1 from its west and north edges; `--tap` aligns it;
/// `--class 2` keeps the ground points; `--max-edge` leaves the gap between two patches
/// nodata instead of bridging it.
#[test]
fn the_inputs_extent_classes_and_the_longest_edge() {
    let dir = scratch("extent");
    let mut rng = scenes::Rng::new(21);
    // Ground in two patches, 100 apart; vegetation above and between them.
    let mut points = Vec::new();
    for k in 0..1200 {
        let patch = if k % 2 == 0 { 10.0 } else { 210.0 };
        let (x, y) = (patch + rng.range(0.0, 90_000.0).round() / 1000.0, 5.0 + rng.range(0.0, 80_000.0).round() / 1000.0);
        points.push(([x, y, (x * 0.1 + y * 0.05 * 1000.0).round() / 1000.0], 2u8));
        if k % 3 == 0 {
            points.push(([rng.range(0.0, 320_000.0).round() / 1000.0, rng.range(0.0, 100_000.0).round() / 1000.0, 60.0], 5));
        }
    }
    let las = dir.join("p.laz");
    let mut builder = las::Builder::from((1, 4));
    builder.point_format.is_compressed = true;
    let mut writer = las::Writer::from_path(&las, builder.into_header().unwrap()).unwrap();
    for &(p, class) in &points {
        let classification = las::point::Classification::new(class).unwrap();
        writer.write_point(las::Point { x: p[0], y: p[1], z: p[2], classification, ..Default::default() }).unwrap();
    }
    writer.close().unwrap();
    drop(writer);
    let ground: Vec<[f64; 3]> = points.iter().filter(|p| p.1 == 2).map(|p| p.0).collect();
    let span = |axis: usize| ground.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], p| [lo.min(p[axis]), hi.max(p[axis])]);
    let ([xmin, xmax], [ymin, ymax]) = (span(0), span(1));
    let (width, height) = (((xmax - xmin) + 0.5).floor() as u32, ((ymax - ymin) + 0.5).floor() as u32);

    let tif = dir.join("dem.tif");
    let out = rasterise_cli(&las, &tif, &["--tr", "1", "1", "--class", "2"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(tif_layout(&tif), (width, height, vec![0.0, 0.0, 0.0, xmin, ymax, 0.0], vec![1.0, 1.0, 0.0]));
    let tin = tileraster_tin::triangulate(&ground).unwrap().scene;
    let grid = Grid::new(xmin, xmin + width as f64, ymax - height as f64, ymax, width, height);
    let expected = rasterise(&tin, &Params::new(grid).with_nodata(-9999.0), Backend::Cpu).unwrap();
    assert_same_bits(&read_tif_values(&tif), &expected.values, "the ground points' TIN");

    // Aligned to whole metres, covering the extent.
    let out = rasterise_cli(&las, &tif, &["--tr", "1", "1", "--class", "2", "--tap"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (w, h, tie, _) = tif_layout(&tif);
    assert_eq!((w, h, tie[3], tie[4]), ((xmax.ceil() - xmin.floor()) as u32, (ymax.ceil() - ymin.floor()) as u32, xmin.floor(), ymax.ceil()));

    // The gap between the patches: bridged by long triangles, nodata without them.
    let gap = |values: &[f32], w: u32, tie: &[f64]| {
        let column = (155.0 - tie[3]) as u32;
        (0..h).filter(|&row| values[(row * w + column) as usize] != -9999.0).count()
    };
    assert!(gap(&read_tif_values(&tif), w, &tie) > 50, "without --max-edge the gap is bridged");
    let out = rasterise_cli(&las, &tif, &["--tr", "1", "1", "--class", "2", "--tap", "--max-edge", "20"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && stderr.contains("triangles with a longer edge left out"), "{stderr}");
    assert_eq!(gap(&read_tif_values(&tif), w, &tie), 0, "--max-edge 20 leaves the gap nodata");

    // Bad uses are refused with what to do.
    let refused = |args: &[&str], expected: &str| {
        let out = rasterise_cli(&las, &dir.join("refused.tif"), args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!dir.join("refused.tif").exists());
    };
    refused(&["--tr", "1", "1", "--class", "7"], "no point is of class 7 (the file holds class 2: 1200 points, class 5: 400 points)");
    refused(&["--tr", "1", "1", "--max-edge", "-3"], "--max-edge is -3");
    refused(&["--outsize", "10", "10", "--tap"], "--tr");
    let csv = dir.join("p.csv");
    std::fs::write(&csv, "0 0 1\n10 0 2\n0 10 3\n").unwrap();
    let out = rasterise_cli(&csv, &dir.join("refused.tif"), &["--tr", "1", "1", "--class", "2"]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--class filters LAS/LAZ points by classification; this file has none"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `--of COG`: a cloud-optimised GeoTIFF that GDAL's validator accepts (the owner file too),
/// the same bytes when streamed in bands as in one.
#[test]
fn cloud_optimised_geotiffs_validate_and_do_not_depend_on_bands() {
    let scene = scenes::terrain(0.0, 0.0, 600.0, 900.0, 9, 13, 8);
    let (dir, obj) = mesh_file("cog", &scene);
    let grid = ["--txe", "-20", "610", "--tye", "-5", "905", "--outsize", "700", "1100"];
    let cog = ["--of", "COG", "--co", "COMPRESS=DEFLATE", "--co", "PREDICTOR=YES"];
    let (single, banded, owner) = (dir.join("single.tif"), dir.join("banded.tif"), dir.join("owner.tif"));
    let out = rasterise_cli(&obj, &single, &[&grid[..], &cog[..]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = rasterise_cli(&obj, &banded, &[&grid[..], &cog[..], &["--memory", "1", "--owner", owner.to_str().unwrap()]].concat());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && stderr.contains("5 bands"), "{stderr}");
    assert!(std::fs::read(&single).unwrap() == std::fs::read(&banded).unwrap(), "banded and single COGs differ");
    assert_same_bits(&read_tif_values(&banded), &read_tif_values(&dir.join("single.tif")), "COG values");
    let has_validator = Command::new("/usr/bin/python3").args(["-c", "import osgeo_utils"]).output().is_ok_and(|o| o.status.success());
    if !has_validator && std::env::var_os("TILERASTER_SKIP_GDAL").is_some_and(|v| v == "1") {
        eprintln!("SKIPPED: GDAL's COG validator is not installed and TILERASTER_SKIP_GDAL=1");
    } else {
        assert!(has_validator, "GDAL's Python utilities are not installed: apt-get install python3-gdal, or set TILERASTER_SKIP_GDAL=1");
        for file in [&banded, &owner] {
            let check = Command::new("/usr/bin/python3")
                .args(["-m", "osgeo_utils.samples.validate_cloud_optimized_geotiff", "--full-check=yes"])
                .arg(file)
                .output()
                .unwrap();
            let said = String::from_utf8_lossy(&check.stdout).to_string() + &String::from_utf8_lossy(&check.stderr);
            assert!(check.status.success() && said.contains("is a valid cloud optimized GeoTIFF") && !said.contains("arning"), "{}: {said}", file.display());
        }
    }
    // Predictor 3 is for floating point: refused for the owner file before anything is read.
    let out = rasterise_cli(
        &obj,
        &dir.join("p3.tif"),
        &[&grid[..], &["--of", "COG", "--co", "COMPRESS=DEFLATE", "--co", "PREDICTOR=3", "--owner", dir.join("p3-owner.tif").to_str().unwrap()]].concat(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("p3-owner.tif") && stderr.contains("PREDICTOR=2"), "{stderr}");
    assert!(!dir.join("p3.tif").exists() && !dir.join("p3-owner.tif").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// `--algorithm linear:radius=R:nodata=V`, gdal_grid's spelling: cells outside the TIN take
/// the nearest point's z within R; its nodata is --nodata; other algorithms are refused.
#[test]
fn the_linear_algorithms_radius_fills_cells_outside_the_tin() {
    let dir = scratch("linear");
    let csv = dir.join("p.csv");
    std::fs::write(&csv, "x,y,z\n10,10,1\n30,10,2\n10,30,3\n30,30,4\n").unwrap();
    let grid = ["--txe", "0", "40", "--tye", "0", "40", "--outsize", "40", "40"];
    let tif = dir.join("dem.tif");
    let run = |args: &[&str]| {
        let out = rasterise_cli(&csv, &tif, &[&grid[..], args].concat());
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        read_tif_values(&tif)
    };
    let at = |values: &[f32], x: usize, y: usize| values[(39 - y) * 40 + x];
    let plain = run(&[]);
    assert_eq!(at(&plain, 0, 0), -9999.0);
    let inside = |values: &[f32]| (0..values.len()).filter(|&k| plain[k] != -9999.0).all(|k| values[k] == plain[k]);
    let all = run(&["-a", "linear"]);
    assert_eq!((at(&all, 0, 0), at(&all, 39, 39), at(&all, 39, 0)), (1.0, 4.0, 2.0), "bare linear: any distance");
    assert!(all.iter().all(|&v| v != -9999.0) && inside(&all));
    let near = run(&["--algorithm", "linear:radius=5:nodata=-1"]);
    assert_eq!((at(&near, 0, 0), at(&near, 6, 6), at(&near, 39, 39), at(&near, 34, 34)), (-1.0, 1.0, -1.0, 4.0));
    assert!(inside(&near));
    for (args, expected) in
        [(&["-a", "invdist:power=2"][..], "give linear[:radius=R][:nodata=V]"), (&["-a", "linear:nodata=0", "--nodata", "5"], "differ; give one")]
    {
        let out = rasterise_cli(&csv, &tif, &[&grid[..], args].concat());
        assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains(expected), "{}", String::from_utf8_lossy(&out.stderr));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A glTF file with a square of side 2 about the origin in the plane z = 0 facing +z, and two
/// cameras 5 units up looking down at it: node 1 "Top", orthographic, 8 × 4 units (xmag 4,
/// ymag 2), and node 2 "Lens", perspective with an aspect ratio of 1.5.
fn gltf_with_cameras(dir: &Path) -> PathBuf {
    let positions: [[f32; 3]; 4] = [[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]];
    let indices: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut buffer: Vec<u8> = positions.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    buffer.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    std::fs::write(dir.join("square.bin"), &buffer).unwrap();
    let json = r#"{
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0, 1, 2]}],
  "nodes": [
    {"mesh": 0},
    {"name": "Top", "camera": 0, "translation": [0, 0, 5]},
    {"name": "Lens", "camera": 1, "translation": [0, 0, 5]}
  ],
  "cameras": [
    {"type": "orthographic", "orthographic": {"xmag": 4, "ymag": 2, "znear": 0.1, "zfar": 20}},
    {"name": "lens camera", "type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 1.5, "znear": 0.1}}
  ],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "buffers": [{"uri": "square.bin", "byteLength": 60}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}
  ]
}"#;
    let path = dir.join("square.gltf");
    std::fs::write(&path, json).unwrap();
    path
}

/// `tileraster render` with `args`; the PNG's size and the pixels drawn (alpha not 0).
fn rendered(input: &Path, png: &Path, args: &[&str]) -> Result<((u32, u32), usize), String> {
    let out = bin().args(["render", input.to_str().unwrap(), "-o", png.to_str().unwrap(), "--backend", "cpu", "--quiet"]).args(args).output().unwrap();
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    let image = image::open(png).unwrap().to_rgba8();
    Ok((image.dimensions(), image.pixels().filter(|p| p[3] != 0).count()))
}

/// `--camera-node`: the file's cameras by node index, node name or camera name; the frame as
/// high as the camera's aspect ratio makes it unless `--size` says otherwise, the vertical
/// extent kept; an unknown name lists the cameras there are.
#[test]
fn render_views_through_a_gltf_files_cameras() {
    let dir = scratch("render-camera-node");
    let gltf = gltf_with_cameras(&dir);
    let png = dir.join("frame.png");
    // 1280 px across 8 units: the square is 320 × 320 pixels.
    assert_eq!(rendered(&gltf, &png, &["--camera-node", "Top"]).unwrap(), ((1280, 640), 320 * 320));
    let by_name = std::fs::read(&png).unwrap();
    assert_eq!(rendered(&gltf, &png, &["--camera-node", "1"]).unwrap(), ((1280, 640), 320 * 320));
    assert_eq!(std::fs::read(&png).unwrap(), by_name, "by index and by name: the same frame");
    // A square frame keeps the 4 units of height: 160 px a unit.
    assert_eq!(rendered(&gltf, &png, &["--camera-node", "Top", "--size", "640", "640"]).unwrap(), ((640, 640), 320 * 320));
    // The perspective camera, by its camera's name: 1280 × 853; the square at distance 5 in a
    // vertical field of 0.8 rad spans 2 / (2 · 5 · tan 0.4) of the height.
    let ((w, h), drawn) = rendered(&gltf, &png, &["--camera-node", "lens camera"]).unwrap();
    assert_eq!((w, h), (1280, 853));
    let side = 853.0 * 2.0 / (10.0 * 0.4f64.tan());
    assert!((drawn as f64 - side * side).abs() < 4.0 * side, "{drawn} pixels drawn, about {:.0} expected", side * side);
    let e = rendered(&gltf, &png, &["--camera-node", "Nope"]).unwrap_err();
    assert!(e.contains("Nope") && e.contains("\"Top\"") && e.contains("\"lens camera\""), "{e}");
    let obj = dir.join("square.obj");
    std::fs::write(&obj, "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nf 1 2 3\n").unwrap();
    let e = rendered(&obj, &png, &["--camera-node", "0"]).unwrap_err();
    assert!(e.contains("--camera-node"), "{e}");
}

/// `--ortho`: a width in the mesh's units, or fitted to the mesh; `--up` and the formats'
/// up axes: a box tall along +y stands upright in the default view of an OBJ file (y up),
/// and `--up z` views it otherwise.
#[test]
fn render_projects_orthographically_and_knows_which_way_is_up() {
    let dir = scratch("render-ortho-up");
    let gltf = gltf_with_cameras(&dir);
    let png = dir.join("frame.png");
    // Looking down from +z, y up on the screen, 4 units across 640 px: 320 × 320 pixels.
    let camera = ["--camera", "0,0,5,0,0,0,0,1,0", "--size", "640", "480"];
    assert_eq!(rendered(&gltf, &png, &[&camera[..], &["--ortho", "4"]].concat()).unwrap(), ((640, 480), 320 * 320));
    // Fitted: the square fills 90 % of the height.
    let ((_, _), drawn) = rendered(&gltf, &png, &[&camera[..], &["--ortho"]].concat()).unwrap();
    assert!((drawn as f64 - (0.9f64 * 480.0).powi(2)).abs() < 4.0 * 432.0, "{drawn} pixels");
    for width in ["0", "-3"] {
        let e = rendered(&gltf, &png, &["--ortho", width]).unwrap_err();
        assert!(e.contains("positive"), "{e}");
    }
    // An orthographic matrix as it is, lit from its viewing direction: looking down −z from
    // z = 5 (depth 0.5 at z = 0), 4 units across 640 px.
    let mvp = "0.5,0,0,0,0,-0.5,0,0,0,0,-0.125,0.5,0,0,0,1";
    assert_eq!(rendered(&gltf, &png, &["--mvp", mvp, "--size", "640", "640", "--shading", "phong"]).unwrap(), ((640, 640), 320 * 320));
    let e = rendered(&gltf, &png, &["--ortho", "2", "--fov", "30"]).unwrap_err();
    assert!(e.contains("--fov") && e.contains("--ortho"), "{e}");

    let mut text = String::new();
    for k in 0..8 {
        text += &format!("v {} {} {}\n", if k & 1 == 0 { -0.5 } else { 0.5 }, if k & 2 == 0 { -2.0 } else { 2.0 }, if k & 4 == 0 { -0.5 } else { 0.5 });
    }
    // Faces outward: -x, +x, -y, +y, -z, +z.
    text += "f 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\n";
    let obj = dir.join("tall.obj");
    std::fs::write(&obj, text).unwrap();
    let extent = |args: &[&str]| {
        rendered(&obj, &png, args).unwrap();
        let image = image::open(&png).unwrap().to_rgba8();
        let drawn: Vec<(u32, u32)> = image.enumerate_pixels().filter(|p| p.2[3] != 0).map(|p| (p.0, p.1)).collect();
        let span = |f: fn(&(u32, u32)) -> u32| drawn.iter().map(f).max().unwrap() - drawn.iter().map(f).min().unwrap();
        (span(|p| p.0), span(|p| p.1), std::fs::read(&png).unwrap())
    };
    let (w, h, default) = extent(&[]);
    assert!(h > 2 * w, "an OBJ's y axis is up: the tall box spans {w} × {h} pixels");
    assert_eq!(extent(&["--up", "y"]).2, default, "y is the OBJ default");
    let (w, h, _) = extent(&["--up", "z"]);
    assert!(h < 2 * w, "with z up the box lies along the view: {w} × {h} pixels");
}

/// `tileraster render dem.tif`: a GeoTIFF DEM as terrain, +Z up, its nodata cells left as holes.
/// The frame is the one of the mesh the definition gives (a vertex at every cell centre with a
/// height, every 2 × 2 block of them as two triangles split north-west to south-east), built
/// here from the file's own samples and written as an OBJ: the same PNG, bit for bit, although
/// the DEM's is drawn by the kernels' heightfield program (its flat grid lifted by its heights
/// in the vertex stage) and the OBJ's from its positions.
#[test]
fn render_draws_a_geotiff_dem_as_terrain() {
    let dir = scratch("render-dem");
    let scene = scenes::terrain(500_000.0, 5_000_000.0, 600.0, 400.0, 20, 14, 4);
    let (obj, tif) = (dir.join("tin.obj"), dir.join("dem.tif"));
    write_obj(&scene, &obj);
    // The grid reaches beyond the TIN: nodata at its edges.
    let out = rasterise_cli(&obj, &tif, &["--nodata", "-32768", "--txe", "499990", "500590", "--tye", "4999980", "5000410", "--outsize", "60", "43"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    let heights = read_tif_values(&tif);
    let (w, h, dx, dy) = (60usize, 43usize, 10.0, 10.0);
    let mut text = String::new();
    let mut index = vec![None; w * h];
    let mut vertices = 0;
    for (k, &z) in heights.iter().enumerate() {
        if z != -32768.0 {
            let (i, j) = ((k % w) as f64, (k / w) as f64);
            text += &format!("v {:?} {:?} {:?}\n", 499_990.0 + (i + 0.5) * dx, 5_000_410.0 - (j + 0.5) * dy, z as f64);
            vertices += 1;
            index[k] = Some(vertices);
        }
    }
    let mut faces = 0;
    for j in 0..h - 1 {
        for i in 0..w - 1 {
            let at = |i: usize, j: usize| index[j * w + i];
            if let (Some(nw), Some(ne), Some(sw), Some(se)) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)) {
                text += &format!("f {nw} {sw} {se}\nf {nw} {se} {ne}\n");
                faces += 2;
            }
        }
    }
    assert!(faces > 1000 && faces < 2 * (w - 1) * (h - 1), "{faces} faces: the TIN should cover most of the grid, not all");
    let expected = dir.join("expected.obj");
    std::fs::write(&expected, text).unwrap();

    let args = ["--size", "320", "240", "--shading", "phong", "--stats"];
    let (from_dem, from_obj) = (dir.join("dem.png"), dir.join("obj.png"));
    let run = |input: &Path, png: &Path, extra: &[&str]| {
        let out = bin().args(["render", input.to_str().unwrap(), "-o", png.to_str().unwrap(), "--backend", "cpu"]).args(args).args(extra).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let dem_stats = run(&tif, &from_dem, &[]);
    run(&expected, &from_obj, &["--up", "z"]);
    assert_eq!(std::fs::read(&from_dem).unwrap(), std::fs::read(&from_obj).unwrap(), "the DEM's frame and its mesh's");
    assert!(dem_stats.contains(&format!("{faces} triangles (the DEM's heights lifted by the vertex stage)")), "{dem_stats}");
    // Back faces culled (the default) and the terrain still fills the frame: its faces turn
    // counter-clockwise seen from above.
    assert!(rendered(&tif, &from_dem, &[]).unwrap().1 > 10_000, "the terrain fills the frame");
    let out = rasterise_cli(&tif, &dir.join("again.tif"), &["--tr", "1", "1"]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("a raster already") && e.contains("tileraster render"), "{e}");
}

/// `--time`: an animated glTF file posed by its skin and morph target (`common::skinned_gltf`),
/// seen from +z, 4 units across 640 px (160 px a unit, the squares' edges on pixel edges).
/// At rest and at 0 s, both squares: 320 × 160 pixels. At 1 s the right square is edge-on and
/// the morph has widened the left one to 1.5 units: 240 × 160. Before the first keyframe and
/// after the last the channels hold their ends. Halfway, the left square is 1.25 units wide and
/// the right one, turned by 45°, cos 45° = 0.7071 units (113.1 px): 313 columns. A time for a
/// file without animation, or for an OBJ file, and a time that is not finite are refused.
#[test]
fn render_poses_an_animated_gltf_file_at_a_time() {
    let dir = scratch("render-time");
    let gltf = common::skinned_gltf(&dir);
    let png = dir.join("frame.png");
    let view = ["--camera", "1,0.5,5,1,0.5,0,0,1,0", "--ortho", "4", "--size", "640", "640", "--cull", "none"];
    let at = |time: Option<&str>| {
        let time: Vec<&str> = time.map(|t| vec!["--time", t]).unwrap_or_default();
        rendered(&gltf, &png, &[&view[..], &time].concat()).map(|(_, drawn)| drawn)
    };
    assert_eq!(at(None).unwrap(), 320 * 160);
    assert_eq!(at(Some("0")).unwrap(), 320 * 160);
    assert_eq!(at(Some("-2")).unwrap(), 320 * 160);
    assert_eq!(at(Some("1")).unwrap(), 240 * 160);
    assert_eq!(at(Some("30")).unwrap(), 240 * 160);
    assert_eq!(at(Some("0.5")).unwrap(), 313 * 160);
    for bad in ["inf", "NaN"] {
        let e = at(Some(bad)).unwrap_err();
        assert!(e.contains("finite"), "{e}");
    }
    let still = gltf_with_cameras(&dir);
    let e = rendered(&still, &png, &["--time", "1"]).unwrap_err();
    assert!(e.contains("no animation") && e.contains("square.gltf"), "{e}");
    let obj = dir.join("square.obj");
    std::fs::write(&obj, "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nf 1 2 3\n").unwrap();
    let e = rendered(&obj, &png, &["--time", "1"]).unwrap_err();
    assert!(e.contains("glTF") && e.contains("square.obj"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The README's materials frame: `examples/materials_scene.py` writes the glTF scene, and
/// `tileraster render` draws it with its materials (pbr, blended and masked faces, emission)
/// to the colour the README quotes, the same bits on both backends.
#[test]
fn the_readmes_materials_frame_is_the_same_on_both_backends() {
    let dir = scratch("materials-scene");
    let glb = dir.join("materials.glb");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/materials_scene.py");
    let out = Command::new("python3").arg(&script).arg(&glb).output().expect("python3 runs examples/materials_scene.py");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut checksums = Vec::new();
    for backend in ["cpu", "gpu"] {
        if backend == "gpu" && !common::gpu_or_skip("the_readmes_materials_frame_is_the_same_on_both_backends") {
            continue;
        }
        let png = dir.join(format!("{backend}.png"));
        let out = bin()
            .args(["render", glb.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "960", "720", "--tone-map", "neutral", "--srgb"])
            .args(["--background", "30,34,42,255", "--backend", backend, "--stats", "-q"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{backend}: {stderr}");
        let json: serde_json::Value = serde_json::from_str(stderr.trim()).unwrap_or_else(|e| panic!("--stats is not JSON ({e}): {stderr}"));
        checksums.push(json["checksums"].clone());
    }
    assert_eq!(checksums[0]["colour"], "688ec3ad", "the README's figure");
    assert!(checksums.iter().all(|c| *c == checksums[0]), "{checksums:?}");
    // The frame's surface is for meshes without materials: given for this file, it is refused.
    let out = bin().args(["render", glb.to_str().unwrap(), "-o", dir.join("no.png").to_str().unwrap(), "--metallic", "0.5", "-q"]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("--metallic: the file's materials give each surface its own factors"), "{stderr}");
    assert!(!dir.join("no.png").exists(), "no partial output");
}
