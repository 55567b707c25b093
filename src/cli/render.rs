//! `tileraster render`: a mesh to a PNG, with optional depth and triangle-id rasters.

use super::progress::{note, set_quiet};
use clap::{Args, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use tileraster::render::{
    Address, CameraChoice, Cull, Filter, Interpolation, Lens, LineRule, MeshSource, Model, ModelOptions, Shading, ToneMap, Up, VertexStage, ViewOptions,
    render_world,
};
use tileraster::{Backend, Grid, Window};
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
    #[command(flatten)]
    frame: FrameArgs,
    /// Also write the depth raster (Float32 GeoTIFF, 1 where no triangle is).
    #[arg(long, value_name = "DEPTH.tif")]
    depth: Option<PathBuf>,
    /// Also write the triangle-id raster (UInt32 GeoTIFF: the input's faces in file order from
    /// 0, 4294967295 where no triangle is).
    #[arg(long, value_name = "IDS.tif")]
    ids: Option<PathBuf>,
    /// Print what the frame did (instances, clipped, culled, rasterised, fragments, overdraw,
    /// the kernels' tiles and hidden triangles) and a CRC-32 of each output layer as JSON on
    /// stderr; equal on both backends.
    #[arg(long)]
    stats: bool,
    /// Also write a tile heat map (PNG, three panels: triangles per tile, overdraw, triangles
    /// the tiles' depth bounds hid).
    #[arg(long, value_name = "HEAT.png")]
    heat_map: Option<PathBuf>,
    /// No messages on stderr but errors (and --stats when asked for).
    #[arg(short, long)]
    quiet: bool,
}

