use super::FinePath;
use super::depth::{Way, fine_depth_using};
use super::height::fine_raster_using;
use super::plain::fine_raster_plain;
use super::rows::TriangleRows;
use super::wide::wide_vectors;
use crate::SmallSeeds;
use tileraster_core::Raster;
use tileraster_core::{Grid, Mode, Outputs, Params, Skips, prepare};
use tileraster_kernels::abi::{Counter, Coverage, DepthFunc, FrameParams, TriangleSetup};
use tileraster_kernels::math::edge::Side;
use tileraster_kernels::pipeline::StageBuffers;
use tileraster_kernels::programs::depth::DepthProgram;
use tileraster_kernels::programs::height;
use tileraster_kernels::stages::fine::{self, PixelProgram};
use tileraster_kernels::{FULL_TILE_BIT, NO_OWNER};
use tileraster_testkit::scenes;

/// What the stages before fine raster leave for a scene's whole window.
struct BeforeFine {
    prepared: tileraster_core::Prepared,
    plan: tileraster_core::Plan,
    frame: FrameParams,
    setups: Vec<TriangleSetup>,
    offsets: Vec<u32>,
    bins: Vec<u32>,
}

fn before_fine(scene: &tileraster_core::Scene, params: &Params) -> BeforeFine {
    let prepared = prepare(scene, params, None).unwrap();
    let plan = prepared.plan(prepared.window, false).unwrap();
    let frame = plan.frame(&prepared, plan.active.unwrap());
    let StageBuffers { setups, offsets, bins, .. } = crate::stage_buffers(&prepared).unwrap().unwrap();
    BeforeFine { prepared, plan, frame, setups, offsets, bins }
}

/// A pixel program other than the heightfield's, through the same stage: a depth test.
/// The lowest surface owns a pixel (its exact height is the depth, the index breaks ties),
/// hull edges stay uncovered, and the value is the owner's index.
struct LowestSurface;

impl PixelProgram for LowestSurface {
    type Setup = TriangleSetup;
    type Staged = TriangleSetup;
    type Key = u64;
    type Value = u32;
    const NO_KEY: u64 = u64::MAX;
    const HULL_EDGES: bool = false;

    fn staged(setup: &TriangleSetup) -> &TriangleSetup {
        setup
    }

    fn coverage(staged: &TriangleSetup) -> &Coverage {
        &staged.coverage
    }

    fn key(&self, s: &TriangleSetup, i: i32, j: i32) -> u64 {
        depth_key(s, i, j)
    }

    fn value(&self, setup: &TriangleSetup, _i: i32, _j: i32) -> u32 {
        setup.coverage.index
    }

    fn background(&self) -> u32 {
        u32::MAX
    }
}

/// The exact height's `f32` bits mapped to an unsigned order, then the index.
fn depth_key(s: &TriangleSetup, i: i32, j: i32) -> u64 {
    let bits = height::plane_value_bits(&s.plane, &s.coverage.rect, i, j);
    (tileraster_kernels::programs::depth::ordered(bits) as u64) << 32 | s.coverage.index as u64
}

/// The generic stage with a depth-keyed program gives, at every pixel, what a brute-force
/// depth test over all triangles gives: the owner, the value and the coverage count.
#[test]
fn a_depth_keyed_program_resolves_the_lowest_surface() {
    let grid = Grid::new(0.0, 100.0, 0.0, 100.0, 137, 129);
    let scenes = [scenes::triangle_soup(&grid, 700, 30.0, 9), scenes::fan(&grid, 60, 60, 90, 40.0, 3), scenes::terrain(0.0, 0.0, 100.0, 100.0, 12, 9, 5)];
    for (k, scene) in scenes.iter().enumerate() {
        for skips in [Skips::NONE, Skips::default()] {
            let params = Params::new(grid).with_skips(skips).with_outputs(Outputs { owner: true, coverage: true, tiles: true });
            let BeforeFine { prepared, plan, frame, setups, offsets, bins } = before_fine(scene, &params);
            let mut raster = plan.allocate_raster(&prepared, true).unwrap();
            fine_raster_plain(&LowestSurface, false, &frame, &setups, &offsets, &bins, &SmallSeeds::default(), &mut raster);
            let (owners, counts) = (raster.owner.as_ref().unwrap(), raster.coverage.as_ref().unwrap());
            for j in 0..frame.win_h {
                for i in 0..frame.win_w {
                    let (gi, gj) = ((frame.win_x0 + i) as i32, (frame.win_y0 + j) as i32);
                    let inside: Vec<&TriangleSetup> =
                        plan.listed.iter().map(|&slot| &setups[slot as usize]).filter(|s| fine::side(&s.coverage, gi, gj) == Side::Inside).collect();
                    let lowest = inside.iter().min_by_key(|s| depth_key(s, gi, gj)).map_or(NO_OWNER, |s| s.coverage.index);
                    let n = (gj as usize - raster.window.y0 as usize) * raster.window.width as usize + (gi as usize - raster.window.x0 as usize);
                    let at = format!("scene {k}, {skips:?}, pixel ({gi}, {gj})");
                    assert_eq!(owners[n], lowest, "owner at {at}");
                    assert_eq!(raster.values[n].to_bits(), lowest, "value at {at}");
                    assert_eq!(counts[n], inside.len() as u32, "count at {at}");
                }
            }
        }
    }
}

