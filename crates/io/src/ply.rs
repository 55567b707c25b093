//! PLY meshes: ASCII, binary little-endian and binary big-endian. The `vertex` element's `x`,
//! `y`, `z` properties (any numeric type), its normals (`nx`, `ny`, `nz`) and colours (`red`,
//! `green`, `blue`, optionally `alpha`: integers scaled from their type's range, floats as they
//! are) where present, and the `face` element's index list (`vertex_indices` or `vertex_index`)
//! are read; polygons are fanned into triangles. A `tristrips` element's lists (as some scanners
//! write their faces) are triangle strips, `-1` ending each strip. Other elements and properties
//! are skipped.
//! Errors name the line (ASCII) or the element record (binary).

use crate::IoError;
use std::path::Path;
use tileraster_core::Scene;
use tileraster_core::render::Mesh;

/// Read a PLY mesh's positions and faces.
pub fn read_ply(path: &Path) -> Result<Scene, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    parse_ply(&bytes, path)
}

/// Read a PLY mesh with its vertex normals and colours.
pub fn read_ply_mesh(path: &Path) -> Result<Mesh, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    parse_ply_mesh(&bytes, path)
}

/// Parse PLY bytes' positions and faces; `path` only names the source in errors.
pub fn parse_ply(bytes: &[u8], path: &Path) -> Result<Scene, IoError> {
    let mesh = parse_ply_mesh(bytes, path)?;
    Ok(Scene::new(mesh.positions, mesh.triangles))
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

#[derive(Clone, Copy)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// The largest value of an integer type, by which colours of that type are scaled to
    /// `[0, 1]`; 1 for floats.
    fn unit(self) -> f64 {
        match self {
            Scalar::I8 => i8::MAX as f64,
            Scalar::U8 => u8::MAX as f64,
            Scalar::I16 => i16::MAX as f64,
            Scalar::U16 => u16::MAX as f64,
            Scalar::I32 => i32::MAX as f64,
            Scalar::U32 => u32::MAX as f64,
            Scalar::F32 | Scalar::F64 => 1.0,
        }
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn read(self, b: &[u8], format: Format) -> f64 {
        macro_rules! num {
            ($t:ty) => {{
                let a = b[..std::mem::size_of::<$t>()].try_into().expect("sized");
                (if format == Format::Big { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }) as f64
            }};
        }
        match self {
            Scalar::I8 => num!(i8),
            Scalar::U8 => num!(u8),
            Scalar::I16 => num!(i16),
            Scalar::U16 => num!(u16),
            Scalar::I32 => num!(i32),
            Scalar::U32 => num!(u32),
            Scalar::F32 => num!(f32),
            Scalar::F64 => num!(f64),
        }
    }
}

enum Property {
    Scalar(String, Scalar),
    List(String, Scalar, Scalar),
}

struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

/// Parse PLY bytes with vertex normals and colours; `path` only names the source in errors.
pub fn parse_ply_mesh(bytes: &[u8], path: &Path) -> Result<Mesh, IoError> {
    let format_err = |message: String| IoError::Format { path: path.to_owned(), message };
    let line_err = |line: usize, message: String| IoError::Parse { path: path.to_owned(), line, message };
    // The header: text lines up to `end_header`.
    let end = bytes.windows(10).position(|w| w == b"end_header").ok_or_else(|| format_err("no 'end_header': not a PLY file".into()))?;
    let body_start = bytes[end..].iter().position(|&b| b == b'\n').map(|k| end + k + 1).unwrap_or(bytes.len());
    let header = std::str::from_utf8(&bytes[..end]).map_err(|e| format_err(format!("the PLY header is not text: {e}")))?;
    let mut lines = header.lines().enumerate().map(|(k, l)| (k + 1, l.trim()));
    if lines.next().map(|(_, l)| l) != Some("ply") {
        return Err(format_err("the file does not start with 'ply'".into()));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (no, line) in lines {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["format", f, _version] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    other => return Err(line_err(no, format!("unsupported PLY format '{other}'"))),
                })
            }
            ["element", name, count] => {
                let count = count.parse().map_err(|_| line_err(no, format!("element count '{count}' is not a number")))?;
                elements.push(Element { name: name.to_string(), count, properties: Vec::new() });
            }
            ["property", "list", count_type, item_type, name] => {
                let scalar = |t: &str| Scalar::parse(t).ok_or_else(|| line_err(no, format!("unknown property type '{t}'")));
                let element = elements.last_mut().ok_or_else(|| line_err(no, "property before any element".into()))?;
                element.properties.push(Property::List(name.to_string(), scalar(count_type)?, scalar(item_type)?));
            }
            ["property", kind, name] => {
                let scalar = Scalar::parse(kind).ok_or_else(|| line_err(no, format!("unknown property type '{kind}'")))?;
                let element = elements.last_mut().ok_or_else(|| line_err(no, "property before any element".into()))?;
                element.properties.push(Property::Scalar(name.to_string(), scalar));
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            _ => return Err(line_err(no, format!("unexpected header line '{line}'"))),
        }
    }
    let format = format.ok_or_else(|| format_err("the header has no 'format' line".into()))?;
    let header_lines = header.lines().count() + 1;

    let mut reader = Body { bytes: &bytes[body_start..], at: 0, format, line: header_lines, words: Vec::new() };
    let mut scene = Scene::default();
    let (mut normals, mut colours) = (Vec::new(), Vec::new());
    let (mut has_normals, mut has_colours) = (false, false);
    for element in &elements {
        let is_vertex = element.name == "vertex";
        let axis = |name: &str| element.properties.iter().position(|p| matches!(p, Property::Scalar(n, _) if n == name));
        let xyz = if is_vertex {
            let found = [axis("x"), axis("y"), axis("z")];
            if let Some(missing) = found.iter().position(Option::is_none) {
                return Err(format_err(format!("the vertex element has no '{}' property", ["x", "y", "z"][missing])));
            }
            found.map(|k| k.expect("checked"))
        } else {
            [usize::MAX; 3]
        };
        // Optional attributes: all three normal components, or all three colour channels.
        let all = |names: &[&str]| -> Option<Vec<usize>> { if is_vertex { names.iter().map(|n| axis(n)).collect() } else { None } };
        let normal = all(&["nx", "ny", "nz"]);
        let colour = all(&["red", "green", "blue"]).map(|mut c| {
            c.extend(axis("alpha"));
            c
        });
        has_normals |= normal.is_some();
        has_colours |= colour.is_some();
        let faces = matches!(element.name.as_str(), "face" | "tristrips");
        let face_list = faces
            .then(|| element.properties.iter().position(|p| matches!(p, Property::List(n, _, _) if n == "vertex_indices" || n == "vertex_index")))
            .flatten();
        if faces && face_list.is_none() {
            return Err(format_err(format!("the {} element has no 'vertex_indices' list", element.name)));
        }
        let strips = element.name == "tristrips";
        for record in 0..element.count {
            reader.start_record().map_err(|m| reader.error(path, &element.name, record, m))?;
            let mut v = [0.0; 3];
            let (mut n, mut c) = ([0.0f32; 3], [1.0f32; 4]);
            for (k, property) in element.properties.iter().enumerate() {
                match property {
                    Property::Scalar(_, t) => {
                        let value = reader.scalar(*t).map_err(|m| reader.error(path, &element.name, record, m))?;
                        if let Some(a) = xyz.iter().position(|&p| p == k) {
                            v[a] = value;
                        }
                        if let Some(a) = normal.as_ref().and_then(|p| p.iter().position(|&p| p == k)) {
                            n[a] = value as f32;
                        }
                        if let Some(a) = colour.as_ref().and_then(|p| p.iter().position(|&p| p == k)) {
                            c[a] = (value / t.unit()) as f32;
                        }
                    }
                    Property::List(_, count_type, item_type) => {
                        let n = reader.scalar(*count_type).map_err(|m| reader.error(path, &element.name, record, m))? as usize;
                        let mut items = Vec::with_capacity(n.min(64));
                        for _ in 0..n {
                            items.push(reader.scalar(*item_type).map_err(|m| reader.error(path, &element.name, record, m))?);
                        }
                        if face_list == Some(k) {
                            let vertices = scene.vertices.len();
                            let index = |i: f64| {
                                if i >= 0.0 && (i as usize) < vertices && i.fract() == 0.0 {
                                    Ok(i as u32)
                                } else {
                                    Err(format!("vertex index {i} is out of range: there are {vertices} vertices"))
                                }
                            };
                            if strips {
                                // Strips end at -1; every triangle alternates its winding so that all
                                // face the same way, and those with a repeated corner (the strips'
                                // joins) have no area.
                                for strip in items.split(|&i| i == -1.0) {
                                    let ids: Vec<u32> =
                                        strip.iter().map(|&i| index(i)).collect::<Result<_, _>>().map_err(|m| reader.error(path, &element.name, record, m))?;
                                    let triangles = ids.windows(3).enumerate().map(|(k, w)| if k % 2 == 0 { [w[0], w[1], w[2]] } else { [w[1], w[0], w[2]] });
                                    scene.triangles.extend(triangles.filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]));
                                }
                                continue;
                            }
                            let ids: Vec<u32> =
                                items.iter().map(|&i| index(i)).collect::<Result<_, _>>().map_err(|m| reader.error(path, &element.name, record, m))?;
                            if ids.len() < 3 {
                                return Err(reader.error(path, &element.name, record, format!("face has {} corners; a face needs at least 3", ids.len())));
                            }
                            scene.triangles.extend((1..ids.len() - 1).map(|k| [ids[0], ids[k], ids[k + 1]]));
                        }
                    }
                }
            }
            if is_vertex {
                if v.iter().any(|c| !c.is_finite()) {
                    return Err(reader.error(path, &element.name, record, format!("coordinates {v:?} are not all finite")));
                }
                scene.vertices.push(v);
                normals.push(n);
                colours.push(c);
            }
        }
    }
    if scene.vertices.is_empty() || scene.triangles.is_empty() {
        return Err(format_err(format!("{} vertices and {} triangles: nothing to rasterise", scene.vertices.len(), scene.triangles.len())));
    }
    Ok(Mesh {
        positions: scene.vertices,
        triangles: scene.triangles,
        normals: has_normals.then_some(normals),
        colours: has_colours.then_some(colours),
        uvs: None,
        ..Default::default()
    })
}

