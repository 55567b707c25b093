//! The DEM product as a library user meets it: a grid from gdal_grid's flags, a scene from a
//! file, and a window streamed to GeoTIFFs in bands, equal bit for bit to one call.

use std::path::{Path, PathBuf};
use tiff::decoder::{Decoder, DecodingResult};
use tileraster::dem::{self, DemError, Destinations, GridSize, GridSpec};
use tileraster::{Backend, Outputs, Params, Window, rasterise_window};
use tileraster_testkit::scenes;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tileraster-dem-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn read_tif(tif: &Path) -> DecodingResult {
    Decoder::new(std::io::BufReader::new(std::fs::File::open(tif).unwrap())).unwrap().read_image().unwrap()
}

#[test]
fn a_window_streamed_in_bands_is_the_single_call_bit_for_bit() {
    let dir = scratch("bands");
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let scene = scenes::terrain(x0, y0, 1000.0, 1000.0, 40, 40, 11);
    tileraster_io::write_obj(&scene, &dir.join("terrain.obj")).unwrap();
    let input = dem::read_scene(&dir.join("terrain.obj"), &Default::default(), &()).unwrap();
    assert!(input.points.is_none(), "a mesh is read as it is");
    let grid = GridSpec { txe: Some([x0 - 50.0, x0 + 1050.0]), tye: Some([y0, y0 + 1000.0]), size: GridSize::Resolution { x: 1.5, y: 1.25 }, tap: false }
        .grid()
        .unwrap();
    assert_eq!((grid.width, grid.height), (733, 800));
    let window = Window { x0: 20, y0: 30, width: 700, height: 700 };
    let params = Params::new(grid).with_nodata(-9999.0);
    // Bands of one GeoTIFF tile row each: three of them.
    let rows = dem::streamed_band_rows(&window, dem::bytes_per_cell(true, Backend::Cpu), 700 * 8 * 300);
    assert_eq!(rows, 256);
    let (heights, owner) = (dir.join("dem.tif"), dir.join("owner.tif"));
    let files = Destinations { heights: &heights, owner: Some(&owner), preview: None, tiff: Default::default() };
    let run = dem::write_dem(&input.scene, &params, window, Backend::Cpu, rows, &files, None, &()).unwrap();
    assert_eq!(run.bands.len(), 3);
    let single = rasterise_window(&scene, &params.with_outputs(Outputs { owner: true, coverage: false, tiles: false }), Some(window), Backend::Cpu).unwrap();
    let DecodingResult::F32(values) = read_tif(&heights) else { panic!("heights are not Float32") };
    let DecodingResult::U32(owners) = read_tif(&owner) else { panic!("owners are not UInt32") };
    assert_eq!(values.len(), single.values.len());
    let differ = values.iter().zip(&single.values).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(differ, 0, "cells of the banded file that differ from the single call");
    assert_eq!(&owners, single.owner.as_ref().unwrap());
    assert!(values.iter().any(|&v| v == -9999.0) && values.iter().any(|&v| v != -9999.0), "the window has covered and uncovered cells");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_dem_input_gets_a_typed_error_and_leaves_no_file() {
    let dir = scratch("bad");
    let e57 = dir.join("scan.e57");
    std::fs::write(&e57, b"not read").unwrap();
    assert!(matches!(dem::read_scene(&e57, &Default::default(), &()), Err(DemError::UnsupportedInput { extension, .. }) if extension == "e57"));
    let collinear = dir.join("line.csv");
    std::fs::write(&collinear, "x,y,z\n0,0,1\n1,1,2\n2,2,3\n").unwrap();
    assert!(matches!(dem::read_scene(&collinear, &Default::default(), &()), Err(DemError::Triangulation { .. })));
    let spec = GridSpec { txe: Some([0.0, 10.0]), tye: Some([0.0, 10.0]), size: GridSize::Cells { width: 0, height: 10 }, tap: false };
    assert!(matches!(spec.grid(), Err(DemError::Raster(_))));
    // A scene the rasteriser refuses: nothing is written.
    let grid = GridSpec { size: GridSize::Cells { width: 10, height: 10 }, ..spec }.grid().unwrap();
    let empty = tileraster::Scene::new(vec![], vec![]);
    let tif = dir.join("never.tif");
    let files = Destinations { heights: &tif, owner: None, preview: None, tiff: Default::default() };
    let result = dem::write_dem(&empty, &Params::new(grid), Window::whole(&grid), Backend::Cpu, 10, &files, None, &());
    assert!(matches!(result, Err(DemError::Raster(_))), "{result:?}");
    assert!(!tif.exists());
    std::fs::remove_dir_all(&dir).ok();
}
