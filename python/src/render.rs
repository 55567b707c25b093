//! Rendering for Python: `tileraster.render` and `tileraster.Renderer` over the library's
//! [`Model`], so that the same options draw the command line's bits. Frames come out as the
//! library's buffers handed over to numpy, not copied.

use crate::{error, interruptible, triangles_of, vertices_of};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyBool;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use tileraster::Backend;
use tileraster::render::{
    Address, CameraChoice, Cull, Filter, Frame, FrameError, Interpolation, Lens, LineRule, Mesh as RustMesh, MeshSource, Model, ModelOptions, PreparedModel,
    RenderParams, Shading, ToneMap, Up, ViewOptions, render_world,
};

/// A library error as Python raises it: an option's error names the keyword argument.
fn frame_error(e: FrameError) -> PyErr {
    match e {
        FrameError::Option { option, message } => error(format!("{}: {message}", option.replace('-', "_"))),
        other => error(other),
    }
}

/// A triangle mesh with optional per-vertex normals, colours and texture coordinates.
#[pyclass(frozen, module = "tileraster._native")]
pub(crate) struct Mesh {
    mesh: Arc<RustMesh>,
}

/// `value` as (N, `W`) rows of `f32` (any numeric array-like), N being `count`.
fn float_rows<const W: usize>(value: &Bound<'_, PyAny>, what: &str, count: usize, scale: f32) -> PyResult<Vec<[f32; W]>> {
    let numpy = value.py().import("numpy")?;
    let array = numpy.call_method1("asarray", (value,))?;
    let shape: Vec<usize> = array.getattr("shape")?.extract()?;
    let kind: String = array.getattr("dtype")?.getattr("kind")?.extract()?;
    if shape != [count, W] || !matches!(kind.as_str(), "f" | "i" | "u") {
        return Err(error(format!(
            "{what} has shape {} and dtype {}; give a ({count}, {W}) array of numbers, a row per vertex",
            array.getattr("shape")?.repr()?,
            array.getattr("dtype")?.str()?
        )));
    }
    let array = numpy.call_method1("ascontiguousarray", (array, "float64"))?;
    let array: PyReadonlyArray2<'_, f64> = array.extract()?;
    let rows = array.as_slice().map_err(error)?.as_chunks::<W>().0;
    Ok(rows.iter().map(|row| row.map(|v| (v / scale as f64) as f32)).collect())
}