/// The body after the header: binary values, or ASCII words line by line.
struct Body<'a> {
    bytes: &'a [u8],
    at: usize,
    format: Format,
    /// ASCII: the current line number and its words not yet read.
    line: usize,
    words: Vec<String>,
}

impl Body<'_> {
    /// ASCII records are one line each.
    fn start_record(&mut self) -> Result<(), String> {
        if self.format != Format::Ascii {
            return Ok(());
        }
        if !self.words.is_empty() {
            return Err(format!("{} values left over on line {}", self.words.len(), self.line));
        }
        loop {
            if self.at >= self.bytes.len() {
                return Err("the file ends before all records are read".into());
            }
            let end = self.bytes[self.at..].iter().position(|&b| b == b'\n').map_or(self.bytes.len(), |k| self.at + k);
            let text = String::from_utf8_lossy(&self.bytes[self.at..end]).into_owned();
            self.at = end + 1;
            self.line += 1;
            self.words = text.split_whitespace().rev().map(str::to_string).collect();
            if !self.words.is_empty() {
                return Ok(());
            }
        }
    }

    fn scalar(&mut self, t: Scalar) -> Result<f64, String> {
        if self.format == Format::Ascii {
            let word = self.words.pop().ok_or_else(|| format!("line {} has too few values", self.line))?;
            return word.parse::<f64>().map_err(|_| format!("'{word}' on line {} is not a number", self.line));
        }
        let size = t.size();
        let b = self.bytes.get(self.at..self.at + size).ok_or("the file ends before all records are read")?;
        self.at += size;
        Ok(t.read(b, self.format))
    }

    fn error(&self, path: &Path, element: &str, record: usize, message: String) -> IoError {
        match self.format {
            Format::Ascii => IoError::Parse { path: path.to_owned(), line: self.line, message: format!("{element} {record}: {message}") },
            _ => IoError::Format { path: path.to_owned(), message: format!("{element} record {record}: {message}") },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment a square\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 1 255\n1 0 2 0\n1 1 3 0\n0 1 4 0\n4 0 1 2 3\n";

    fn binary(big: bool) -> Vec<u8> {
        let mut b = format!(
            "ply\nformat binary_{}_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty float z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n",
            if big { "big" } else { "little" }
        )
        .into_bytes();
        let f64s = |v: f64| if big { v.to_be_bytes().to_vec() } else { v.to_le_bytes().to_vec() };
        let f32s = |v: f32| if big { v.to_be_bytes().to_vec() } else { v.to_le_bytes().to_vec() };
        let u32s = |v: u32| if big { v.to_be_bytes().to_vec() } else { v.to_le_bytes().to_vec() };
        for (x, y, z) in [(0.0, 0.0, 1.0), (1.0, 0.0, 2.0), (1.0, 1.0, 3.0), (0.0, 1.0, 4.0)] {
            b.extend(f64s(x));
            b.extend(f64s(y));
            b.extend(f32s(z as f32));
        }
        b.push(4);
        for i in 0..4 {
            b.extend(u32s(i));
        }
        b
    }

    #[test]
    fn ascii_and_binary_give_the_same_mesh() {
        let ascii = parse_ply(ASCII.as_bytes(), Path::new("a.ply")).unwrap();
        assert_eq!(ascii.vertices, vec![[0.0, 0.0, 1.0], [1.0, 0.0, 2.0], [1.0, 1.0, 3.0], [0.0, 1.0, 4.0]]);
        assert_eq!(ascii.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        for big in [false, true] {
            let b = parse_ply(&binary(big), Path::new("b.ply")).unwrap();
            assert_eq!((&b.vertices, &b.triangles), (&ascii.vertices, &ascii.triangles), "big endian: {big}");
        }
    }

    #[test]
    fn normals_and_colours_are_read_where_present() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 0 0 1 255 0 51\n1 0 0 0 0 1 0 255 0\n0 1 0 0 0 1 0 0 255\n3 0 1 2\n";
        let mesh = parse_ply_mesh(text.as_bytes(), Path::new("c.ply")).unwrap();
        assert_eq!(mesh.normals.unwrap(), vec![[0.0, 0.0, 1.0]; 3]);
        assert_eq!(mesh.colours.unwrap()[0], [1.0, 0.0, 0.2, 1.0]);
        // Only a red channel: no colours; no normals.
        let plain = parse_ply_mesh(ASCII.as_bytes(), Path::new("a.ply")).unwrap();
        assert!(plain.colours.is_none() && plain.normals.is_none());
    }

    /// Triangle strips, as scanners write them (`element tristrips` with one list, `-1` between
    /// strips): the triangles of each strip, every other one turned to face the same way, the
    /// joins' degenerate triangles dropped.
    #[test]
    fn triangle_strips_are_read_as_their_triangles() {
        let strips = "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n0 0 0\n0 1 0\n1 0 0\n1 1 0\n2 0 0\n2 1 0\n9 0 1 2 3 -1 2 3 4 5\n";
        let mesh = parse_ply_mesh(strips.as_bytes(), Path::new("s.ply")).unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [2, 1, 3], [2, 3, 4], [4, 3, 5]]);
        // All four face the same way (+z here: counter-clockwise seen from above... or all the other way).
        let area = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        };
        let signs: Vec<bool> = mesh.triangles.iter().map(|t| area(t) > 0.0).collect();
        assert!(signs.iter().all(|&s| s == signs[0]), "{signs:?}");
        // A join by repeated indices gives no triangle; a bad index names its record.
        let joined = strips.replace("9 0 1 2 3 -1 2 3 4 5", "10 0 1 2 3 3 2 2 3 4 5");
        assert_eq!(parse_ply_mesh(joined.as_bytes(), Path::new("s.ply")).unwrap().triangles.len(), 4);
        let bad = strips.replace("2 3 4 5\n", "2 3 4 7\n");
        assert!(parse_ply_mesh(bad.as_bytes(), Path::new("s.ply")).unwrap_err().to_string().contains("tristrips 0: vertex index 7 is out of range"));
    }

    #[test]
    fn bad_ply_is_refused_with_where_and_why() {
        let err = |text: &[u8]| parse_ply(text, Path::new("m.ply")).unwrap_err().to_string();
        assert!(err(ASCII.replace("4 0 1 2 3", "4 0 1 2 9").as_bytes()).starts_with("m.ply:16: face 0: vertex index 9 is out of range: there are 4 vertices"));
        assert!(err(ASCII.replace("1 1 3 0", "1 one 3 0").as_bytes()).starts_with("m.ply:14: vertex 2: 'one' on line 14 is not a number"));
        assert!(err(ASCII.replace("4 0 1 2 3\n", "").as_bytes()).contains("ends before all records"));
        assert!(err(ASCII.replace("property float y\n", "").as_bytes()).contains("no 'y' property"));
        assert!(err(b"ply\nformat ascii 1.0\n").contains("no 'end_header'"));
        assert!(err(ASCII.replace("ascii", "binary_middle_endian").as_bytes()).contains("unsupported PLY format 'binary_middle_endian'"));
        let mut truncated = binary(false);
        truncated.truncate(truncated.len() - 3);
        assert!(err(&truncated).contains("face record 0: the file ends before all records are read"));
    }
}