/// What a frame is: the options `tileraster render` and `tileraster view` share.
#[derive(Args)]
pub struct FrameArgs {
    /// Frame width and height in pixels (default 1280 × 720; with --camera-node, 1280 wide and
    /// as high as the camera's aspect ratio makes it, 16:9 where it names none).
    #[arg(long, num_args = 2, value_names = ["WIDTH", "HEIGHT"])]
    size: Option<Vec<u32>>,
    /// A look-at camera: eye, target and up vector, in the mesh's coordinates.
    #[arg(long, value_name = "EX,EY,EZ,TX,TY,TZ,UX,UY,UZ", value_parser = numbers::<9>, allow_hyphen_values = true, conflicts_with_all = ["mvp", "camera_node"])]
    camera: Option<[f64; 9]>,
    /// Vertical field of view of --camera (and of the default camera), degrees (default 45); of
    /// a cylindrical projection, from the frame's bottom to its top (default 90); of a fisheye,
    /// across the frame's width (default 180, at most 360).
    #[arg(long, conflicts_with_all = ["ortho", "camera_node", "mvp"])]
    fov: Option<f64>,
    /// How the camera projects: perspective (the default), orthographic (as --ortho), or around
    /// the eye, resampled from the faces of a cube map drawn as exact perspective frames (each
    /// pixel a face pixel: its colour, depth and face id): cylindrical (360° across), equirectangular
    /// (360° × 180°: a panorama from a point, as a visibility study needs) or fisheye
    /// (equidistant).
    #[arg(long, value_enum, conflicts_with_all = ["ortho", "camera_node", "mvp"])]
    projection: Option<ProjectionArg>,
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
    /// Which faces are dropped by facing; by default back faces, but not those of a glTF
    /// file's double-sided materials. Given, every face is culled as it says.
    #[arg(long, value_enum)]
    cull: Option<CullArg>,
    /// How pixels are coloured; by default pbr for a file with materials (glTF, an OBJ with
    /// an MTL file), else smooth.
    #[arg(long, value_enum)]
    shading: Option<ShadingArg>,
    /// How metallic the surface of a mesh without materials is, 0 (a dielectric; the default)
    /// to 1, for --shading pbr.
    #[arg(long, value_name = "FACTOR")]
    metallic: Option<f64>,
    /// The perceptual roughness of a mesh without materials, 0 (a mirror; shaded as 0.045) to 1
    /// (0.5 by default), for --shading pbr.
    #[arg(long, value_name = "FACTOR")]
    roughness: Option<f64>,
    /// Bring lit colours into range so: clamped (none), Khronos PBR Neutral, or ACES.
    #[arg(long, value_enum, default_value = "none")]
    tone_map: ToneMapArg,
    /// Store lit colours sRGB-encoded, as image files and screens expect (default: linear).
    #[arg(long)]
    srgb: bool,
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
    #[arg(long, value_enum, default_value = "auto")]
    backend: crate::BackendArg,
    /// Turn one of the pipeline's skips off (repeatable), to measure its gain; the frame does
    /// not change. Names: cull_window, empty_tiles, hidden_triangles, cull_instances.
    #[arg(long = "no-skip", value_name = "SKIP", value_parser = crate::skip_name)]
    no_skip: Vec<tileraster::Skip>,
    /// Draw N frames at a fixed sequence of sub-pixel offsets (Halton's, bases 2 and 3) and
    /// average their colours in integers, in order: an anti-aliased frame without MSAA's memory,
    /// the same bits on every backend (depth and ids are the first sample's). At most 256.
    #[arg(long, value_name = "N", default_value_t = 1)]
    jitter: u32,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum LineRuleArg {
    DiamondExit,
    Bresenham,
    Rectangle,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum FilterArg {
    Nearest,
    Bilinear,
    Trilinear,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum AddressArg {
    Repeat,
    Clamp,
    Mirror,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum ProjectionArg {
    Perspective,
    Orthographic,
    Cylindrical,
    Equirectangular,
    Fisheye,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum UpArg {
    Y,
    Z,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum CullArg {
    Back,
    Front,
    None,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum InterpolationArg {
    Perspective,
    Screen,
    Flat,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum ToneMapArg {
    None,
    Neutral,
    Aces,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum ShadingArg {
    Unlit,
    Flat,
    Smooth,
    Phong,
    Pbr,
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

/// `N` comma-separated numbers.
fn numbers<const N: usize>(s: &str) -> Result<[f64; N], String> {
    let values: Vec<f64> = s.split(',').map(|v| v.trim().parse::<f64>().map_err(|e| format!("'{v}': {e}"))).collect::<Result<_, _>>()?;
    values.try_into().map_err(|v: Vec<f64>| format!("expected {N} comma-separated numbers, got {}", v.len()))
}

impl FrameArgs {
    /// The file `--instances` names.
    pub fn instances_path(&self) -> Option<PathBuf> {
        self.instances.clone()
    }

    /// The model's options and the frame's, as the library takes them, and the backend asked for.
    pub fn options(self) -> Result<(ModelOptions, ViewOptions, crate::BackendArg), String> {
        let FrameArgs {
            size,
            camera,
            fov,
            projection,
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
            metallic,
            roughness,
            tone_map,
            srgb,
            interpolation,
            points,
            no_faces,
            wireframe,
            msaa,
            wire_colour,
            filter,
            address,
            blend,
            backend,
            no_skip,
            jitter,
        } = self;
        let instances = instances.as_deref().map(read_transforms).transpose()?;
        let model = ModelOptions { time, z_scale, instances, points: points.is_some() };
        let view = ViewOptions {
            size: size.map(|s| [s[0], s[1]]),
            camera: match (mvp, camera_node, camera) {
                (Some(m), ..) => CameraChoice::Matrix(std::array::from_fn(|r| std::array::from_fn(|c| m[r * 4 + c]))),
                (None, Some(node), _) => CameraChoice::Node(node),
                (None, None, Some(c)) => CameraChoice::LookAt { eye: [c[0], c[1], c[2]], target: [c[3], c[4], c[5]], up: [c[6], c[7], c[8]] },
                (None, None, None) => CameraChoice::Framing,
            },
            lens: Lens::of(projection.map(value_name).as_deref(), fov, ortho).map_err(|e| e.to_string())?,
            up: up.map(|up| library(&UPS, up)),
            background,
            cull: cull.map(|c| library(&CULLS, c)),
            shading: shading.map(|s| library(&SHADINGS, s)),
            metallic,
            roughness,
            tone_map: library(&TONE_MAPS, tone_map),
            srgb,
            interpolation: library(&INTERPOLATIONS, interpolation),
            points,
            faces: !no_faces,
            wireframe: wireframe.map(|rule| library(&LINE_RULES, rule)),
            wire_colour,
            msaa,
            filter: filter.map(|f| library(&FILTERS, f)),
            address: address.map(|a| library(&ADDRESSES, a)),
            blend,
            no_skip,
            jitter,
            return_depth: false,
            count_fragments: false,
            count_tiles: false,
        };
        Ok((model, view, backend))
    }
}

/// The `tileraster render` command line that draws the frame of `model` and `view` on
/// `backend` into `output`: [`FrameArgs::options`] of its arguments gives them back (the
/// instances read from `instances`, the file they came from). Options at their defaults are
/// left out; numbers are written as Rust writes them, the shortest text that reads back as the
/// same number.
pub fn command_line(input: &Path, output: &str, instances: Option<&Path>, model: &ModelOptions, view: &ViewOptions, backend: Backend) -> Vec<String> {
    let mut args: Vec<String> = vec!["tileraster".into(), "render".into(), input.display().to_string(), "-o".into(), output.into()];
    let mut flag = |name: &str, values: &[String]| {
        args.push(format!("--{name}"));
        args.extend(values.iter().cloned());
    };
    let joined = |values: &[f64]| values.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(",");
    if let Some([w, h]) = view.size {
        flag("size", &[w.to_string(), h.to_string()]);
    }
    match &view.camera {
        CameraChoice::Framing => {}
        CameraChoice::LookAt { eye, target, up } => flag("camera", &[joined(&[*eye, *target, *up].concat())]),
        CameraChoice::Node(node) => flag("camera-node", std::slice::from_ref(node)),
        CameraChoice::Matrix(m) => flag("mvp", &[joined(&m.concat())]),
    }
    let lens_given = matches!(view.camera, CameraChoice::Framing | CameraChoice::LookAt { .. });
    let (projection, fov) = view.lens.projection();
    match view.lens {
        Lens::Orthographic { width: Some(w) } if lens_given => flag(&format!("ortho={w}"), &[]),
        _ if lens_given && projection != "perspective" => flag("projection", &[projection.into()]),
        _ => {}
    }
    if let Some((fov, _)) = fov.filter(|&(fov, default)| lens_given && fov != default) {
        flag("fov", &[fov.to_string()]);
    }
    if let (Some(up), CameraChoice::Framing) = (view.up, &view.camera) {
        flag("up", &[named(&UPS, up)]);
    }
    if let Some(time) = model.time {
        flag("time", &[time.to_string()]);
    }
    if let Some(path) = instances {
        flag("instances", &[path.display().to_string()]);
    }
    if model.z_scale != 1.0 {
        flag("z-scale", &[model.z_scale.to_string()]);
    }
    if view.background != [0.0; 4] {
        flag("background", &[joined(&view.background)]);
    }
    if let Some(cull) = view.cull {
        flag("cull", &[named(&CULLS, cull)]);
    }
    if let Some(shading) = view.shading {
        flag("shading", &[named(&SHADINGS, shading)]);
    }
    if let Some(metallic) = view.metallic {
        flag("metallic", &[metallic.to_string()]);
    }
    if let Some(roughness) = view.roughness {
        flag("roughness", &[roughness.to_string()]);
    }
    if view.tone_map != ToneMap::None {
        flag("tone-map", &[named(&TONE_MAPS, view.tone_map)]);
    }
    if view.srgb {
        flag("srgb", &[]);
    }
    if view.interpolation != Interpolation::Perspective {
        flag("interpolation", &[named(&INTERPOLATIONS, view.interpolation)]);
    }
    if let Some(points) = view.points {
        flag("points", &[points.to_string()]);
    }
    if !view.faces {
        flag("no-faces", &[]);
    }
    if let Some(rule) = view.wireframe {
        flag("wireframe", &[named(&LINE_RULES, rule)]);
    }
    if let Some(colour) = view.wire_colour {
        flag("wire-colour", &[joined(&colour)]);
    }
    if view.msaa != 1 {
        flag("msaa", &[view.msaa.to_string()]);
    }
    if let Some(filter) = view.filter {
        flag("filter", &[named(&FILTERS, filter)]);
    }
    if let Some(address) = view.address {
        flag("address", &[named(&ADDRESSES, address)]);
    }
    if view.blend {
        flag("blend", &[]);
    }
    for skip in &view.no_skip {
        flag("no-skip", &[skip.name().into()]);
    }
    if view.jitter != 1 {
        flag("jitter", &[view.jitter.to_string()]);
    }
    flag("backend", &[backend.name().into()]);
    args
}

/// Each command-line value beside the library's, read both ways.
const CULLS: [(CullArg, Cull); 3] = [(CullArg::Back, Cull::Back), (CullArg::Front, Cull::Front), (CullArg::None, Cull::None)];
const SHADINGS: [(ShadingArg, Shading); 8] = [
    (ShadingArg::Unlit, Shading::Unlit),
    (ShadingArg::Flat, Shading::Flat),
    (ShadingArg::Smooth, Shading::Smooth),
    (ShadingArg::Phong, Shading::Phong),
    (ShadingArg::Pbr, Shading::Pbr),
    (ShadingArg::Depth, Shading::Depth),
    (ShadingArg::Normals, Shading::Normals),
    (ShadingArg::Ids, Shading::Ids),
];
const TONE_MAPS: [(ToneMapArg, ToneMap); 3] = [(ToneMapArg::None, ToneMap::None), (ToneMapArg::Neutral, ToneMap::Neutral), (ToneMapArg::Aces, ToneMap::Aces)];
const INTERPOLATIONS: [(InterpolationArg, Interpolation); 3] = [
    (InterpolationArg::Perspective, Interpolation::Perspective),
    (InterpolationArg::Screen, Interpolation::Screen),
    (InterpolationArg::Flat, Interpolation::Flat),
];
const LINE_RULES: [(LineRuleArg, LineRule); 3] =
    [(LineRuleArg::DiamondExit, LineRule::DiamondExit), (LineRuleArg::Bresenham, LineRule::Bresenham), (LineRuleArg::Rectangle, LineRule::Rectangle)];
const FILTERS: [(FilterArg, Filter); 3] =
    [(FilterArg::Nearest, Filter::Nearest), (FilterArg::Bilinear, Filter::Bilinear), (FilterArg::Trilinear, Filter::Trilinear)];
const ADDRESSES: [(AddressArg, Address); 3] =
    [(AddressArg::Repeat, Address::Repeat), (AddressArg::Clamp, Address::ClampToEdge), (AddressArg::Mirror, Address::MirroredRepeat)];
const UPS: [(UpArg, Up); 2] = [(UpArg::Y, Up::Y), (UpArg::Z, Up::Z)];

/// The shading `--shading NAME` names.
pub fn shading_named(name: &str) -> Option<Shading> {
    ShadingArg::from_str(name, false).ok().map(|arg| library(&SHADINGS, arg))
}

/// `--shading`'s name of `shading`.
pub fn shading_name(shading: Shading) -> String {
    named(&SHADINGS, shading)
}

/// The library's value of a command-line value.
fn library<A: PartialEq + Copy, L: Copy>(table: &[(A, L)], arg: A) -> L {
    table.iter().find(|(a, _)| *a == arg).expect("every value is in its table").1
}

/// The name of a command-line value.
fn value_name<A: ValueEnum>(arg: A) -> String {
    arg.to_possible_value().expect("every value is named").get_name().to_string()
}

/// The command line's name of a library value.
fn named<A: ValueEnum + Copy, L: PartialEq>(table: &[(A, L)], value: L) -> String {
    value_name(table.iter().find(|(_, l)| *l == value).expect("every value is in its table").0)
}

pub fn render_command(args: RenderArgs) -> Result<ExitCode, String> {
    let RenderArgs { input, output, frame, depth, ids, stats, heat_map, quiet } = args;
    set_quiet(quiet);
    let (options, mut view, backend) = frame.options()?;
    let model = Model::load(MeshSource::File(input), &options).map_err(|e| e.to_string())?;
    // The depth layer only where it is written or checksummed (the GPU then reads it back).
    view.return_depth = depth.is_some() || stats;
    (view.count_fragments, view.count_tiles) = (stats || heat_map.is_some(), heat_map.is_some());
    let params = model.params(&view).map_err(|e| e.to_string())?;
    let (width, height) = (params.width, params.height);
    let world = model.world();
    let (backend, chosen) = crate::choose_backend(backend, width as u64 * height as u64);
    let start = Instant::now();
    let frame = model.draw(&view, &mut |params| render_world(world, params, backend)).map_err(|e| e.to_string())?;
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
        if model.is_single() { String::new() } else { format!(" in {} instances ({} culled)", world.instances.len(), frame.stats.geometry.instances_culled) },
        match model.vertex_stage() {
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: RenderArgs,
    }

    /// The options `args` (after `tileraster render`) give.
    fn options_of(args: &[String]) -> (ModelOptions, ViewOptions, crate::BackendArg) {
        let cli = Cli::try_parse_from(std::iter::once("tileraster").chain(args.iter().map(String::as_str))).unwrap_or_else(|e| panic!("{args:?}: {e}"));
        cli.args.frame.options().unwrap()
    }

    /// The command line written for the options of any command line gives those options back.
    #[test]
    fn a_written_command_line_reads_back_as_its_options() {
        let dir = std::env::temp_dir().join(format!("tileraster-command-line-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let transforms = dir.join("two.txt");
        std::fs::write(&transforms, "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0 0.1 0 1 0 -3e-7 0 0 1 2 0 0 0 1\n").unwrap();
        let cases: Vec<Vec<&str>> = vec![
            vec![],
            vec!["--size", "640", "480", "--fov", "33.3", "--shading", "phong", "--msaa", "8", "--cull", "none"],
            vec!["--shading", "pbr", "--metallic", "0.8", "--roughness", "0.25", "--tone-map", "neutral", "--srgb"],
            vec!["--tone-map", "aces"],
            vec!["--camera", "0.1,-2.5e-3,1e17,5,6,7,0,0,1", "--ortho", "--background", "1,2,3,255", "--interpolation", "screen"],
            vec!["--ortho=12.75", "--up", "z", "--points", "2.5", "--no-faces", "--wireframe", "bresenham", "--wire-colour", "9,8,7,6"],
            vec!["--mvp", "1,0,0,0,0,1,0,0,0,0,0.5,0.5,0,0,0,1", "--filter", "trilinear", "--address", "mirror", "--blend"],
            vec!["--camera-node", "my camera's node", "--time", "0.3333333333333333", "--no-skip", "empty_tiles", "--no-skip", "cull_window"],
            vec!["--instances", transforms.to_str().unwrap(), "--z-scale", "2.5", "--shading", "ids", "--backend", "gpu"],
            vec!["--projection", "equirectangular", "--camera", "1,2,3,4,5,6,0,0,1"],
            vec!["--projection", "fisheye", "--fov", "220"],
            vec!["--projection", "cylindrical"],
            vec!["--projection", "orthographic", "--jitter", "16"],
            vec!["--projection", "perspective", "--fov", "60", "--jitter", "4"],
        ];
        for case in cases {
            let given: Vec<String> = ["mesh dir/it's.obj", "-o", "out.png"].iter().copied().chain(case.iter().copied()).map(String::from).collect();
            let (model, view, backend) = options_of(&given);
            let backend = if backend == crate::BackendArg::Gpu { Backend::Gpu } else { Backend::Cpu };
            let instances = case.iter().position(|&a| a == "--instances").map(|k| Path::new(case[k + 1]));
            let written = command_line(Path::new("mesh dir/it's.obj"), "out.png", instances, &model, &view, backend);
            assert_eq!(&written[..2], ["tileraster", "render"]);
            // Through a shell's quoting and back.
            let read = shell_words::split(&shell_words::join(&written)).unwrap();
            assert_eq!(read, written);
            let (model_again, view_again, backend_again) = options_of(&read[2..]);
            assert_eq!((model_again, view_again), (model, view), "{case:?} → {written:?}");
            assert_eq!(backend_again == crate::BackendArg::Gpu, backend == Backend::Gpu);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
