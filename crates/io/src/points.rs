//! Point sets as delimited text: CSV, XYZ and the like, one point a line.
//!
//! - Separators: commas, semicolons or tabs/spaces, whichever the first data line uses.
//! - A header line (any field not a number) names the columns; without one, columns go by
//!   position. Blank lines and lines starting with `#` are skipped.
//! - Columns are chosen by name (case-insensitive) or by 1-based position. By default: with a
//!   header, the columns named `x`/`easting`/`lon`, `y`/`northing`/`lat` and
//!   `z`/`elevation`/`height`; without one, the first three.
//! - Every problem is reported with the file, the line and what is wrong there.

use crate::IoError;
use rayon::prelude::*;
use std::path::Path;

/// Which column holds a coordinate.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Column {
    /// The column with this header name (case-insensitive).
    Name(String),
    /// The column at this 1-based position.
    Position(usize),
}

impl std::str::FromStr for Column {
    type Err = String;

    /// A 1-based position (`3`) or a header name (`elevation`).
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        match s.parse::<usize>() {
            Ok(0) => Err("column positions start at 1".into()),
            Ok(n) => Ok(Column::Position(n)),
            Err(_) if s.is_empty() => Err("empty column name".into()),
            Err(_) => Ok(Column::Name(s.to_string())),
        }
    }
}

/// The x, y and z columns; `None` for the defaults.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PointColumns {
    pub x: Option<Column>,
    pub y: Option<Column>,
    pub z: Option<Column>,
}

/// Read a delimited-text point file.
pub fn read_points(path: &Path, columns: &PointColumns) -> Result<Vec<[f64; 3]>, IoError> {
    let text = std::fs::read_to_string(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    parse_points(&text, path, columns)
}

#[derive(Clone, Copy)]
enum Separator {
    Comma,
    Semicolon,
    Blank,
}

impl Separator {
    fn of(line: &str) -> Self {
        if line.contains(',') {
            Separator::Comma
        } else if line.contains(';') {
            Separator::Semicolon
        } else {
            Separator::Blank
        }
    }

    fn fields(self, line: &str) -> Vec<&str> {
        let mut fields = Vec::new();
        self.each_field(line, |_, field| {
            fields.push(field);
            true
        });
        fields
    }

    /// `visit` each field of `line` with its 0-based position, while it returns true.
    #[inline]
    fn each_field<'a>(self, line: &'a str, mut visit: impl FnMut(usize, &'a str) -> bool) {
        let mut go = |fields: &mut dyn Iterator<Item = &'a str>| {
            for (k, field) in fields.enumerate() {
                if !visit(k, field) {
                    break;
                }
            }
        };
        match self {
            Separator::Comma => go(&mut line.split(',').map(str::trim)),
            Separator::Semicolon => go(&mut line.split(';').map(str::trim)),
            Separator::Blank => go(&mut line.split_whitespace()),
        }
    }
}

/// Text at least this long is parsed in pieces on all cores.
const PARALLEL_BYTES: usize = 1 << 20;

const DEFAULT_NAMES: [&[&str]; 3] =
    [&["x", "easting", "lon", "longitude"], &["y", "northing", "lat", "latitude"], &["z", "elevation", "height", "alt", "altitude"]];