#[pymethods]
impl Mesh {
    #[new]
    #[pyo3(signature = (positions, triangles, *, normals = None, colours = None, uvs = None))]
    fn new(
        positions: &Bound<'_, PyAny>,
        triangles: &Bound<'_, PyAny>,
        normals: Option<&Bound<'_, PyAny>>,
        colours: Option<&Bound<'_, PyAny>>,
        uvs: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Mesh> {
        let positions = vertices_of(positions, "positions")?;
        let n = positions.len();
        let colours = match colours {
            None => None,
            Some(c) => {
                let array = c.py().import("numpy")?.call_method1("asarray", (c,))?;
                let width: usize = array.getattr("shape")?.extract::<Vec<usize>>()?.get(1).copied().unwrap_or(0);
                // Bytes are 0..=255; other numbers are linear RGBA in [0, 1].
                let scale = if array.getattr("dtype")?.str()?.to_str()? == "uint8" { 255.0 } else { 1.0 };
                match width {
                    3 => Some(float_rows::<3>(&array, "colours", n, scale)?.into_iter().map(|[r, g, b]| [r, g, b, 1.0]).collect()),
                    _ => Some(float_rows::<4>(&array, "colours", n, scale)?),
                }
            }
        };
        let mesh = RustMesh {
            triangles: triangles_of(triangles)?,
            normals: normals.map(|v| float_rows::<3>(v, "normals", n, 1.0)).transpose()?,
            colours,
            uvs: uvs.map(|v| float_rows::<2>(v, "uvs", n, 1.0)).transpose()?,
            positions,
            ..Default::default()
        };
        tileraster::render::validate_mesh(&mesh).map_err(error)?;
        Ok(Mesh { mesh: Arc::new(mesh) })
    }

    fn __len__(&self) -> usize {
        self.mesh.triangles.len()
    }

    fn __repr__(&self) -> String {
        format!("tileraster.Mesh({} vertices, {} triangles)", self.mesh.positions.len(), self.mesh.triangles.len())
    }
}

/// A frame's options, checked (`tileraster.render`'s keyword arguments).
#[pyclass(frozen, module = "tileraster._native")]
pub(crate) struct View {
    options: ViewOptions,
    backend: Option<Backend>,
}

/// `name`'s value among `choices` (its keyword argument's).
fn choice<T: Copy>(what: &str, name: &str, choices: &[(&str, T)]) -> PyResult<T> {
    choices.iter().find(|(n, _)| *n == name).map(|&(_, v)| v).ok_or_else(|| {
        let names: Vec<String> = choices.iter().map(|(n, _)| format!("\"{n}\"")).collect();
        error(format!("{what}=\"{name}\": give one of {}", names.join(", ")))
    })
}

#[pymethods]
impl View {
    #[new]
    #[pyo3(signature = (*, size = None, camera = None, mvp = None, camera_node = None, fov = None, ortho = None, up = None, background = [0.0; 4],
        cull = None, shading = None, metallic = None, roughness = None, tone_map = "none", srgb = false, interpolation = "perspective", points = None, faces = true, wireframe = None, wire_colour = None, msaa = 1,
        filter = None, address = None, blend = false, no_skip = Vec::new(), count_fragments = false, projection = None, jitter = 1, backend = "auto"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        size: Option<(u32, u32)>,
        camera: Option<[[f64; 3]; 3]>,
        mvp: Option<[[f64; 4]; 4]>,
        camera_node: Option<&Bound<'_, PyAny>>,
        fov: Option<f64>,
        ortho: Option<&Bound<'_, PyAny>>,
        up: Option<&str>,
        background: [f64; 4],
        cull: Option<&str>,
        shading: Option<&str>,
        metallic: Option<f64>,
        roughness: Option<f64>,
        tone_map: &str,
        srgb: bool,
        interpolation: &str,
        points: Option<f32>,
        faces: bool,
        wireframe: Option<&Bound<'_, PyAny>>,
        wire_colour: Option<[f64; 4]>,
        msaa: u32,
        filter: Option<&str>,
        address: Option<&str>,
        blend: bool,
        no_skip: Vec<String>,
        count_fragments: bool,
        projection: Option<&str>,
        jitter: u32,
        backend: &str,
    ) -> PyResult<View> {
        let given = [camera.is_some(), mvp.is_some(), camera_node.is_some()];
        if given.iter().filter(|&&g| g).count() > 1 {
            return Err(error("give one camera: camera=(eye, target, up), mvp= or camera_node="));
        }
        let camera = match (camera, mvp, camera_node) {
            (Some([eye, target, up]), ..) => CameraChoice::LookAt { eye, target, up },
            (None, Some(m), _) => CameraChoice::Matrix(m),
            (None, None, Some(node)) => CameraChoice::Node(match node.extract::<usize>() {
                Ok(index) => index.to_string(),
                Err(_) => node.extract::<String>().map_err(|_| error("camera_node: give a node's index or a node's or camera's name"))?,
            }),
            (None, None, None) => CameraChoice::Framing,
        };
        // `ortho=True` frames the whole mesh; a number is the width seen (a bool is an int too).
        let ortho = match ortho {
            None => None,
            Some(o) if o.is_instance_of::<PyBool>() => o.extract::<bool>()?.then_some(None),
            Some(o) => match o.extract::<f64>() {
                Ok(w) if w > 0.0 && w.is_finite() => Some(Some(w)),
                _ => return Err(error(format!("ortho={}: give True (as wide as frames the mesh) or a positive width", o.repr()?))),
            },
        };
        let lens = Lens::of(projection, fov, ortho).map_err(frame_error)?;
        let wireframe = match wireframe {
            None => None,
            Some(w) if w.is_instance_of::<PyBool>() => w.extract::<bool>()?.then_some(LineRule::DiamondExit),
            Some(w) => Some(choice(
                "wireframe",
                &w.extract::<String>().map_err(|_| error("wireframe: give True or a rule's name"))?,
                &[("diamond-exit", LineRule::DiamondExit), ("bresenham", LineRule::Bresenham), ("rectangle", LineRule::Rectangle)],
            )?),
        };
        let no_skip: PyResult<Vec<_>> = no_skip.iter().map(|name| name.parse::<tileraster::Skip>().map_err(|e| error(format!("no_skip: {e}")))).collect();
        let options = ViewOptions {
            size: size.map(|(w, h)| [w, h]),
            camera,
            lens,
            up: up.map(|up| choice("up", up, &[("y", Up::Y), ("z", Up::Z)])).transpose()?,
            background,
            cull: cull.map(|c| choice("cull", c, &[("back", Cull::Back), ("front", Cull::Front), ("none", Cull::None)])).transpose()?,
            shading: shading.map(|s| choice("shading", s, &Shading::ALL.map(|s| (s.name(), s)))).transpose()?,
            metallic,
            roughness,
            tone_map: choice("tone_map", tone_map, &ToneMap::ALL.map(|t| (t.name(), t)))?,
            srgb,
            interpolation: choice(
                "interpolation",
                interpolation,
                &[("perspective", Interpolation::Perspective), ("screen", Interpolation::Screen), ("flat", Interpolation::Flat)],
            )?,
            points,
            faces,
            wireframe,
            wire_colour,
            msaa,
            filter: filter
                .map(|f| choice("filter", f, &[("nearest", Filter::Nearest), ("bilinear", Filter::Bilinear), ("trilinear", Filter::Trilinear)]))
                .transpose()?,
            address: address
                .map(|a| choice("address", a, &[("repeat", Address::Repeat), ("clamp", Address::ClampToEdge), ("mirror", Address::MirroredRepeat)]))
                .transpose()?,
            blend,
            no_skip: no_skip?,
            jitter,
            return_depth: true,
            count_fragments,
            count_tiles: false,
        };
        let backend = choice("backend", backend, &[("cpu", Some(Backend::Cpu)), ("gpu", Some(Backend::Gpu)), ("auto", None)])?;
        Ok(View { options, backend })
    }
}

