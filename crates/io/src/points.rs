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
        match self {
            Separator::Comma => line.split(',').map(str::trim).collect(),
            Separator::Semicolon => line.split(';').map(str::trim).collect(),
            Separator::Blank => line.split_whitespace().collect(),
        }
    }
}

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

    let mut points = Vec::new();
    let data = header.is_none().then_some((first_no, first)).into_iter().chain(lines);
    for (line_no, line) in data {
        let fields = separator.fields(line);
        if fields.len() < needed {
            return Err(fail(line_no, format!("expected at least {needed} fields, found {}", fields.len())));
        }
        let mut p = [0.0; 3];
        for (axis, (value, &k)) in p.iter_mut().zip(&at).enumerate() {
            let field = fields[k];
            *value = field.parse::<f64>().map_err(|_| fail(line_no, format!("{} (column {}) is '{field}', not a number", ["x", "y", "z"][axis], k + 1)))?;
            if !value.is_finite() {
                return Err(fail(line_no, format!("{} (column {}) is {field}; coordinates must be finite", ["x", "y", "z"][axis], k + 1)));
            }
        }
        points.push(p);
    }
    if points.is_empty() {
        return Err(IoError::Format { path: path.to_owned(), message: "no points: the file has a header but no data lines".into() });
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
}