/// Parse delimited-text points (`path` names the source in errors).
pub fn parse_points(text: &str, path: &Path, columns: &PointColumns) -> Result<Vec<[f64; 3]>, IoError> {
    let fail = |line: usize, message: String| IoError::Parse { path: path.to_owned(), line, message };
    let mut lines = text.lines().enumerate().map(|(k, l)| (k + 1, l.trim_end_matches('\r'))).filter(|(_, l)| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with('#')
    });
    let Some((first_no, first)) = lines.next() else {
        return Err(IoError::Format { path: path.to_owned(), message: "no points: the file has no data lines".into() });
    };
    let separator = Separator::of(first);
    let first_fields = separator.fields(first);
    let header: Option<Vec<String>> =
        first_fields.iter().any(|f| f.parse::<f64>().is_err()).then(|| first_fields.iter().map(|f| f.trim_matches('"').to_lowercase()).collect());

    // 0-based field indices of x, y, z.
    let mut at = [0usize; 3];
    let chosen = [&columns.x, &columns.y, &columns.z];
    for (axis, ((slot, choice), defaults)) in at.iter_mut().zip(chosen).zip(DEFAULT_NAMES).enumerate() {
        let axis_name = ["x", "y", "z"][axis];
        *slot = match (choice, &header) {
            (Some(Column::Position(p)), _) => p - 1,
            (Some(Column::Name(name)), Some(names)) => names
                .iter()
                .position(|n| *n == name.to_lowercase())
                .ok_or_else(|| fail(first_no, format!("no column named '{name}' for {axis_name}; the header has: {}", names.join(", "))))?,
            (Some(Column::Name(name)), None) => {
                return Err(fail(
                    first_no,
                    format!("column '{name}' for {axis_name} is chosen by name, but the file has no header line; choose it by position (1, 2, ...)"),
                ));
            }
            (None, Some(names)) => names.iter().position(|n| defaults.contains(&n.as_str())).ok_or_else(|| {
                fail(
                    first_no,
                    format!("no column for {axis_name} among {}; name it (one of {}) or choose it by name or position", names.join(", "), defaults.join(", ")),
                )
            })?,
            (None, None) => axis,
        };
    }
    let needed = at.iter().max().expect("three columns") + 1;

    // The data lines: from the first one on (after the header when there is one), parsed in
    // pieces of whole lines on all cores; an error names the first bad line in file order.
    let offset = |line: &str| line.as_ptr() as usize - text.as_ptr() as usize;
    let body = match header {
        Some(_) => &text[(offset(first) + first.len()).min(text.len())..],
        None => &text[offset(first)..],
    };
    let pieces = if body.len() >= PARALLEL_BYTES { 4 * rayon::current_num_threads() } else { 1 };
    let parsed: Vec<Parsed> =
        split_at_lines(body, pieces).into_par_iter().map(|piece| parse_lines(piece, separator, at, needed).map_err(|(line, e)| (offset(line), e))).collect();
    let mut points = Vec::with_capacity(parsed.iter().map(|p| p.as_ref().map_or(0, Vec::len)).sum());
    for piece in parsed {
        match piece {
            Ok(part) => points.extend(part),
            Err((at, message)) => return Err(fail(1 + text.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count(), message)),
        }
    }
    if points.is_empty() {
        return Err(IoError::Format { path: path.to_owned(), message: "no points: the file has a header but no data lines".into() });
    }
    Ok(points)
}

/// A piece's points, or the byte where its first bad line starts and what is wrong with it.
type Parsed = Result<Vec<[f64; 3]>, (usize, String)>;

/// `text` cut into at most `n` pieces of whole lines, in order.
fn split_at_lines(text: &str, n: usize) -> Vec<&str> {
    let mut pieces = Vec::with_capacity(n);
    let mut rest = text;
    for k in (1..n).rev() {
        let cut = rest.len() - rest.len() * k / (k + 1);
        match rest.as_bytes()[cut.min(rest.len())..].iter().position(|&b| b == b'\n') {
            Some(at) => {
                let (piece, tail) = rest.split_at(cut + at + 1);
                pieces.push(piece);
                rest = tail;
            }
            None => break,
        }
    }
    pieces.push(rest);
    pieces
}