/// The 16-lane row masks of `TriangleRows` say of every pixel of a triangle's rectangle in
/// a tile what the stages' `side` says (inside, on an excluded edge, outside), on scenes
/// with overlaps, slivers and shared edges (checked natively, without an adapter too).
#[test]
fn row_masks_are_the_stages_side_of_every_pixel() {
    let grid = Grid::new(0.0, 100.0, 0.0, 100.0, 137, 129);
    let scenes = [scenes::triangle_soup(&grid, 700, 30.0, 9), scenes::fan(&grid, 60, 60, 90, 40.0, 3), scenes::sliver_wedge(&grid, 80, 0.02, 4)];
    let mut seen = [0usize; 3];
    for (k, scene) in scenes.iter().enumerate() {
        let BeforeFine { frame, setups, offsets, bins, .. } = before_fine(scene, &Params::new(grid).with_skips(Skips::NONE));
        for ty in 0..frame.tiles_y {
            for tx in 0..frame.tiles_x {
                let (start, len) = fine::bin_range(&offsets, ty * frame.tiles_x + tx);
                let tile = fine::tile_rect(tx, ty, &frame);
                for &entry in &bins[start as usize..][..len as usize] {
                    let Some(mut rows) = TriangleRows::new(&setups[(entry & !FULL_TILE_BIT) as usize], &tile) else { continue };
                    for j in rows.j0..=rows.j1 {
                        let (inside, on_edge) = rows.masks();
                        for n in 0..rows.lanes.count_ones() {
                            let i = rows.i0 + n as i32;
                            let side = fine::side(&rows.setup.coverage, i, j);
                            let lanes = (inside >> n & 1 == 1, on_edge >> n & 1 == 1);
                            let expected = (side == Side::Inside, side == Side::OnExcludedEdge);
                            assert_eq!(lanes, expected, "scene {k}, triangle {}, pixel ({i}, {j})", rows.setup.coverage.index);
                            seen[side as usize] += 1;
                        }
                        assert_eq!((inside | on_edge) & !rows.lanes, 0, "lanes past the rectangle");
                        rows.next_row();
                    }
                }
            }
        }
    }
    assert!(seen.iter().all(|&n| n > 0), "every side seen: {seen:?}");
}

