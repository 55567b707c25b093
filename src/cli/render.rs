//! `tileraster render`: a mesh to a PNG, with optional depth and triangle-id rasters.

use super::progress::{note, set_quiet};
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;
use tileraster::dem::InputKind;
use tileraster::render::{
    Address, Camera, Cull, Filter, IDENTITY, Interpolation, LineRule, MAX_RENDER_DIM, Mesh, Projection, RenderParams, Shading, Up, VertexStage, Wireframe,
    World, format_up, is_geotiff, posed_positions, read_dem_grid, read_mesh_at, read_posable_at, read_world_at, render_world,
};
use tileraster::{Grid, Window};
use tileraster_io::{GeoTiffOptions, GeoTiffWriter, Sample};

#[derive(Args)]
pub struct RenderArgs {
    /// The mesh: `.gltf` or `.glb` (node transforms applied, skins and morph targets posed;
    /// normals, vertex colours and the base colour used), `.obj` (normals, materials' diffuse colours), `.ply` (vertex normals
    /// and colours), `.stl`, or points (`.las`, `.laz`, `.csv`, `.xyz`, `.txt`,
    /// `.pts`) rendered as their Delaunay TIN, or a GeoTIFF DEM (`.tif`: a vertex at every cell
    /// centre with a height, nodata cells left as holes), +Z up.
    input: PathBuf,
    /// The PNG to write (RGBA).
    #[arg(short, long)]
    output: PathBuf,
    /// Frame width and height in pixels (default 1280 × 720; with --camera-node, 1280 wide and
    /// as high as the camera's aspect ratio makes it, 16:9 where it names none).
    #[arg(long, num_args = 2, value_names = ["WIDTH", "HEIGHT"])]
    size: Option<Vec<u32>>,
    /// A look-at camera: eye, target and up vector, in the mesh's coordinates.
    #[arg(long, value_name = "EX,EY,EZ,TX,TY,TZ,UX,UY,UZ", value_parser = numbers::<9>, allow_hyphen_values = true, conflicts_with_all = ["mvp", "camera_node"])]
    camera: Option<[f64; 9]>,
    /// Vertical field of view of --camera (and of the default camera), degrees.
    #[arg(long, default_value_t = 45.0, conflicts_with_all = ["ortho", "camera_node", "mvp"])]
    fov: f64,
    /// Project orthographically (parallel, the viewer at infinity: lighting takes the viewing
    /// direction) instead of in perspective, seeing WIDTH in the mesh's units across the frame;
    /// without WIDTH, as wide as frames the whole mesh. With --camera or the default camera.
    #[arg(long, value_name = "WIDTH", num_args = 0..=1, value_parser = ortho_width, allow_negative_numbers = true, conflicts_with_all = ["mvp", "camera_node"])]
    ortho: Option<Option<f64>>,
    /// Which axis of the mesh points up for the default camera, which looks at the model's
    /// front (from +Z with +Y up, from −Y with +Z up), a little from the right and above.
    /// Default: the format's convention, y for glTF, OBJ, PLY and STL, z for points.
    #[arg(long, value_enum, conflicts_with_all = ["camera", "camera_node", "mvp"])]
    up: Option<UpArg>,
    /// View through a glTF file's camera: the node's index, or its name (or its camera's).
    #[arg(long, value_name = "NAME|INDEX", conflicts_with = "mvp")]
    camera_node: Option<String>,
    /// Pose an animated glTF file this many seconds into its first animation: its nodes
    /// (cameras included), skins and morph weights, each channel held at its first or last
    /// keyframe outside their span. Without it, the file's rest pose and default weights. The
    /// default camera frames the posed mesh: give --camera for a sequence of frames.
    #[arg(long, value_name = "SECONDS", value_parser = seconds, allow_negative_numbers = true)]
    time: Option<f64>,
    /// The 16 entries of a 4×4 matrix, row-major, mapping the mesh's coordinates to clip
    /// space (Vulkan: depth 0..1, NDC y down the image): a perspective or an orthographic
    /// projection (lit from its viewing direction, towards which depth decreases).
    #[arg(long, value_name = "M00,M01,...,M33", value_parser = numbers::<16>, allow_hyphen_values = true)]
    mvp: Option<[f64; 16]>,
    /// Draw the mesh once per transform in this file (instances): 16 numbers per line, a 4×4
    /// affine matrix row-major, separated by spaces or commas; `#` starts a comment. Each
    /// placement whose bounding box lies outside the view is culled before any vertex work.
    /// (A glTF file's nodes that share a mesh are instances without this.)
    #[arg(long, value_name = "TRANSFORMS.txt")]
    instances: Option<PathBuf>,
    /// Multiply heights (z) by this factor about the mesh's lowest point (for placed meshes,
    /// the lowest corner of the box holding them all): vertical exaggeration for terrain.
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0)]
    z_scale: f64,
    /// Colour of pixels no triangle covers, RGBA, each 0..255.
    #[arg(long, value_name = "R,G,B,A", value_parser = numbers::<4>, default_value = "0,0,0,0")]
    background: [f64; 4],
    #[arg(long, value_enum, default_value = "back")]
    cull: CullArg,
    #[arg(long, value_enum, default_value = "smooth")]
    shading: ShadingArg,
    /// How attributes are interpolated across a triangle: perspective-correct, linear on the
    /// screen (noperspective), or flat (the face's first vertex's values).
    #[arg(long, value_enum, default_value = "perspective")]
    interpolation: InterpolationArg,
    /// Also draw every vertex as a square this many pixels wide, over the faces (a vertices
    /// view; with --no-faces, the vertices alone: a point cloud).
    #[arg(long, value_name = "PIXELS")]
    points: Option<f32>,
    /// Draw no faces (with --points or --wireframe).
    #[arg(long)]
    no_faces: bool,
    /// Also draw every edge of the faces as a line one pixel wide, over the faces (a wireframe
    /// view; with --no-faces, the edges alone), lit by the diamond-exit rule (Direct3D's),
    /// Bresenham's, or as a rectangle one pixel wide (Vulkan's strict lines).
    #[arg(long, value_enum, value_name = "RULE", num_args = 0..=1, default_missing_value = "diamond-exit")]
    wireframe: Option<LineRuleArg>,
    /// Samples per pixel: 1, or 4 or 8 at Vulkan's standard positions (coverage and depth per
    /// sample, each triangle shaded once per pixel, the samples averaged).
    #[arg(long, value_name = "SAMPLES", default_value_t = 1)]
    msaa: u32,
    /// The wireframe's colour, RGBA, each 0..255 (default: black over the faces; the vertices'
    /// colours with --no-faces).
    #[arg(long, value_name = "R,G,B,A", value_parser = numbers::<4>)]
    wire_colour: Option<[f64; 4]>,
    /// Filter every texture so, whatever the file's samplers say: nearest (the texel), bilinear,
    /// or trilinear (bilinear in the two mip levels the level of detail lies between).
    #[arg(long, value_enum)]
    filter: Option<FilterArg>,
    /// Address every texture so outside [0, 1), whatever the file's samplers say.
    #[arg(long, value_enum)]
    address: Option<AddressArg>,
    /// Blend every fragment source-over onto what is below it, in the input's face order (the
    /// colours' alpha), as a graphics API with blending on does.
    #[arg(long)]
    blend: bool,
    /// Also write the depth raster (Float32 GeoTIFF, 1 where no triangle is).
    #[arg(long, value_name = "DEPTH.tif")]
    depth: Option<PathBuf>,
    /// Also write the triangle-id raster (UInt32 GeoTIFF: the input's faces in file order from
    /// 0, 4294967295 where no triangle is).
    #[arg(long, value_name = "IDS.tif")]
    ids: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "auto")]
    backend: crate::BackendArg,
    /// Print what the frame did (instances, clipped, culled, rasterised, fragments, overdraw,
    /// the kernels' tiles and hidden triangles) and a CRC-32 of each output layer as JSON on
    /// stderr; equal on both backends.
    #[arg(long)]
    stats: bool,
    /// Also write a tile heat map (PNG, three panels: triangles per tile, overdraw, triangles
    /// the tiles' depth bounds hid).
    #[arg(long, value_name = "HEAT.png")]
    heat_map: Option<PathBuf>,
    /// Turn one of the pipeline's skips off (repeatable), to measure its gain; the frame does
    /// not change. Names: cull_window, empty_tiles, hidden_triangles, cull_instances.
    #[arg(long = "no-skip", value_name = "SKIP", value_parser = crate::skip_name)]
    no_skip: Vec<tileraster::Skip>,
    /// No messages on stderr but errors (and --stats when asked for).
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum LineRuleArg {
    DiamondExit,
    Bresenham,
    Rectangle,
}