/// The points of the data lines of `text` (blank and `#` lines skipped), or the first bad
/// line and what is wrong with it.
fn parse_lines(text: &str, separator: Separator, at: [usize; 3], needed: usize) -> Result<Vec<[f64; 3]>, (&str, String)> {
    let mut points = Vec::with_capacity(text.len() / 32);
    for line in text.lines() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let (mut p, mut fields, mut bad) = ([0.0; 3], 0, None);
        let line = line.trim_end_matches('\r');
        separator.each_field(line, |k, field| {
            fields = k + 1;
            for axis in 0..3 {
                if at[axis] != k || bad.is_some() {
                    continue;
                }
                match field.parse::<f64>() {
                    Ok(v) if v.is_finite() => p[axis] = v,
                    Ok(_) => bad = Some(format!("{} (column {}) is {field}; coordinates must be finite", ["x", "y", "z"][axis], k + 1)),
                    Err(_) => bad = Some(format!("{} (column {}) is '{field}', not a number", ["x", "y", "z"][axis], k + 1)),
                }
            }
            fields < needed
        });
        if fields < needed {
            return Err((line, format!("expected at least {needed} fields, found {fields}")));
        }
        if let Some(message) = bad {
            return Err((line, message));
        }
        points.push(p);
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, columns: &PointColumns) -> Result<Vec<[f64; 3]>, String> {
        parse_points(text, Path::new("pts.csv"), columns).map_err(|e| e.to_string())
    }

    #[test]
    fn separators_headers_and_comments() {
        let none = PointColumns::default();
        let expect = vec![[1.0, 2.0, 3.0], [4.5, -5.0, 6e2]];
        assert_eq!(parse("1,2,3\n4.5,-5,6e2\n", &none).unwrap(), expect);
        assert_eq!(parse("# survey\nX;Y;Z\r\n1;2;3\r\n\r\n4.5;-5;6e2\r\n", &none).unwrap(), expect);
        assert_eq!(parse("1 2 3\n4.5\t-5   6e2 extra\n", &none).unwrap(), expect);
        assert_eq!(parse("id,easting,northing,elevation\n7,1,2,3\n8,4.5,-5,6e2\n", &none).unwrap(), expect);
    }

    #[test]
    fn columns_by_name_and_position() {
        let by_name = PointColumns { x: Some("e".parse().unwrap()), y: Some("N".parse().unwrap()), z: Some("h".parse().unwrap()) };
        assert_eq!(parse("h,n,e\n3,2,1\n", &by_name).unwrap(), vec![[1.0, 2.0, 3.0]]);
        let by_position = PointColumns { x: Some("3".parse().unwrap()), y: Some("2".parse().unwrap()), z: Some("1".parse().unwrap()) };
        assert_eq!(parse("3 2 1\n", &by_position).unwrap(), vec![[1.0, 2.0, 3.0]]);
        assert!("0".parse::<Column>().is_err());
    }

    #[test]
    fn errors_name_the_file_the_line_and_the_problem() {
        let none = PointColumns::default();
        let cases = [
            ("x,y,z\n1,2,3\n4,5\n", "pts.csv:3: expected at least 3 fields, found 2"),
            ("1,2,3\n\n1,2,abc\n", "pts.csv:3: z (column 3) is 'abc', not a number"),
            ("1,2,3\n1,NaN,3\n", "pts.csv:2: y (column 2) is NaN; coordinates must be finite"),
            ("", "pts.csv: no points: the file has no data lines"),
            ("x,y,z\n", "pts.csv: no points: the file has a header but no data lines"),
            ("a,b,c\n1,2,3\n", "pts.csv:1: no column for x among a, b, c"),
        ];
        for (text, expected) in cases {
            let err = parse(text, &none).unwrap_err();
            assert!(err.starts_with(expected), "{text:?}: {err}");
        }
        let by_name = PointColumns { z: Some(Column::Name("h".into())), ..Default::default() };
        assert!(parse("1 2 3\n", &by_name).unwrap_err().contains("no header line"));
        assert!(parse("x y z\n1 2 3\n", &by_name).unwrap_err().contains("no column named 'h' for z; the header has: x, y, z"));
    }

    /// Text parsed in pieces on all cores gives the points in file order, and the first bad
    /// line in file order, wherever the pieces are cut.
    #[test]
    fn long_text_is_parsed_in_pieces_in_order() {
        let line = |k: usize| format!("{}.25,{},{}\r\n", 500_000 + k, 5_000_000 + 3 * k, k % 97);
        let mut text = String::from("# survey\nx,y,z\n");
        let mut expected = Vec::new();
        for k in 0..120_000 {
            text += &line(k);
            if k % 1000 == 0 {
                text += "\n# a comment\n";
            }
            expected.push([500_000.0 + k as f64 + 0.25, 5_000_000.0 + 3.0 * k as f64, (k % 97) as f64]);
        }
        assert!(text.len() > 2 * PARALLEL_BYTES);
        assert_eq!(parse(&text, &PointColumns::default()).unwrap(), expected);
        // Two bad lines: the first is named.
        let lines: Vec<&str> = text.split_inclusive('\n').collect();
        let (first, second) = (lines.len() / 3, 2 * lines.len() / 3);
        let bad: String = lines.iter().enumerate().map(|(k, l)| if k == first || k == second { "1,2,x\n" } else { l }).collect();
        assert!(parse(&bad, &PointColumns::default()).unwrap_err().starts_with(&format!("pts.csv:{}: z (column 3) is 'x'", first + 1)));
    }
}