/// The depth test in rows of lanes (built for the CPU's baseline, and for AVX-512 where the
/// CPU has it) gives the same bits as centre by centre and as the plain twin: every depth function, with and without depth writes,
/// on a soup of crossing triangles drawn twice (exact depth ties), on full-frame layers
/// drawn back to front and front to back, and on full-frame layers whose depths cross
/// (slopes in both directions, so that tiles' early depth rejection decides on bounds that
/// vary across the tile). Both specialised paths reject hidden triangles early; the plain
/// twin does not.
#[test]
fn depth_test_in_lanes_changes_no_bit() {
    use tileraster_core::render::{Cull, Eye, IDENTITY, RenderParams, prepare_render};
    use tileraster_testkit::meshes;
    let mut ways = vec![Way::Centres, Way::Lanes];
    if wide_vectors() {
        ways.push(Way::WideLanes);
    } else {
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "depth_test_in_lanes_changes_no_bit: this CPU lacks AVX-512 F/DQ/VL; the lanes run in the baseline build only");
    }
    let mut soup = meshes::soup(300, [-1.2, -1.2, 0.1], [1.2, 1.2, 0.9], 0.5, 9);
    let n = soup.triangles.len();
    soup.triangles.extend_from_within(..n);
    let back_to_front = meshes::fill_layers(5);
    let mut front_to_back = back_to_front.clone();
    front_to_back.triangles.reverse();
    let mut crossing = tileraster_core::render::Mesh::default();
    for (k, (left, right)) in [(0.2, 0.8), (0.8, 0.2), (0.5, 0.5), (0.1, 0.6), (0.45, 0.55)].into_iter().enumerate() {
        let v = 4 * k as u32;
        crossing.positions.extend([[-1.0, -1.0, left], [1.0, -1.0, right], [1.0, 1.0, right], [-1.0, 1.0, left]]);
        crossing.triangles.extend([[v, v + 1, v + 2], [v, v + 2, v + 3]]);
    }
    let (mut hidden_somewhere, mut small_somewhere) = (false, false);
    for mesh in [soup, back_to_front, front_to_back, crossing] {
        for func in DepthFunc::ALL {
            for write in [true, false] {
                // The `Greater` functions pass against a clear value of 0.
                let clear_depth = if matches!(func, DepthFunc::Greater | DepthFunc::GreaterEqual) { 0.0 } else { 1.0 };
                let mut reference: Option<Raster> = None;
                let variants = [(true, false, true), (true, true, true), (false, true, true), (false, false, true), (true, true, false), (false, true, false)];
                for (count_fragments, hidden_triangles, small_triangles) in variants {
                    let skips = tileraster_core::Skips { hidden_triangles, small_triangles, ..tileraster_core::Skips::ALL };
                    let params = RenderParams {
                        cull: Cull::None,
                        depth_func: func,
                        depth_write: write,
                        clear_depth,
                        eye: Some(Eye::Point([0.0, 0.0, -1.0])),
                        count_fragments,
                        skips,
                        ..RenderParams::new(203, 157, IDENTITY)
                    };
                    let (prepared, _) = prepare_render(&mesh, &params, &mut crate::GeometryTwins::default()).unwrap();
                    let plan = prepared.plan(prepared.window, false).unwrap();
                    let frame = plan.frame(&prepared, plan.active.unwrap());
                    let StageBuffers { setups, offsets, bins, .. } = crate::stage_buffers(&prepared).unwrap().unwrap();
                    let program = DepthProgram::of(&frame);
                    // The small triangles first (`fine_small`), where the plan lists them apart.
                    let seeds = crate::fine_small(&frame, &setups, &plan.small);
                    // The fast paths' way: the small triangles binned apart.
                    let crate::SmallTriangles::Binned(small_bins) = crate::fine_small_for(true, &frame, &setups, &plan.small) else {
                        panic!("binned apart, as asked")
                    };
                    assert!(small_triangles || plan.small.is_empty(), "small triangles listed apart with the skip off");
                    small_somewhere |= !plan.small.is_empty();
                    let run = |way: Option<Way>| {
                        let mut raster = plan.allocate_raster(&prepared, true).unwrap();
                        let counters = match way {
                            Some(way) => fine_depth_using(way, &program, &frame, &setups, &offsets, &bins, &small_bins, &mut raster),
                            None => {
                                let counters = fine_raster_plain(&program, false, &frame, &setups, &offsets, &bins, &seeds, &mut raster);
                                // The tiles it leaves to the shade stage, as the shade twin
                                // resolves them first.
                                crate::stages::shade::resolve_left_tiles(&frame, &setups, &offsets, &seeds, &mut raster);
                                counters
                            }
                        };
                        (raster, counters.map(|c| c.into_inner()))
                    };
                    let what = format!(
                        "{func:?}, write {write}, fragments counted {count_fragments}, hidden triangles rejected {hidden_triangles}, small triangles apart {small_triangles}"
                    );
                    let (plain, plain_counts) = run(None);
                    // The walk, with the keys binning writes for it (`bin::entry_keys`).
                    let mut walked = plan.allocate_raster(&prepared, true).unwrap();
                    let walked_counts = fine_raster_plain(&program, true, &frame, &setups, &offsets, &bins, &seeds, &mut walked).map(|c| c.into_inner());
                    crate::stages::shade::resolve_left_tiles(&frame, &setups, &offsets, &seeds, &mut walked);
                    assert_eq!(walked.compare_bits(&plain, 4), (0, vec![]), "{what}: the walk against the batches");
                    assert_eq!(walked_counts, plain_counts, "{what}: the walk's statistics");
                    let mut lanes = None;
                    for &way in &ways {
                        let (raster, counts) = run(Some(way));
                        assert_eq!(raster.compare_bits(&plain, 4), (0, vec![]), "{what}: {way:?} against the plain twin");
                        assert_eq!(counts, plain_counts, "{what}: {way:?}'s statistics");
                        lanes = Some(raster);
                    }
                    let lanes = lanes.unwrap();
                    let hidden = plain_counts[Counter::TrianglesHidden as usize];
                    assert!(hidden_triangles || hidden == 0, "{what}: {hidden} hidden with the rejection off");
                    hidden_somewhere |= hidden > 0;
                    if count_fragments {
                        assert!(lanes.coverage.as_ref().unwrap().iter().any(|&c| c > 1), "{what}: fragments overlap where they pass");
                    }
                    // The rejection and the fragment count change no bit of the other layers.
                    let mut bits = lanes;
                    bits.coverage = None;
                    match &reference {
                        None => reference = Some(bits),
                        Some(r) => assert_eq!(bits.compare_bits(r, 4), (0, vec![]), "{what}: against the first variant"),
                    }
                }
            }
        }
    }
    assert!(hidden_somewhere, "the depth bounds hid no triangle in any scene");
    assert!(small_somewhere, "no scene has small triangles");
}