#[derive(Clone, Copy, ValueEnum)]
enum FilterArg {
    Nearest,
    Bilinear,
    Trilinear,
}

#[derive(Clone, Copy, ValueEnum)]
enum AddressArg {
    Repeat,
    Clamp,
    Mirror,
}

#[derive(Clone, Copy, ValueEnum)]
enum UpArg {
    Y,
    Z,
}

#[derive(Clone, Copy, ValueEnum)]
enum CullArg {
    Back,
    Front,
    None,
}

#[derive(Clone, Copy, ValueEnum)]
enum InterpolationArg {
    Perspective,
    Screen,
    Flat,
}

#[derive(Clone, Copy, ValueEnum)]
enum ShadingArg {
    Unlit,
    Flat,
    Smooth,
    Phong,
    Depth,
    Normals,
    Ids,
}

/// The transforms of `--instances`: 16 numbers a line.
fn read_transforms(path: &std::path::Path) -> Result<Vec<[[f64; 4]; 4]>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("--instances {}: {e}", path.display()))?;
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let at = || format!("--instances {}, line {}", path.display(), k + 1);
        let values: Vec<f64> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|v| !v.is_empty())
            .map(|v| v.parse::<f64>().map_err(|e| format!("{}: '{v}': {e}", at())))
            .collect::<Result<_, _>>()?;
        if values.len() != 16 {
            return Err(format!("{}: {} numbers; give the 16 entries of a 4×4 matrix, row-major", at(), values.len()));
        }
        out.push(std::array::from_fn(|r| std::array::from_fn(|c| values[r * 4 + c])));
    }
    if out.is_empty() {
        return Err(format!("--instances {}: no transforms in the file", path.display()));
    }
    Ok(out)
}

