//! Bad input as typed errors before any stage runs: a frame's size and choices, a mesh's
//! indices, coordinates and attributes.

use super::params::{AlphaMode, MAX_POINT_SIZE, MAX_RENDER_DIM, MIN_POINT_SIZE, Mesh, RenderParams};
use crate::Error;
use tileraster_kernels::abi::NO_TEXTURE;

/// The frame's size and matrices.
pub(super) fn validate_params(params: &RenderParams) -> Result<(), Error> {
    let (w, h) = (params.width, params.height);
    if w == 0 || h == 0 {
        return Err(Error::ZeroSizedRaster { width: w as u64, height: h as u64 });
    }
    if w > MAX_RENDER_DIM || h > MAX_RENDER_DIM {
        return Err(Error::RasterTooLarge { width: w as u64, height: h as u64, reason: format!("a frame is at most {MAX_RENDER_DIM} pixels wide and high") });
    }
    match params.points {
        Some(size) if !(MIN_POINT_SIZE..=MAX_POINT_SIZE).contains(&size) => {
            return Err(Error::InvalidPointSize { size });
        }
        None if !params.faces && params.wireframe.is_none() => return Err(Error::NothingToDraw),
        _ => {}
    }
    if ![1, 4, 8].contains(&params.samples) {
        return Err(Error::InvalidSamples { samples: params.samples, reason: "give 1, 4 or 8 samples per pixel" });
    }
    if params.layer_sample >= params.samples.max(1) {
        return Err(Error::InvalidSamples { samples: params.samples, reason: "the layer sample must be one of the frame's samples" });
    }
    if params.samples > 1 && params.blend {
        return Err(Error::InvalidSamples { samples: params.samples, reason: "blending is drawn with one sample per pixel" });
    }
    if let Some(colour) = params.wireframe.and_then(|w| w.colour)
        && colour.iter().any(|c| !(0.0..=1.0).contains(c))
    {
        return Err(Error::InvalidColour { what: "the wireframe", colour });
    }
    for (what, value) in [("metallic factor", params.metallic), ("roughness", params.roughness)] {
        if !(0.0..=1.0).contains(&value) {
            return Err(Error::InvalidMaterial { what, value });
        }
    }
    for (name, m) in [("model", &params.model), ("view-projection", &params.view_projection)] {
        for (row, r) in m.iter().enumerate() {
            for (column, &value) in r.iter().enumerate() {
                if !value.is_finite() {
                    return Err(Error::NonFiniteMatrix { name, row, column, value });
                }
            }
        }
        if name == "model" && m[3] != [0.0, 0.0, 0.0, 1.0] {
            return Err(Error::NonAffineModel { last_row: m[3] });
        }
    }
    if let Some(t) = &params.vertex_texture {
        let texels = t.width as u64 * t.height as u64;
        if texels != t.texels.len() as u64 || texels > u32::MAX as u64 {
            return Err(Error::InvalidVertexTexture { width: t.width, height: t.height, texels: t.texels.len() });
        }
    }
    Ok(())
}

/// A mesh's positions, faces and attributes: finite, in range, one attribute per vertex.
pub fn validate_mesh(mesh: &Mesh) -> Result<(), Error> {
    if mesh.positions.is_empty() {
        return Err(Error::EmptyScene { what: "vertices" });
    }
    if mesh.triangles.is_empty() {
        return Err(Error::EmptyScene { what: "triangles" });
    }
    for (vertex, v) in mesh.positions.iter().enumerate() {
        for (axis, value) in ['x', 'y', 'z'].into_iter().zip(*v) {
            if !value.is_finite() {
                return Err(Error::NonFiniteCoordinate { vertex, axis, value });
            }
        }
    }
    let n = mesh.positions.len();
    for (triangle, tri) in mesh.triangles.iter().enumerate() {
        for (corner, &index) in tri.iter().enumerate() {
            if index as usize >= n {
                return Err(Error::IndexOutOfRange { triangle, corner, index: index as u64, vertex_count: n });
            }
        }
    }
    check_attribute("normals", mesh.normals.as_deref(), n)?;
    check_attribute("colours", mesh.colours.as_deref(), n)?;
    check_attribute("texture coordinates", mesh.uvs.as_deref(), n)?;
    for (k, texture) in mesh.textures.iter().enumerate() {
        texture.check(k)?;
    }
    if let Some(faces) = &mesh.face_textures {
        if faces.len() != mesh.triangles.len() {
            return Err(Error::FaceListLength { what: "face textures", len: faces.len(), faces: mesh.triangles.len() });
        }
        if let Some((face, &t)) = faces.iter().enumerate().find(|&(_, &t)| t != NO_TEXTURE && t as usize >= mesh.textures.len()) {
            return Err(Error::InvalidTexture {
                texture: t as usize,
                reason: format!("face {face} takes it, but the mesh has {} textures", mesh.textures.len()),
            });
        }
    }
    for (material, m) in mesh.materials.iter().enumerate() {
        let cutoff = match m.alpha {
            AlphaMode::Mask { cutoff } => cutoff,
            _ => 0.0,
        };
        for (what, value) in [("metallic factor", m.metallic), ("roughness", m.roughness)] {
            if !(0.0..=1.0).contains(&value) {
                return Err(Error::InvalidMeshMaterial { material, what, value: value as f64, range: "from 0 to 1" });
            }
        }
        if !(0.0..=1.0).contains(&m.occlusion_strength) {
            return Err(Error::InvalidMeshMaterial { material, what: "occlusion strength", value: m.occlusion_strength as f64, range: "from 0 to 1" });
        }
        if let Some((what, t)) = m.textures().into_iter().find_map(|(what, t)| t.filter(|&t| t as usize >= mesh.textures.len()).map(|t| (what, t))) {
            return Err(Error::InvalidTexture {
                texture: t as usize,
                reason: format!("material {material}'s {what} texture, but the mesh has {} textures", mesh.textures.len()),
            });
        }
        let not_negative = [("alpha cutoff", cutoff), ("emission", m.emissive[0]), ("emission", m.emissive[1]), ("emission", m.emissive[2])];
        if let Some(&(what, value)) = not_negative.iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
            return Err(Error::InvalidMeshMaterial { material, what, value: value as f64, range: "finite and not negative" });
        }
    }
    if let Some(faces) = &mesh.face_materials {
        if faces.len() != mesh.triangles.len() {
            return Err(Error::FaceListLength { what: "face materials", len: faces.len(), faces: mesh.triangles.len() });
        }
        if let Some((face, &m)) = faces.iter().enumerate().find(|&(_, &m)| m as usize >= mesh.materials.len()) {
            return Err(Error::InvalidFaceMaterial { face, material: m as usize, materials: mesh.materials.len() });
        }
    }
    Ok(())
}

fn check_attribute<const N: usize>(attribute: &'static str, values: Option<&[[f32; N]]>, vertex_count: usize) -> Result<(), Error> {
    let Some(values) = values else { return Ok(()) };
    if values.len() != vertex_count {
        return Err(Error::AttributeLength { attribute, len: values.len(), vertex_count });
    }
    for (vertex, v) in values.iter().enumerate() {
        if let Some(&value) = v.iter().find(|c| !c.is_finite()) {
            return Err(Error::NonFiniteAttribute { attribute, vertex, value: value as f64 });
        }
    }
    Ok(())
}
