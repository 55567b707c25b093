use crate::{IoError, write_atomically};
use std::io::Write as _;
use std::path::Path;
use tileraster_core::Scene;
use tileraster_core::render::{AlphaMode, Material, Mesh, NO_TEXTURE, Texture};

/// Read a Wavefront OBJ mesh: `v x y z` vertices (world x, y and height z) and `f` faces
/// (1-based or negative indices, `v/vt/vn` forms accepted; polygons are fanned into
/// triangles). Other statements are ignored.
pub fn read_obj(path: &Path) -> Result<Scene, IoError> {
    let text = std::fs::read_to_string(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    parse_obj(&text, path)
}

/// Write a mesh as OBJ: every coordinate in the shortest text that reads back to the same
/// `f64`, faces 1-based in the scene's order (face `k + 1` is owner index `k`).
pub fn write_obj(scene: &Scene, path: &Path) -> Result<(), IoError> {
    write_atomically(path, |out| {
        let e = |e: std::io::Error| e.to_string();
        writeln!(out, "# {} vertices, {} triangles", scene.vertices.len(), scene.triangles.len()).map_err(e)?;
        for [x, y, z] in &scene.vertices {
            writeln!(out, "v {x:?} {y:?} {z:?}").map_err(e)?;
        }
        for [a, b, c] in &scene.triangles {
            writeln!(out, "f {} {} {}", a + 1, b + 1, c + 1).map_err(e)?;
        }
        Ok(())
    })
}

/// Write a mesh as OBJ with a texture: its MTL file beside it (`NAME.mtl`, one material whose
/// `map_Kd` is `texture`, a path from the OBJ's folder) and texture coordinates per vertex
/// (`uvs`, `v = 0` at the image's first row; written with OBJ's `v` up).
pub fn write_obj_textured(scene: &Scene, uvs: &[[f32; 2]], texture: &str, path: &Path) -> Result<(), IoError> {
    if uvs.len() != scene.vertices.len() {
        return Err(IoError::Format { path: path.to_owned(), message: format!("{} texture coordinates for {} vertices", uvs.len(), scene.vertices.len()) });
    }
    let mtl = path.with_extension("mtl");
    let mtl_name = mtl.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    write_atomically(&mtl, |out| writeln!(out, "newmtl textured\nKd 1 1 1\nmap_Kd {texture}").map_err(|e| e.to_string()))?;
    write_atomically(path, |out| {
        let e = |e: std::io::Error| e.to_string();
        writeln!(out, "# {} vertices, {} triangles\nmtllib {mtl_name}\nusemtl textured", scene.vertices.len(), scene.triangles.len()).map_err(e)?;
        for [x, y, z] in &scene.vertices {
            writeln!(out, "v {x:?} {y:?} {z:?}").map_err(e)?;
        }
        for [u, v] in uvs {
            writeln!(out, "vt {u:?} {:?}", 1.0 - v).map_err(e)?;
        }
        for [a, b, c] in &scene.triangles {
            writeln!(out, "f {0}/{0} {1}/{1} {2}/{2}", a + 1, b + 1, c + 1).map_err(e)?;
        }
        Ok(())
    })
}

/// Parse OBJ text; `path` only names the source in errors.
pub fn parse_obj(text: &str, path: &Path) -> Result<Scene, IoError> {
    let err = |line: usize, message: String| IoError::Parse { path: path.to_owned(), line, message };
    let mut scene = Scene::default();
    for (n, raw) in text.lines().enumerate() {
        let line_no = n + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut xyz = [0.0f64; 3];
                for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                    let word = words.next().ok_or_else(|| err(line_no, format!("vertex has no {axis} coordinate; expected `v x y z`")))?;
                    xyz[k] = word.parse().map_err(|_| err(line_no, format!("vertex {axis} coordinate {word:?} is not a number")))?;
                    if !xyz[k].is_finite() {
                        return Err(err(line_no, format!("vertex {axis} coordinate {word:?} is not finite")));
                    }
                }
                scene.vertices.push(xyz);
            }
            Some("f") => {
                let count = scene.vertices.len();
                let corners =
                    words
                        .map(|w| resolve_index(w.split('/').next().unwrap_or(""), count, "vertex").map_err(|m| err(line_no, m)))
                        .collect::<Result<Vec<u32>, IoError>>()?;
                if corners.len() < 3 {
                    return Err(err(line_no, format!("face has {} corners; a face needs at least 3", corners.len())));
                }
                for k in 1..corners.len() - 1 {
                    scene.triangles.push([corners[0], corners[k], corners[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if scene.vertices.is_empty() || scene.triangles.is_empty() {
        return Err(IoError::Format {
            path: path.to_owned(),
            message: format!("no mesh: {} vertices and {} faces found; expected `v x y z` and `f a b c` lines", scene.vertices.len(), scene.triangles.len()),
        });
    }
    Ok(scene)
}

/// An OBJ index (1-based, or negative from the last defined) into `count` defined items.
fn resolve_index(word: &str, count: usize, what: &str) -> Result<u32, String> {
    let i: i64 = word.parse().map_err(|_| format!("face {what} index {word:?} is not an integer"))?;
    let resolved = if i > 0 { i - 1 } else { count as i64 + i };
    if i == 0 || resolved < 0 || resolved >= count as i64 {
        return Err(format!("face {what} index {i} is out of range: {count} are defined before this line"));
    }
    Ok(resolved as u32)
}

/// Read an OBJ mesh with its normals (`vn`), texture coordinates (`vt`, `v` flipped to the
/// image's row order), and its materials' (`mtllib`, `usemtl`) diffuse colours (`Kd`, with `d`
/// as alpha) and textures (`map_Kd`: PNG or JPEG, sRGB, trilinear, repeated): a vertex for each
/// distinct corner (position, normal, texture coordinates, material), faces fanned into
/// triangles in file order, as [`read_obj`] does.
pub fn read_obj_mesh(path: &Path) -> Result<Mesh, IoError> {
    let text = std::fs::read_to_string(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    let folder = path.parent().unwrap_or(Path::new("."));
    let materials = |name: &str| {
        let mtl = local_path(folder, name);
        std::fs::read_to_string(&mtl).map_err(|source| IoError::Io { path: mtl, source })
    };
    parse_obj_mesh(&text, path, &materials, &|name| read_texture(&local_path(folder, name)))
}

/// An image file (PNG or JPEG) as an sRGB base-colour texture, trilinear and repeated.
pub fn read_texture(path: &Path) -> Result<Texture, IoError> {
    let image = image::open(path).map_err(|e| IoError::Format { path: path.to_owned(), message: format!("not a readable PNG or JPEG image: {e}") })?.to_rgba8();
    Ok(Texture::srgb(image.width(), image.height(), image.into_raw()))
}

/// Parse OBJ text with its attributes; `materials` reads a `mtllib` file by name, `images` a
/// `map_Kd` texture by its path from the OBJ's folder.
pub fn parse_obj_mesh(
    text: &str,
    path: &Path,
    materials: &dyn Fn(&str) -> Result<String, IoError>,
    images: &dyn Fn(&str) -> Result<Texture, IoError>,
) -> Result<Mesh, IoError> {
    let err = |line: usize, message: String| IoError::Parse { path: path.to_owned(), line, message };
    let (mut positions, mut normals, mut uvs) = (Vec::<[f64; 3]>::new(), Vec::<[f32; 3]>::new(), Vec::<[f32; 2]>::new());
    let mut colours: std::collections::HashMap<String, MtlMaterial> = Default::default();
    let mut material: Option<[f32; 4]> = None;
    // The current material's texture (an index into the mesh's), and the textures by path.
    let mut texture = NO_TEXTURE;
    let mut texture_of: std::collections::HashMap<String, u32> = Default::default();
    let mut face_textures = Vec::new();
    // The current material (an index into the mesh's), the materials by name, and each face's.
    let mut surface: Option<u32> = None;
    let mut surface_of: std::collections::HashMap<String, u32> = Default::default();
    let mut face_surfaces: Vec<Option<u32>> = Vec::new();
    let mut texture_at = |file: &str, mesh: &mut Mesh| -> Result<u32, IoError> {
        if let Some(&k) = texture_of.get(file) {
            return Ok(k);
        }
        mesh.textures.push(images(file)?);
        let k = mesh.textures.len() as u32 - 1;
        texture_of.insert(file.to_owned(), k);
        Ok(k)
    };
    let mut corners: std::collections::HashMap<(u32, u32, u32, [u32; 4]), u32> = Default::default();
    let mut mesh = Mesh::default();
    let (mut out_normals, mut out_uvs, mut out_colours) = (Vec::new(), Vec::new(), Vec::new());
    let (mut any_normal, mut all_normals, mut any_uv, mut any_colour) = (false, true, false, false);
    let numbers = |words: &mut std::str::SplitWhitespace, n: usize, line: usize, what: &str| -> Result<Vec<f64>, IoError> {
        let values: Vec<f64> =
            words.take(n).map(|w| w.parse::<f64>().map_err(|_| err(line, format!("{what} value {w:?} is not a number")))).collect::<Result<_, _>>()?;
        if values.len() < n || values.iter().any(|v| !v.is_finite()) {
            return Err(err(line, format!("{what} needs {n} finite numbers")));
        }
        Ok(values)
    };
    for (n, raw) in text.lines().enumerate() {
        let line_no = n + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let v = numbers(&mut words, 3, line_no, "vertex")?;
                positions.push([v[0], v[1], v[2]]);
            }
            Some("vn") => {
                let v = numbers(&mut words, 3, line_no, "normal")?;
                normals.push([v[0] as f32, v[1] as f32, v[2] as f32]);
            }
            Some("vt") => {
                let v = numbers(&mut words, 2, line_no, "texture coordinate")?;
                // OBJ's v runs up from the image's last row; the mesh's from its first.
                uvs.push([v[0] as f32, (1.0 - v[1]) as f32]);
            }
            Some("mtllib") => {
                for name in words {
                    let mtl = materials(name)?;
                    // Its textures' paths are from its own folder (Windows tools separate with backslashes).
                    let unix = name.replace('\\', "/");
                    let folder = Path::new(&unix).parent().unwrap_or(Path::new(""));
                    parse_mtl(&mtl, folder, &mut colours);
                }
            }
            Some("usemtl") => {
                let name = words.next().unwrap_or("");
                let m = colours.get(name).ok_or_else(|| err(line_no, format!("material {name:?} is not defined in any mtllib file")))?;
                material = Some(m.colour);
                any_colour = true;
                texture = match &m.texture {
                    None => NO_TEXTURE,
                    Some(file) => texture_at(file, &mut mesh)?,
                };
                surface = Some(match surface_of.get(name) {
                    Some(&k) => k,
                    None => {
                        let emissive_texture = m.emissive_texture.as_deref().map(|file| texture_at(file, &mut mesh)).transpose()?;
                        mesh.materials.push(Material { emissive_texture, ..m.surface() });
                        let k = mesh.materials.len() as u32 - 1;
                        surface_of.insert(name.to_owned(), k);
                        k
                    }
                });
            }
            Some("f") => {
                let resolve = |w: &str, count: usize, what: &str| resolve_index(w, count, what).map_err(|m| err(line_no, m));
                let mut ids = Vec::new();
                for w in words {
                    let mut parts = w.split('/');
                    let v = resolve(parts.next().unwrap_or(""), positions.len(), "vertex")?;
                    let t = match parts.next() {
                        Some(t) if !t.is_empty() => resolve(t, uvs.len(), "texture coordinate")?,
                        _ => u32::MAX,
                    };
                    let vn = match parts.next() {
                        Some(t) if !t.is_empty() => resolve(t, normals.len(), "normal")?,
                        _ => u32::MAX,
                    };
                    let colour = material.unwrap_or([0.8, 0.8, 0.8, 1.0]);
                    let key = (v, t, vn, colour.map(f32::to_bits));
                    let next = mesh.positions.len() as u32;
                    let id = *corners.entry(key).or_insert_with(|| {
                        mesh.positions.push(positions[v as usize]);
                        any_normal |= vn != u32::MAX;
                        all_normals &= vn != u32::MAX;
                        any_uv |= t != u32::MAX;
                        out_normals.push(if vn == u32::MAX { [0.0; 3] } else { normals[vn as usize] });
                        out_uvs.push(if t == u32::MAX { [0.0; 2] } else { uvs[t as usize] });
                        out_colours.push(colour);
                        next
                    });
                    ids.push(id);
                }
                if ids.len() < 3 {
                    return Err(err(line_no, format!("face has {} corners; a face needs at least 3", ids.len())));
                }
                mesh.triangles.extend((1..ids.len() - 1).map(|k| [ids[0], ids[k], ids[k + 1]]));
                face_textures.resize(mesh.triangles.len(), texture);
                face_surfaces.resize(mesh.triangles.len(), surface);
            }
            _ => {}
        }
    }
    if mesh.triangles.is_empty() {
        return Err(IoError::Format {
            path: path.to_owned(),
            message: format!("no mesh: {} vertices and no faces found; expected `v x y z` and `f a b c` lines", positions.len()),
        });
    }
    mesh.normals = (any_normal && all_normals).then_some(out_normals);
    mesh.uvs = any_uv.then_some(out_uvs);
    mesh.colours = any_colour.then_some(out_colours);
    mesh.face_textures = (!mesh.textures.is_empty()).then_some(face_textures);
    // Faces before any `usemtl` take MTL's default surface.
    if !mesh.materials.is_empty() {
        let default = mesh.materials.len() as u32;
        if face_surfaces.iter().any(Option::is_none) {
            mesh.materials.push(MtlMaterial::default().surface());
        }
        mesh.face_materials = Some(face_surfaces.iter().map(|s| s.unwrap_or(default)).collect());
    }
    Ok(mesh)
}

/// `name`, a path from `folder` as an OBJ or MTL file names it: as it is where that file
/// exists, else with its backslashes read as separators (Windows tools write `.\tex.jpg`).
fn local_path(folder: &Path, name: &str) -> std::path::PathBuf {
    let literal = folder.join(name);
    if literal.exists() || !name.contains('\\') {
        return literal;
    }
    folder.join(name.replace('\\', "/"))
}

/// An MTL material: its diffuse colour (`Kd`, with `d` or `1 − Tr` as alpha) and texture
/// (`map_Kd`, a path from the OBJ's folder), its specular colour (`Ks`) and exponent (`Ns`),
/// its emission (`Ke`, `map_Ke`).
struct MtlMaterial {
    colour: [f32; 4],
    texture: Option<String>,
    specular: [f32; 3],
    shininess: f32,
    emissive: [f32; 3],
    emissive_texture: Option<String>,
}

impl Default for MtlMaterial {
    fn default() -> MtlMaterial {
        MtlMaterial { colour: [0.8, 0.8, 0.8, 1.0], texture: None, specular: [0.0; 3], shininess: 0.0, emissive: [0.0; 3], emissive_texture: None }
    }
}

impl MtlMaterial {
    /// Its metallic-roughness surface as the common converters (obj2gltf) map Blinn-Phong:
    /// not metallic; roughness `1 − Ns/1000` clamped to `[0, 1]`, and times `1 − I` where the
    /// specular colour's luminance `I` is below 0.1 (a dim highlight is a rough surface); a
    /// dissolved one (alpha below 1) blended and double-sided; its emission.
    fn surface(&self) -> Material {
        let [r, g, b] = self.specular;
        let intensity = 0.2125 * r + 0.7154 * g + 0.0721 * b;
        let mut roughness = (1.0 - self.shininess / 1000.0).clamp(0.0, 1.0);
        if intensity < 0.1 {
            roughness *= 1.0 - intensity.max(0.0);
        }
        let dissolved = self.colour[3] < 1.0;
        Material {
            metallic: 0.0,
            roughness,
            double_sided: dissolved,
            alpha: if dissolved { AlphaMode::Blend } else { AlphaMode::Opaque },
            emissive: self.emissive.map(|e| e.max(0.0)),
            ..Material::PLAIN
        }
    }
}

/// An MTL file's materials ([`MtlMaterial`]), textures from the MTL's `folder` (the last word
/// of `map_Kd` and `map_Ke`).
fn parse_mtl(text: &str, folder: &Path, colours: &mut std::collections::HashMap<String, MtlMaterial>) {
    let mut current: Option<String> = None;
    for raw in text.lines() {
        let mut words = raw.split('#').next().unwrap_or("").split_whitespace();
        let number = |w: Option<&str>| w.and_then(|w| w.parse::<f32>().ok()).filter(|v| v.is_finite());
        match words.next() {
            Some("newmtl") => {
                let name = words.next().unwrap_or("").to_string();
                colours.insert(name.clone(), MtlMaterial::default());
                current = Some(name);
            }
            Some("Kd") => {
                if let (Some(name), Some(r), Some(g), Some(b)) = (&current, number(words.next()), number(words.next()), number(words.next())) {
                    let c = &mut colours.get_mut(name).expect("inserted at newmtl").colour;
                    (c[0], c[1], c[2]) = (r, g, b);
                }
            }
            Some("d") => {
                if let (Some(name), Some(a)) = (&current, number(words.next())) {
                    colours.get_mut(name).expect("inserted at newmtl").colour[3] = a.clamp(0.0, 1.0);
                }
            }
            Some("Tr") => {
                if let (Some(name), Some(t)) = (&current, number(words.next())) {
                    colours.get_mut(name).expect("inserted at newmtl").colour[3] = (1.0 - t).clamp(0.0, 1.0);
                }
            }
            Some(key @ ("Ks" | "Ke")) => {
                if let (Some(name), Some(r), Some(g), Some(b)) = (&current, number(words.next()), number(words.next()), number(words.next())) {
                    let m = colours.get_mut(name).expect("inserted at newmtl");
                    *(if key == "Ks" { &mut m.specular } else { &mut m.emissive }) = [r, g, b];
                }
            }
            Some("Ns") => {
                if let (Some(name), Some(n)) = (&current, number(words.next())) {
                    colours.get_mut(name).expect("inserted at newmtl").shininess = n;
                }
            }
            Some("map_Ke") => {
                if let (Some(name), Some(file)) = (&current, words.last()) {
                    colours.get_mut(name).expect("inserted at newmtl").emissive_texture = Some(folder.join(file).to_string_lossy().into_owned());
                }
            }
            Some("map_Kd") => {
                if let (Some(name), Some(file)) = (&current, words.last()) {
                    colours.get_mut(name).expect("inserted at newmtl").texture = Some(folder.join(file).to_string_lossy().into_owned());
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_vertices_faces_and_polygons() {
        let s = parse_obj("# c\nv 0 0 1\nv 1 0 2\nv 1 1 3\nv 0 1 4\nf 1/1/1 2 3 4\nf -1 -2 -3\n", Path::new("m.obj")).unwrap();
        assert_eq!(s.vertices.len(), 4);
        assert_eq!(s.triangles, vec![[0, 1, 2], [0, 2, 3], [3, 2, 1]]);
    }

    #[test]
    fn attributes_and_materials_are_read_per_corner() {
        let mtl = "newmtl red\nKd 1 0 0\nd 0.5\nnewmtl blue\nKd 0 0 1\n";
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nusemtl red\nf 1//1 2//1 3//1\nusemtl blue\nf 1//1 3//1 4//1\n";
        let mesh = parse_obj_mesh(
            obj,
            Path::new("m.obj"),
            &|name| {
                assert_eq!(name, "m.mtl");
                Ok(mtl.to_string())
            },
            &|_| unreachable!("no textures"),
        )
        .unwrap();
        // Corners 1 and 3 carry both materials: each becomes two vertices.
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(mesh.positions[3], [0.0, 0.0, 0.0]);
        assert_eq!(mesh.colours.as_ref().unwrap()[0], [1.0, 0.0, 0.0, 0.5]);
        assert_eq!(mesh.colours.as_ref().unwrap()[5], [0.0, 0.0, 1.0, 1.0]);
        assert_eq!(mesh.normals.unwrap(), vec![[0.0, 0.0, 1.0]; 6]);
        assert!(mesh.uvs.is_none());
        let e = parse_obj_mesh("v 0 0 0\nusemtl missing\n", Path::new("m.obj"), &|_| unreachable!(), &|_| unreachable!()).unwrap_err().to_string();
        assert!(e.starts_with("m.obj:2:") && e.contains("\"missing\""), "{e}");
        let e =
            parse_obj_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//2 2 3\n", Path::new("m.obj"), &|_| unreachable!(), &|_| unreachable!()).unwrap_err().to_string();
        assert!(e.starts_with("m.obj:4:") && e.contains("normal index 2 is out of range"), "{e}");
    }

    /// MTL's Blinn-Phong materials as metallic-roughness ones, as obj2gltf maps them: `Ns` and
    /// `Ks` to roughness, `d` (or `Tr`) below 1 blended and double-sided, `Ke` and `map_Ke` to
    /// emission; each face its `usemtl`'s, the faces before any the default material's.
    #[test]
    fn mtl_materials_map_to_metallic_roughness() {
        let mtl = "newmtl shiny\nKs 1 1 1\nNs 250\nnewmtl dim\nKs 0.05 0.05 0.05\nNs 500\nTr 0.25\nKe 0.5 0.25 0\nmap_Ke glow.png\n";
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nusemtl shiny\nf 1 3 4\nusemtl dim\nf 1 2 4\nusemtl shiny\nf 2 3 4\n";
        let texture = Texture::srgb(1, 1, vec![255; 4]);
        let mesh = parse_obj_mesh(obj, Path::new("m.obj"), &|_| Ok(mtl.to_string()), &|file| {
            assert_eq!(file, "glow.png");
            Ok(texture.clone())
        })
        .unwrap();
        let [shiny, dim, default] = [&mesh.materials[0], &mesh.materials[1], &mesh.materials[2]];
        assert_eq!((shiny.metallic, shiny.roughness, shiny.alpha, shiny.double_sided), (0.0, 0.75, AlphaMode::Opaque, false));
        // A dim highlight roughens: (1 − 0.5)·(1 − 0.05).
        assert!((dim.roughness - 0.5 * 0.95).abs() < 1e-6, "{}", dim.roughness);
        assert_eq!((dim.alpha, dim.double_sided, dim.emissive, dim.emissive_texture), (AlphaMode::Blend, true, [0.5, 0.25, 0.0], Some(0)));
        assert_eq!((default.roughness, default.alpha), (1.0, AlphaMode::Opaque));
        assert_eq!(mesh.face_materials, Some(vec![2, 0, 1, 0]));
        assert_eq!(mesh.colours.as_ref().unwrap()[mesh.triangles[2][0] as usize][3], 0.75, "1 − Tr as the colour's alpha");
    }

    /// `map_Kd` textures: loaded once per file, from the MTL's folder, each face taking its
    /// material's (or none); `vt`'s v flipped to the image's row order.
    #[test]
    fn materials_textures_are_loaded_once_and_taken_per_face() {
        let mtl = "newmtl brick\nKd 1 1 1\nmap_Kd -s 2 2 1 tex/brick.png\nnewmtl plain\nKd 0 1 0\nnewmtl wall\nmap_Kd tex/brick.png\n";
        let obj = "mtllib mats/m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0.25\nvt 1 1\nusemtl brick\nf 1/1 2/2 3/3\nusemtl plain\nf 1 2 3\nusemtl wall\nf 1/1 2/2 3/3\n";
        let loads = std::cell::Cell::new(0);
        let mesh = parse_obj_mesh(obj, Path::new("m.obj"), &|_| Ok(mtl.to_string()), &|name| {
            assert_eq!(Path::new(name), Path::new("mats/tex/brick.png"));
            loads.set(loads.get() + 1);
            Ok(Texture::srgb(1, 1, vec![9, 9, 9, 255]))
        })
        .unwrap();
        assert_eq!(loads.get(), 1);
        assert_eq!(mesh.textures.len(), 1);
        assert_eq!(mesh.face_textures, Some(vec![0, NO_TEXTURE, 0]));
        assert_eq!(mesh.uvs.as_ref().unwrap()[1], [1.0, 0.75]);
        let e = parse_obj_mesh(obj, Path::new("m.obj"), &|_| Ok(mtl.to_string()), &|name| Err(IoError::Format { path: name.into(), message: "broken".into() }))
            .unwrap_err()
            .to_string();
        assert!(e.contains("brick.png") && e.contains("broken"), "{e}");
    }

    /// Paths written by Windows tools (`mtllib models\m.mtl`, `map_Kd .\tex.png`) are found
    /// with their backslashes read as separators.
    #[test]
    fn windows_paths_in_obj_and_mtl_files_are_found() {
        let dir = std::env::temp_dir().join(format!("tileraster-obj-windows-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("models")).unwrap();
        image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 10, 10, 255])).save(dir.join("models").join("tex.png")).unwrap();
        std::fs::write(dir.join("models").join("m.mtl"), "newmtl red\r\nKd 1 1 1\r\nmap_Kd .\\tex.png\r\n").unwrap();
        let obj = "mtllib models\\m.mtl\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nvt 0 0\r\nvt 1 0\r\nvt 0 1\r\nusemtl red\r\nf 1/1 2/2 3/3\r\n";
        std::fs::write(dir.join("w.obj"), obj).unwrap();
        let mesh = read_obj_mesh(&dir.join("w.obj")).unwrap();
        assert_eq!((mesh.textures.len(), mesh.triangles.len()), (1, 1));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn reports_line_and_problem() {
        let e = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", Path::new("m.obj")).unwrap_err().to_string();
        assert!(e.starts_with("m.obj:4:") && e.contains("out of range"), "{e}");
        let e = parse_obj("v 0 zero 0\n", Path::new("m.obj")).unwrap_err().to_string();
        assert!(e.contains("m.obj:1:") && e.contains("not a number"), "{e}");
        let e = parse_obj("", Path::new("m.obj")).unwrap_err().to_string();
        assert!(e.contains("no mesh"), "{e}");
    }

    #[test]
    fn written_meshes_read_back_bit_for_bit() {
        let scene = Scene::new(vec![[500_000.1, 5e6 + 1.0 / 3.0, -0.0], [1e-300, 2.5, f64::MAX], [7.0, 8.0, 9.125]], vec![[0, 1, 2], [2, 1, 0]]);
        let path = std::env::temp_dir().join(format!("tileraster-obj-{}.obj", std::process::id()));
        write_obj(&scene, &path).unwrap();
        let back = read_obj(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(back.triangles, scene.triangles);
        let bits = |s: &Scene| s.vertices.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&scene));
    }
}