/// `--ortho`'s width: a positive number.
fn ortho_width(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(w) if w > 0.0 && w.is_finite() => Ok(w),
        Ok(w) => Err(format!("{w}: the orthographic width must be positive and finite")),
        Err(e) => Err(format!("'{s}': {e} (a path after a bare --ortho reads as its width: put the input first, or write --ortho=WIDTH)")),
    }
}

/// `--time`: a finite number of seconds.
fn seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(t) if t.is_finite() => Ok(t),
        Ok(t) => Err(format!("{t}: give a finite number of seconds")),
        Err(e) => Err(format!("'{s}': {e}")),
    }
}

/// The camera of `input` that `wanted` names (in the pose at `time`): a node index, a node's
/// name or a camera's name.
fn gltf_camera(input: &std::path::Path, wanted: &str, time: Option<f64>) -> Result<tileraster_io::GltfCamera, String> {
    if !matches!(InputKind::of(input), Ok(InputKind::Gltf)) {
        return Err(format!("--camera-node: {} is not a glTF file (.gltf, .glb); only glTF files hold cameras", input.display()));
    }
    let cameras = tileraster_io::read_gltf_cameras(input, time).map_err(|e| format!("--camera-node: {e}"))?;
    // A node's index first, then a node's name, then a camera's (so a node named "2" is found).
    let found = wanted
        .parse::<usize>()
        .ok()
        .and_then(|node| cameras.iter().find(|c| c.node == node))
        .or_else(|| cameras.iter().find(|c| c.node_name.as_deref() == Some(wanted)))
        .or_else(|| cameras.iter().find(|c| c.name.as_deref() == Some(wanted)));
    found.cloned().ok_or_else(|| {
        let listed: Vec<String> = cameras
            .iter()
            .map(|c| {
                let named = |what: &str, name: &Option<String>| name.as_ref().map(|n| format!(" {what}{n:?}")).unwrap_or_default();
                format!("node {}{}{}", c.node, named("", &c.node_name), named("camera ", &c.name))
            })
            .collect();
        match listed.is_empty() {
            true => format!("--camera-node {wanted}: {} places no camera in its scene", input.display()),
            false => format!("--camera-node {wanted}: no such camera node; the scene's cameras: {}", listed.join(", ")),
        }
    })
}