/// A key's depth read back is the depth it was built from, for every sign and size.
#[test]
fn value_of_key_undoes_the_key() {
    use tileraster_kernels::programs::depth::ordered;
    for depth in [-f32::INFINITY, -3.5, -f32::MIN_POSITIVE / 2.0, -0.0, 0.0, 1e-40, 0.25, 1.0, f32::MAX] {
        let bits = depth.to_bits();
        for func in [DepthFunc::Less, DepthFunc::LessEqual, DepthFunc::Greater, DepthFunc::GreaterEqual] {
            let program = DepthProgram { func, write: true, clear: 0.5, small_edges: false };
            let above = if matches!(func, DepthFunc::Greater | DepthFunc::GreaterEqual) { !ordered(bits) } else { ordered(bits) };
            assert_eq!(program.value_of_key((above as u64) << 32 | 7), Some(bits), "{depth} under {func:?}");
        }
    }
    assert_eq!(DepthProgram { func: DepthFunc::Always, write: true, clear: 0.5, small_edges: false }.value_of_key(0), None);
    assert_eq!(DepthProgram { func: DepthFunc::Less, write: false, clear: 0.5, small_edges: false }.value_of_key(3), Some(0.5f32.to_bits()));
}

/// The wide-vector build of fine raster gives the same bits as the plain one.
#[test]
fn wide_vectors_change_no_bit() {
    if !wide_vectors() {
        // Say so where the harness cannot swallow it: the comparison needs the features.
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "SKIPPED wide_vectors_change_no_bit: this CPU lacks AVX-512 F/DQ/VL");
        return;
    }
    let scenes = [
        (scenes::terrain(0.0, 0.0, 1000.0, 800.0, 30, 20, 3), Grid::new(0.0, 1000.0, 0.0, 800.0, 331, 277)),
        (scenes::sloping_plane(), Grid::new(0.0, 1.0, 0.0, 1.0, 331, 277)),
    ];
    for (scene, grid) in &scenes {
        let grid = *grid;
        for mode in Mode::ALL {
            let params = Params::new(grid).with_mode(mode).with_outputs(Outputs { owner: true, coverage: true, tiles: true });
            let BeforeFine { prepared, plan, frame, setups, offsets, bins } = before_fine(scene, &params);
            let run = |wide| {
                let mut raster = plan.allocate_raster(&prepared, true).unwrap();
                fine_raster_using(FinePath::Specialised, wide, &frame, &setups, &offsets, &bins, &mut raster);
                raster
            };
            let (plain, wide) = (run(false), run(true));
            assert_eq!(plain.compare_bits(&wide, 4).0, 0, "{mode:?}: the wide build differs");
        }
    }
}

/// The walk reads setups as words (`SetupPart`): every field of every record, as the typed
/// buffer holds it (the coverage's slot from the bin entry), on a real scene's setups.
#[test]
fn setup_records_read_as_words_are_the_typed_records() {
    use tileraster_kernels::abi::{SetupPart, setup_rect};
    use tileraster_kernels::memory::Lanes;
    let scene = scenes::delaunay_terrain(0.0, 0.0, 100.0, 100.0, 40, 40, 7);
    let before = before_fine(&scene, &Params::new(Grid::new(0.0, 100.0, 0.0, 100.0, 137, 129)));
    assert!(before.setups.len() > 1000);
    let words: &[u64] = bytemuck::cast_slice(&before.setups);
    for (slot, setup) in before.setups.iter().enumerate() {
        let whole = TriangleSetup::read_setup(&Lanes::new(), words, slot as u32);
        assert_eq!(bytemuck::bytes_of(&whole), bytemuck::bytes_of(setup), "setup slot {slot}");
        assert_eq!(Coverage::read_setup(&Lanes::new(), words, slot as u32), setup.coverage, "coverage of slot {slot}");
        assert_eq!(setup_rect(words, slot as u32), setup.coverage.rect, "rectangle of slot {slot}");
    }
}