/// The backend for a frame of `params`' size: `auto` (`None`) decides without opening a device.
fn backend_for(backend: Option<Backend>, params: &RenderParams) -> Backend {
    backend.unwrap_or_else(|| tileraster::choose_backend(params.width as u64 * params.height as u64).backend)
}

/// Where `mesh` comes from: a path, or a `Mesh`.
fn source_of(mesh: &Bound<'_, PyAny>) -> PyResult<MeshSource> {
    if let Ok(m) = mesh.cast::<Mesh>() {
        return Ok(MeshSource::Mesh(m.get().mesh.as_ref().clone()));
    }
    mesh.extract::<PathBuf>()
        .map(MeshSource::File)
        .map_err(|_| error(format!("mesh: {} is neither a path nor a tileraster.Mesh", mesh.get_type().name().map_or("this".into(), |n| n.to_string()))))
}

/// A frame as Python takes it: (width, height, colour as u32 RGBA words, depth, ids, stats as
/// JSON, checksums as JSON), the layers handed over, not copied.
type FrameTuple<'py> = (u32, u32, Bound<'py, PyArray1<u32>>, Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<u32>>, String, String);

fn frame_tuple(py: Python<'_>, frame: Frame) -> FrameTuple<'_> {
    let (stats, checksums) = (frame.stats.to_json(), frame.checksums().to_json());
    (frame.width, frame.height, frame.colour.into_pyarray(py), frame.depth.into_pyarray(py), frame.ids.into_pyarray(py), stats, checksums)
}

/// One frame of `mesh` (a path or a `Mesh`), as `tileraster render` with the same options draws it.
#[pyfunction]
#[pyo3(signature = (mesh, view, *, time = None, z_scale = 1.0, instances = None))]
pub(crate) fn render<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyAny>,
    view: &View,
    time: Option<f64>,
    z_scale: f64,
    instances: Option<Vec<[[f64; 4]; 4]>>,
) -> PyResult<FrameTuple<'py>> {
    let source = source_of(mesh)?;
    let options = ModelOptions { time, z_scale, instances, points: view.options.points.is_some() };
    let (view_options, backend) = (view.options.clone(), view.backend);
    let frame = interruptible(py, move |_| -> Result<Frame, FrameError> {
        let model = Model::load(source, &options)?;
        let params = model.params(&view_options)?;
        let backend = backend_for(backend, &params);
        model.draw(&view_options, &mut |params| render_world(model.world(), params, backend))
    })?
    .map_err(frame_error)?;
    Ok(frame_tuple(py, frame))
}

/// One mesh kept for many frames: read, posed and prepared once.
#[pyclass(frozen, module = "tileraster._native")]
pub(crate) struct Renderer {
    inner: Arc<Mutex<PreparedModel>>,
}

#[pymethods]
impl Renderer {
    #[new]
    #[pyo3(signature = (mesh, *, time = None, z_scale = 1.0, instances = None, points = false))]
    fn new(
        py: Python<'_>,
        mesh: &Bound<'_, PyAny>,
        time: Option<f64>,
        z_scale: f64,
        instances: Option<Vec<[[f64; 4]; 4]>>,
        points: bool,
    ) -> PyResult<Renderer> {
        let source = source_of(mesh)?;
        let options = ModelOptions { time, z_scale, instances, points };
        let prepared = interruptible(py, move |_| Model::load(source, &options)?.prepare())?.map_err(frame_error)?;
        Ok(Renderer { inner: Arc::new(Mutex::new(prepared)) })
    }

    /// The lowest and highest corners of the box holding what the frames draw.
    #[getter]
    fn bounds(&self) -> [[f64; 3]; 2] {
        self.inner.lock().unwrap_or_else(|e| e.into_inner()).bounds()
    }

    /// One frame as `view` says, without the GIL.
    fn render<'py>(&self, py: Python<'py>, view: &View) -> PyResult<FrameTuple<'py>> {
        let inner = self.inner.clone();
        let (options, backend) = (view.options.clone(), view.backend);
        let frame = interruptible(py, move |_| {
            let mut prepared = inner.lock().unwrap_or_else(|e| e.into_inner());
            // `auto` decides by the frame's size, which the options settle.
            let chosen = backend_for(backend, &prepared.params(&options)?);
            let mut frame = Frame::default();
            prepared.render_view(&options, chosen, &mut frame)?;
            Ok::<_, FrameError>(frame)
        })?
        .map_err(frame_error)?;
        Ok(frame_tuple(py, frame))
    }
}

/// Register the rendering classes and functions.
pub(crate) fn register(module: &Bound<'_, PyModule>) -> PyResult<()> {
    module.add_class::<Mesh>()?;
    module.add_class::<View>()?;
    module.add_class::<Renderer>()?;
    module.add_function(wrap_pyfunction!(render, module)?)?;
    Ok(())
}