/// `N` comma-separated numbers.
fn numbers<const N: usize>(s: &str) -> Result<[f64; N], String> {
    let values: Vec<f64> = s.split(',').map(|v| v.trim().parse::<f64>().map_err(|e| format!("'{v}': {e}"))).collect::<Result<_, _>>()?;
    values.try_into().map_err(|v: Vec<f64>| format!("expected {N} comma-separated numbers, got {}", v.len()))
}

pub fn render_command(args: RenderArgs) -> Result<ExitCode, String> {
    let RenderArgs {
        input,
        output,
        size,
        camera,
        fov,
        ortho,
        up,
        camera_node,
        time,
        mvp,
        instances,
        z_scale,
        background,
        cull,
        shading,
        interpolation,
        points,
        no_faces,
        wireframe,
        msaa,
        wire_colour,
        filter,
        address,
        blend,
        depth,
        ids,
        backend,
        stats,
        heat_map,
        no_skip,
        quiet,
    } = args;
    if !(z_scale.is_finite() && z_scale != 0.0) {
        return Err(format!("--z-scale {z_scale}: give a finite, non-zero factor"));
    }
    set_quiet(quiet);
    let node_camera = match &camera_node {
        Some(wanted) => Some(gltf_camera(&input, wanted, time)?),
        None => None,
    };
    let (width, height) = match (size, &node_camera) {
        (Some(size), _) => (size[0], size[1]),
        (None, Some(c)) => {
            let aspect = match c.projection {
                tileraster_io::GltfProjection::Perspective { aspect_ratio, .. } => aspect_ratio.unwrap_or(16.0 / 9.0),
                tileraster_io::GltfProjection::Orthographic { xmag, ymag, .. } => (xmag / ymag).abs(),
            };
            match aspect.is_finite() && aspect > 0.0 {
                true => (1280, ((1280.0 / aspect).round() as u32).clamp(1, MAX_RENDER_DIM)),
                false => (1280, 720),
            }
        }
        (None, None) => (1280, 720),
    };
    // A DEM is drawn by the kernels' built-in heightfield program: its flat grid, lifted in the
    // vertex stage by its heights as a vertex texture (the same frame as its mesh's). Its points
    // would include the cells without a height, and `--z-scale` scales about the lowest height:
    // both take the mesh.
    let lifted = match is_geotiff(&input) && instances.is_none() && points.is_none() && z_scale == 1.0 {
        true => read_dem_grid(&input).map_err(|e| e.to_string())?,
        false => None,
    };
    // A glTF file's skins and morph targets are posed by the kernels' built-in deform program:
    // the file at rest, and its pose at `--time` as a vertex texture (the same frame as the
    // host's pose gives). `--z-scale` scales the posed mesh: the host poses it then.
    let posable = match instances.is_none() && lifted.is_none() && z_scale == 1.0 {
        true => read_posable_at(&input, time).map_err(|e| e.to_string())?,
        false => None,
    };
    let (world, pose) = match (&instances, lifted, posable) {
        (None, Some((grid, texture)), _) => (World::single(grid), Some((VertexStage::HEIGHTS, texture, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]))),
        (None, None, Some(posable)) => (World::single(posable.mesh), Some((VertexStage::DEFORM, posable.texture, posable.constants))),
        (Some(file), ..) => (World::instanced(read_mesh_at(&input, time).map_err(|e| e.to_string())?, &read_transforms(file)?), None),
        (None, None, None) => (read_world_at(&input, time).map_err(|e| e.to_string())?, None),
    };
    let mut posing = RenderParams::new(1, 1, IDENTITY);
    if let Some((stage, texture, constants)) = pose {
        (posing.vertex, posing.vertex_texture, posing.vertex_constants) = (Some(stage), Some(Arc::new(texture)), constants);
    }
    // A single mesh is scaled and framed as it is; instances by the box holding them all.
    let single = world.instances.len() == 1 && world.instances[0].transform == IDENTITY;
    let (mut world, mut model) = (world, IDENTITY);
    let mesh = if single {
        let mut mesh = world.meshes.swap_remove(0);
        if z_scale != 1.0 {
            let lowest = mesh.positions.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min);
            for p in &mut mesh.positions {
                p[2] = lowest + z_scale * (p[2] - lowest);
            }
        }
        world = World::single(mesh);
        match posing.vertex {
            // Framed as posed, by the vertices its faces use (not a DEM's cells without a height).
            Some(_) => {
                let grid = &world.meshes[0];
                let mut used = vec![false; grid.positions.len()];
                grid.triangles.iter().flatten().for_each(|&v| used[v as usize] = true);
                let posed = posed_positions(grid, &posing).map_err(|e| e.to_string())?;
                &Mesh { positions: posed.into_iter().zip(used).filter_map(|(p, used)| used.then_some(p)).collect(), ..Default::default() }
            }
            None => &world.meshes[0],
        }
    } else {
        let [lo, hi] = world.bounds().map_err(|e| e.to_string())?;
        model[2] = [0.0, 0.0, z_scale, lo[2] * (1.0 - z_scale)];
        let scaled = |z: f64| lo[2] + z_scale * (z - lo[2]);
        let corners =
            (0..8).map(|k| [if k & 1 == 0 { lo[0] } else { hi[0] }, if k & 2 == 0 { lo[1] } else { hi[1] }, scaled(if k & 4 == 0 { lo[2] } else { hi[2] })]);
        &Mesh { positions: corners.collect(), triangles: vec![[0, 1, 2]], ..Default::default() }
    };
    let aspect = width as f64 / height.max(1) as f64;
    let projection = match ortho {
        Some(width) => Projection::Orthographic { width: width.unwrap_or(1.0) },
        None => Projection::Perspective { fov_deg: fov },
    };
    let up = match up {
        Some(UpArg::Y) => Up::Y,
        Some(UpArg::Z) => Up::Z,
        None => format_up(&input).map_err(|e| e.to_string())?,
    };
    // The matrix, and the viewer the lighting takes where a camera names it (the default
    // perspective camera's is its matrix's centre of projection, and an `--mvp`'s too).
    let named = |camera: Camera, flag: &str| match camera.view_projection(width, height) {
        Ok(m) => Ok((m, Some(camera.viewer()))),
        Err(e) => Err(format!("{flag}: {e}")),
    };
    let (view_projection, viewer) = match (mvp, &node_camera, camera) {
        (Some(m), ..) => (std::array::from_fn(|r| std::array::from_fn(|c| m[r * 4 + c])), None),
        (None, Some(c), _) => named(Camera::of_gltf(c, mesh, aspect), "--camera-node")?,
        (None, None, Some(c)) => {
            let look = Camera::look_at([c[0], c[1], c[2]], [c[3], c[4], c[5]], [c[6], c[7], c[8]], projection, mesh);
            named(if ortho == Some(None) { look.fit_orthographic(mesh, aspect) } else { look }, "--camera")?
        }
        (None, None, None) => {
            let mut framed = Camera::framing(mesh, aspect, projection, up);
            if let Some(Some(seen)) = ortho {
                framed.projection = Projection::Orthographic { width: seen };
            }
            (framed.view_projection(width, height).map_err(|e| e.to_string())?, ortho.map(|_| framed.viewer()))
        }
    };
    for (flag, colour) in [("--background", Some(background)), ("--wire-colour", wire_colour)] {
        if let Some(c) = colour.iter().flatten().find(|c| !(0.0..=255.0).contains(*c) || c.fract() != 0.0) {
            return Err(format!("{flag}: {c} is not a whole number from 0 to 255"));
        }
    }
    let mut params = RenderParams::new(width, height, view_projection);
    params.model = model;
    params.background = background.map(|c| c as u8);
    params.cull = match cull {
        CullArg::Back => Cull::Back,
        CullArg::Front => Cull::Front,
        CullArg::None => Cull::None,
    };
    params.blend = blend;
    params.count_fragments = stats || heat_map.is_some();
    params.count_tiles = heat_map.is_some();
    // The depth layer only where it is written or checksummed (the GPU then reads it back).
    params.return_depth = depth.is_some() || stats;
    (params.points, params.faces, params.samples) = (points, !no_faces, msaa);
    params.wireframe = wireframe.map(|rule| Wireframe {
        rule: match rule {
            LineRuleArg::DiamondExit => LineRule::DiamondExit,
            LineRuleArg::Bresenham => LineRule::Bresenham,
            LineRuleArg::Rectangle => LineRule::Rectangle,
        },
        colour: match (wire_colour, no_faces) {
            (Some(c), _) => Some(c.map(|c| (c / 255.0) as f32)),
            (None, false) => Some([0.0, 0.0, 0.0, 1.0]),
            (None, true) => None,
        },
    });
    params.texture_filter = filter.map(|f| match f {
        FilterArg::Nearest => Filter::Nearest,
        FilterArg::Bilinear => Filter::Bilinear,
        FilterArg::Trilinear => Filter::Trilinear,
    });
    params.texture_address = address.map(|a| match a {
        AddressArg::Repeat => Address::Repeat,
        AddressArg::Clamp => Address::ClampToEdge,
        AddressArg::Mirror => Address::MirroredRepeat,
    });
    for skip in no_skip {
        params.skips = params.skips.without(skip);
    }
    params.interpolation = match interpolation {
        InterpolationArg::Perspective => Interpolation::Perspective,
        InterpolationArg::Screen => Interpolation::Screen,
        InterpolationArg::Flat => Interpolation::Flat,
    };
    params.shading = match shading {
        ShadingArg::Unlit => Shading::Unlit,
        ShadingArg::Flat => Shading::Flat,
        ShadingArg::Smooth => Shading::Smooth,
        ShadingArg::Phong => Shading::Phong,
        ShadingArg::Depth => Shading::Depth,
        ShadingArg::Normals => Shading::Normals,
        ShadingArg::Ids => Shading::Ids,
    };
    params.eye = viewer;
    (params.vertex, params.vertex_texture, params.vertex_constants) = (posing.vertex, posing.vertex_texture, posing.vertex_constants);
    let (backend, chosen) = crate::choose_backend(backend, width as u64 * height as u64);
    let start = Instant::now();
    let frame = render_world(&world, &params, backend).map_err(|e| e.to_string())?;
    let took = start.elapsed();
    tileraster_io::write_rgba_png(&output, width, height, &frame.rgba8()).map_err(|e| e.to_string())?;
    if let Some(path) = &heat_map {
        let (w, h, rgba) = frame.heat_map().map_err(|e| e.to_string())?;
        tileraster_io::write_rgba_png(path, w, h, &rgba).map_err(|e| e.to_string())?;
    }
    let grid = Grid::new(0.0, width as f64, 0.0, height as f64, width, height);
    let window = Window::whole(&grid);
    if let Some(path) = &depth {
        let mut tiff = GeoTiffWriter::create(path, &grid, window, Sample::Float32 { nodata: params.clear_depth }, &GeoTiffOptions::default())
            .map_err(|e| e.to_string())?;
        tiff.write_rows(&frame.depth).and_then(|()| tiff.finish()).map_err(|e| e.to_string())?;
    }
    if let Some(path) = &ids {
        let mut tiff = GeoTiffWriter::create(path, &grid, window, Sample::UInt32, &GeoTiffOptions::default()).map_err(|e| e.to_string())?;
        tiff.write_rows(&frame.ids).and_then(|()| tiff.finish()).map_err(|e| e.to_string())?;
    }
    note(format!(
        "tileraster: {} triangles{}{} → {width}×{height} on the {} backend in {:.1} ms ({} rasterised, {} pixels covered) → {}",
        world.instances.iter().map(|i| world.meshes[i.mesh as usize].triangles.len() as u64).sum::<u64>(),
        if single { String::new() } else { format!(" in {} instances ({} culled)", world.instances.len(), frame.stats.geometry.instances_culled) },
        match posing.vertex {
            Some(stage) if stage == VertexStage::HEIGHTS => " (the DEM's heights lifted by the vertex stage)",
            Some(stage) if stage == VertexStage::DEFORM => " (skins and morph targets posed by the vertex stage)",
            _ => "",
        },
        backend.name(),
        took.as_secs_f64() * 1e3,
        frame.stats.geometry.rasterised,
        frame.stats.pixels_covered,
        output.display()
    ));
    if stats {
        if let Some(choice) = &chosen {
            eprintln!("{}", choice.to_json());
        }
        let json = frame.stats.to_json();
        eprintln!("{},\"checksums\":{}}}", &json[..json.len() - 1], frame.checksums().to_json());
    }
    Ok(ExitCode::SUCCESS)
}
