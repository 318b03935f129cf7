//! Text clouds (`.xyz`, `.xyzn`, `.txt`, `.pts`, `.csv`): one point per line, values
//! separated by whitespace and commas, or whitespace and semicolons (a comma is then
//! a decimal comma: `1,5;2;3`); blank lines and lines starting with `#` or `//` are
//! skipped; every data line has the column count of the first one.
//!
//! What the columns hold, in this order of precedence:
//! 1. `--columns` ([`Columns`]), e.g. `x,y,z,nx,ny,nz` or `x,y,z,_,r,g,b`;
//! 2. a header line naming them, plain (`X,Y,Z,Intensity`) or as the last comment
//!    before the data (`//X,Y,Z,R,G,B` as CloudCompare writes it, `# x y z nx ny nz`);
//!    a comment is a header only when it names x, y and z and as many columns as the
//!    data has;
//! 3. the column count: 3 is `x y z`; 4 is `x y z intensity`; 6 and 9 are `x y z`
//!    then groups of three, 7 and 10 `x y z intensity` then groups. A group holds
//!    normals when no row is longer than a unit vector and at least half the rows
//!    are unit vectors (length within [`UNIT_TOLERANCE`] of 1; zero or NaN rows are
//!    normals left unknown), and colours when its values are all integers in 0-255
//!    or all in 0-1. Anything else is an error that asks for `--columns`.
//!
//! Colours named by a header or `--columns` are 0-1 when every value of the file is,
//! 0-255 otherwise (another value is an error naming its line). Intensity and other
//! columns are read as numbers and not kept. A first line holding one integer (the
//! point count of a Leica PTS file) is skipped.
//!
//! Cost: one pass over the bytes; memory is the output plus, for more than three
//! columns, the other columns' values until the layout is known (8 bytes a value).

use super::{check_finite, Cloud, Lines, ReadErrorKind, Shown};
use std::fmt;
use std::str::FromStr;

type Result<T> = core::result::Result<T, ReadErrorKind>;

/// How far from 1 the length of a unit normal may be (normals written with 3
/// decimals are within 0.3 % of unit length).
pub const UNIT_TOLERANCE: f64 = 0.01;

/// What one column of a text cloud holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Column {
    /// Position.
    X,
    /// Position.
    Y,
    /// Position.
    Z,
    /// Normal.
    Nx,
    /// Normal.
    Ny,
    /// Normal.
    Nz,
    /// Colour, 0-255 or 0-1.
    R,
    /// Colour, 0-255 or 0-1.
    G,
    /// Colour, 0-255 or 0-1.
    B,
    /// A column read as a number and not kept (`_`, intensity, ...).
    Skip,
}

impl Column {
    /// The column a name stands for; `None` for a name this reader does not keep.
    fn from_name(name: &str) -> Option<Column> {
        let name = name
            .trim()
            .trim_start_matches("//")
            .trim_matches(['"', '\''])
            .to_ascii_lowercase();
        Some(match name.as_str() {
            "x" => Column::X,
            "y" => Column::Y,
            "z" => Column::Z,
            "nx" | "normal_x" | "normalx" | "n_x" => Column::Nx,
            "ny" | "normal_y" | "normaly" | "n_y" => Column::Ny,
            "nz" | "normal_z" | "normalz" | "n_z" => Column::Nz,
            "r" | "red" | "rf" => Column::R,
            "g" | "green" | "gf" => Column::G,
            "b" | "blue" | "bf" => Column::B,
            "_" | "i" | "intensity" => Column::Skip,
            _ => return None,
        })
    }

    fn name(self) -> &'static str {
        match self {
            Column::X => "x",
            Column::Y => "y",
            Column::Z => "z",
            Column::Nx => "nx",
            Column::Ny => "ny",
            Column::Nz => "nz",
            Column::R => "r",
            Column::G => "g",
            Column::B => "b",
            Column::Skip => "_",
        }
    }
}

/// The layout of a text cloud's columns: `x`, `y` and `z` once each, `nx ny nz` and
/// `r g b` all three or none.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Columns(Vec<Column>);

impl Columns {
    /// A layout from its columns, checked.
    pub fn new(columns: Vec<Column>) -> core::result::Result<Columns, String> {
        let count = |c: Column| columns.iter().filter(|&&k| k == c).count();
        for c in [
            Column::X,
            Column::Y,
            Column::Z,
            Column::Nx,
            Column::Ny,
            Column::Nz,
            Column::R,
            Column::G,
            Column::B,
        ] {
            if count(c) > 1 {
                return Err(format!("'{}' is named twice", c.name()));
            }
        }
        for c in [Column::X, Column::Y, Column::Z] {
            if count(c) == 0 {
                return Err(format!("no '{}' column", c.name()));
            }
        }
        for group in [
            [Column::Nx, Column::Ny, Column::Nz],
            [Column::R, Column::G, Column::B],
        ] {
            let n: usize = group.iter().map(|&c| count(c)).sum();
            if n != 0 && n != 3 {
                let names = group.map(Column::name).join(" ");
                return Err(format!("'{names}' must be named all three or none"));
            }
        }
        Ok(Columns(columns))
    }

    /// Columns in a line.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Never true: a layout has x, y and z.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    fn index(&self, c: Column) -> Option<usize> {
        self.0.iter().position(|&k| k == c)
    }

    fn group(&self, g: [Column; 3]) -> Option<[usize; 3]> {
        Some([self.index(g[0])?, self.index(g[1])?, self.index(g[2])?])
    }

    /// A header line's names, unknown names as [`Column::Skip`].
    fn from_header(names: &[&str]) -> core::result::Result<Columns, String> {
        Columns::new(
            names
                .iter()
                .map(|n| Column::from_name(n).unwrap_or(Column::Skip))
                .collect(),
        )
    }
}

/// `--columns`: names separated by commas (or spaces): `x y z`, `nx ny nz`,
/// `r g b` and `_` for a column to skip (also `i`, `intensity`).
impl FromStr for Columns {
    type Err = String;

    fn from_str(s: &str) -> core::result::Result<Columns, String> {
        let columns = s
            .split(|c: char| c == ',' || c.is_ascii_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| {
                Column::from_name(t).ok_or_else(|| {
                    format!(
                        "unknown column {} (use x, y, z, nx, ny, nz, r, g, b, or _ to skip)",
                        Shown(t)
                    )
                })
            })
            .collect::<core::result::Result<Vec<_>, _>>()?;
        Columns::new(columns).map_err(|e| format!("'{s}': {e}"))
    }
}

impl fmt::Display for Columns {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = self.0.iter().map(|c| c.name()).collect();
        write!(f, "{}", names.join(","))
    }
}

/// The tokens of a line: separated by whitespace and commas, or, in a line with a
/// semicolon, by whitespace and semicolons (a comma is then a decimal comma, see
/// [`number`]).
fn tokens(line: &str) -> impl Iterator<Item = &str> {
    let semicolons = line.contains(';');
    line.split(move |c: char| c.is_ascii_whitespace() || c == if semicolons { ';' } else { ',' })
        .filter(|t| !t.is_empty())
}

/// A token as a number; a comma in it is a decimal comma (`1,5;2;3`).
fn number(tok: &str) -> Option<f64> {
    tok.parse::<f64>().ok().or_else(|| {
        tok.contains(',')
            .then(|| tok.replace(',', ".").parse::<f64>().ok())
            .flatten()
    })
}

/// A comment line's text, without its `#` or `//`.
fn comment(line: &str) -> Option<&str> {
    line.strip_prefix('#').or_else(|| line.strip_prefix("//"))
}

/// Whether a comment's words name the columns: they start with x, y and z, or are
/// all names of columns this reader knows, x, y and z among them.
fn is_header_comment(names: &[&str]) -> bool {
    let known: Vec<Option<Column>> = names.iter().map(|n| Column::from_name(n)).collect();
    let xyz = [Some(Column::X), Some(Column::Y), Some(Column::Z)];
    (known.starts_with(&xyz) || known.iter().all(Option::is_some))
        && Columns::from_header(names).is_ok()
}

/// Where the layout came from, for messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    /// `--columns`.
    Option,
    /// A header on this line.
    Header(usize),
}

/// The values of the columns other than x, y and z, row after row, with each row's
/// line, until the layout says what they are.
struct Others {
    /// Column indices kept (every column but x, y and z).
    columns: Vec<usize>,
    values: Vec<f64>,
    lines: Vec<usize>,
}

impl Others {
    /// The values of column `c` (an index into the line), with their lines.
    fn column(&self, c: usize) -> impl Iterator<Item = (f64, usize)> + '_ {
        let k = self.columns.iter().position(|&j| j == c);
        let stride = self.columns.len();
        self.lines
            .iter()
            .enumerate()
            .map(move |(row, &line)| (k.map_or(f64::NAN, |k| self.values[row * stride + k]), line))
    }

    fn triples(&self, cols: [usize; 3]) -> impl Iterator<Item = ([f64; 3], usize)> + '_ {
        let stride = self.columns.len();
        let ks = cols.map(|c| self.columns.iter().position(|&j| j == c));
        self.lines.iter().enumerate().map(move |(row, &line)| {
            (
                ks.map(|k| k.map_or(f64::NAN, |k| self.values[row * stride + k])),
                line,
            )
        })
    }
}

/// Parses a text cloud; `columns` (from `--columns`) overrides any header.
pub fn parse_cloud(data: &[u8], columns: Option<&Columns>) -> Result<Cloud> {
    if data.is_empty() {
        return Err(ReadErrorKind::file("file is empty"));
    }
    // Each point needs a line of at least 6 bytes ("0 0 0\n"): reserve no more rows
    // than there are lines, nor than the bytes allow (a file of newlines reserves little).
    let newlines = data.iter().filter(|&&b| b == b'\n').count();
    let max_rows = (newlines + 1).min(data.len() / 6 + 1);
    let mut positions: Vec<[f64; 3]> = Vec::with_capacity(max_rows);
    // The last comment before the data that reads as a header, with its line.
    let mut comment_header: Option<(usize, Vec<&str>)> = None;
    let mut header: Option<(Columns, Source)> = columns.map(|c| (c.clone(), Source::Option));
    let mut plain_header = false;
    // (column count, line it was set by), set by the first data line.
    let mut first: Option<(usize, usize)> = None;
    let mut xyz = [0usize, 1, 2];
    let mut others = Others {
        columns: Vec::new(),
        values: Vec::new(),
        lines: Vec::new(),
    };
    let mut row: Vec<&str> = Vec::new();
    for next in Lines::new(data, 0, 1).texts() {
        let (n, line) = next?;
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(text) = comment(line) {
            if first.is_none() {
                let names: Vec<&str> = tokens(text).collect();
                if is_header_comment(&names) {
                    comment_header = Some((n, names));
                }
            }
            continue;
        }
        row.clear();
        row.extend(tokens(line));
        if first.is_none() {
            // Words only: a header; numbers and words: a data line with a bad value.
            let words = row.iter().all(|t| number(t).is_none());
            if words && !plain_header {
                // A header line naming the columns.
                plain_header = true;
                if header.is_none() {
                    let layout = Columns::from_header(&row).map_err(|e| {
                        ReadErrorKind::line(
                            n,
                            format!(
                                "neither numbers nor a header naming x, y and z ({e}): {}",
                                Shown(line)
                            ),
                        )
                    })?;
                    header = Some((layout, Source::Header(n)));
                }
                continue;
            }
            if row.len() == 1 && !plain_header && row[0].parse::<u64>().is_ok() {
                // The point count of a PTS file.
                continue;
            }
            let found = row.len();
            if header.is_none() {
                if let Some((hn, names)) = comment_header.take() {
                    if names.len() == found {
                        let layout =
                            Columns::from_header(&names).map_err(|e| ReadErrorKind::line(hn, e))?;
                        header = Some((layout, Source::Header(hn)));
                    }
                }
            }
            match &header {
                Some((layout, source)) if layout.len() != found => {
                    let by = match source {
                        Source::Option => format!("--columns {layout} names"),
                        Source::Header(hn) => format!("the header on line {hn} names"),
                    };
                    return Err(ReadErrorKind::line(
                        n,
                        format!("{by} {} columns, the line has {found}", layout.len()),
                    ));
                }
                Some((layout, _)) => {
                    xyz = [Column::X, Column::Y, Column::Z]
                        .map(|c| layout.index(c).unwrap_or_default());
                }
                None if matches!(found, 3 | 4 | 6 | 7 | 9 | 10) => {}
                None => {
                    return Err(ReadErrorKind::line(
                        n,
                        format!(
                            "expected 3, 4, 6, 7, 9 or 10 numbers, found {found} (name the \
                             columns with a header line or --columns)"
                        ),
                    ))
                }
            }
            first = Some((found, n));
            others.columns = (0..found).filter(|c| !xyz.contains(c)).collect();
        }
        let Some((columns, first_line)) = first else {
            continue; // set above
        };
        if row.len() != columns {
            return Err(ReadErrorKind::line(
                n,
                format!(
                    "expected {columns} numbers like line {first_line}, found {}",
                    row.len()
                ),
            ));
        }
        // Every value is parsed, in order: the first bad one is named.
        let mut p = [0.0; 3];
        for (c, tok) in row.iter().enumerate() {
            let v = number(tok).ok_or_else(|| {
                ReadErrorKind::line(
                    n,
                    format!("column {}: {} is not a number", c + 1, Shown(tok)),
                )
            })?;
            if let Some(k) = xyz.iter().position(|&j| j == c) {
                p[k] = v;
            } else {
                others.values.push(v);
            }
        }
        check_finite(p, positions.len() as u64, Some(n))?;
        positions.push(p);
        if !others.columns.is_empty() {
            others.lines.push(n);
        }
    }
    let Some((count, first_line)) = first else {
        return Err(ReadErrorKind::file(
            "no points: the file has only blank, comment or header lines",
        ));
    };
    let layout = match header {
        Some((layout, _)) => layout,
        None => by_count(count, first_line, &others)?,
    };
    let normals = layout
        .group([Column::Nx, Column::Ny, Column::Nz])
        .map(|cols| others.triples(cols).map(|(v, _)| v).collect());
    let colors = layout
        .group([Column::R, Column::G, Column::B])
        .map(|cols| colors(&others, cols))
        .transpose()?;
    Ok(Cloud {
        positions,
        normals,
        colors,
        invalid: 0,
    })
}

/// The layout of a file of `count` columns without a header (see the module docs).
fn by_count(count: usize, first_line: usize, others: &Others) -> Result<Columns> {
    use Column::*;
    let mut layout = vec![X, Y, Z];
    if count % 3 == 1 {
        layout.push(Skip);
    }
    while layout.len() < count {
        let at = layout.len();
        let cols = [at, at + 1, at + 2];
        let group = if is_normals(others, cols) && !layout.contains(&Nx) {
            [Nx, Ny, Nz]
        } else if is_colors(others, cols) && !layout.contains(&R) {
            [R, G, B]
        } else {
            let why = others
                .triples(cols)
                .find(|(v, _)| length(*v).is_some_and(|l| l > 1.0 + UNIT_TOLERANCE))
                .map(|(v, line)| format!("; line {line} has {} {} {}", v[0], v[1], v[2]))
                .unwrap_or_default();
            return Err(ReadErrorKind::line(
                first_line,
                format!(
                    "{count} columns: columns {}-{} are neither unit normals nor colours \
                     (0-255 integers or 0-1){why}; name the columns with --columns, e.g. \
                     --columns x,y,z,{}",
                    at + 1,
                    at + 3,
                    vec!["_"; count - 3].join(",")
                ),
            ));
        };
        layout.extend(group);
    }
    Columns::new(layout).map_err(|e| ReadErrorKind::line(first_line, e))
}

/// The length of a row of a group, `None` for a normal left unknown (zero or NaN).
fn length(v: [f64; 3]) -> Option<f64> {
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (len.is_finite() && len > 0.0).then_some(len)
}

/// Normals: no row longer than a unit vector, and at least half the known rows
/// unit vectors (averaged normals at sharp edges are often shorter).
fn is_normals(others: &Others, cols: [usize; 3]) -> bool {
    let (mut known, mut unit) = (0usize, 0usize);
    for (v, _) in others.triples(cols) {
        let Some(len) = length(v) else { continue };
        if len > 1.0 + UNIT_TOLERANCE {
            return false;
        }
        known += 1;
        unit += usize::from(len >= 1.0 - UNIT_TOLERANCE);
    }
    known > 0 && 2 * unit >= known
}

fn is_colors(others: &Others, cols: [usize; 3]) -> bool {
    let mut bytes = true;
    let mut unit = true;
    for c in cols {
        for (v, _) in others.column(c) {
            bytes &= (0.0..=255.0).contains(&v) && v.fract() == 0.0;
            unit &= (0.0..=1.0).contains(&v);
        }
    }
    bytes || unit
}

/// The colours of columns `cols`: 0-1 when every value is, else 0-255.
fn colors(others: &Others, cols: [usize; 3]) -> Result<Vec<[u8; 3]>> {
    let unit = cols
        .iter()
        .all(|&c| others.column(c).all(|(v, _)| (0.0..=1.0).contains(&v)));
    let scale = if unit { 255.0 } else { 1.0 };
    others
        .triples(cols)
        .map(|(v, line)| {
            let mut rgb = [0u8; 3];
            for k in 0..3 {
                if !(0.0..=255.0).contains(&v[k]) {
                    return Err(ReadErrorKind::line(
                        line,
                        format!(
                            "colour {} is {}, outside 0-255 (colours are 0-255 or 0-1)",
                            ["r", "g", "b"][k],
                            v[k]
                        ),
                    ));
                }
                rgb[k] = (v[k] * scale).round() as u8;
            }
            Ok(rgb)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(data: &str) -> Cloud {
        parse_cloud(data.as_bytes(), None).unwrap()
    }

    fn err(data: &str) -> String {
        parse_cloud(data.as_bytes(), None).unwrap_err().to_string()
    }

    #[test]
    fn comments_commas_and_crlf() {
        let c = read("# head\r\n\r\n1,2,3,0,0,1\r\n  4 5 6 0 1 0  \r\n// c\n");
        assert_eq!(c.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!(c.normals, Some(vec![[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]));
        assert_eq!(c.colors, None);
    }

    #[test]
    fn six_columns_of_bytes_are_colours_not_normals() {
        let c = read("1 2 3 255 0 0\n4 5 6 10 20 30\n");
        assert_eq!(c.normals, None);
        assert_eq!(c.colors, Some(vec![[255, 0, 0], [10, 20, 30]]));
        let c = read("1;2;3;0.5;0;1\n4;5;6;0;0;0\n");
        assert_eq!(c.colors, Some(vec![[128, 0, 255], [0, 0, 0]]));
        // Semicolons and decimal commas, as some spreadsheets write them.
        let c = read("X;Y;Z\n1,5;2;-3,25\n");
        assert_eq!(c.positions, vec![[1.5, 2.0, -3.25]]);
        assert_eq!(
            err("1,5;2;3,0,1\n"),
            "line 1: column 3: \"3,0,1\" is not a number"
        );
    }

    #[test]
    fn unit_vectors_with_unknown_rows_are_normals() {
        let c = read("1 2 3 0.6 0.8 0\n4 5 6 nan nan nan\n7 8 9 0 0 0\n");
        let n = c.normals.unwrap();
        assert_eq!(n[0], [0.6, 0.8, 0.0]);
        assert!(n[1][0].is_nan());
        // Shorter rows (averaged at an edge) are normals while half are unit.
        let c = read("1 2 3 0 0 1\n4 5 6 0 -0.7 0\n");
        assert_eq!(c.normals.unwrap()[1], [0.0, -0.7, 0.0]);
    }

    #[test]
    fn intensity_columns_are_skipped() {
        let c = read("1 2 3 0.7\n4 5 6 1200\n");
        assert_eq!(c.positions.len(), 2);
        assert_eq!((c.normals, c.colors), (None, None));
        // PTS: a count line, then x y z intensity r g b.
        let c = read("2\n1 2 3 -1200 255 128 0\n4 5 6 30 0 0 0\n");
        assert_eq!(c.colors, Some(vec![[255, 128, 0], [0, 0, 0]]));
        // 10: x y z i, colours, normals.
        let c = read("1 2 3 9 255 0 0 0 0 1\n4 5 6 9 0 9 0 1 0 0\n");
        assert_eq!(c.colors.unwrap()[1], [0, 9, 0]);
        assert_eq!(c.normals.unwrap()[1], [1.0, 0.0, 0.0]);
    }

    #[test]
    fn header_lines_name_the_columns() {
        let c = read("X,Y,Z,Intensity\n1,2,3,4\n");
        assert_eq!(c.positions, vec![[1.0, 2.0, 3.0]]);
        let c = read("//X,Y,Z,R,G,B\n1,2,3,0,0,1\n");
        assert_eq!(c.colors, Some(vec![[0, 0, 255]]));
        assert_eq!(c.normals, None);
        let c = read("# nz ny nx z y x\n0 0 1 3 2 1\n");
        assert_eq!(c.positions, vec![[1.0, 2.0, 3.0]]);
        assert_eq!(c.normals, Some(vec![[1.0, 0.0, 0.0]]));
        // A comment that does not match the data is only a comment.
        let c = read("# x y z\n1 2 3 0 0 1\n");
        assert_eq!(c.normals, Some(vec![[0.0, 0.0, 1.0]]));
        assert_eq!(
            err("x y z r g b\n1 2 3 300 0 0\n"),
            "line 2: colour r is 300, outside 0-255 (colours are 0-255 or 0-1)"
        );
        assert_eq!(
            err("x y w\n1 2 3\n"),
            "line 1: neither numbers nor a header naming x, y and z (no 'z' column): \"x y w\""
        );
        assert_eq!(
            err("x y z\n1 2 3 4\n"),
            "line 2: the header on line 1 names 3 columns, the line has 4"
        );
    }

    #[test]
    fn the_columns_option_overrides_header_and_guess() {
        let cols: Columns = "x,y,z,_,r,g,b".parse().unwrap();
        let c = parse_cloud(b"a b c d e f g\n1 2 3 4 0 0 1\n", Some(&cols)).unwrap();
        assert_eq!(c.colors, Some(vec![[0, 0, 255]]));
        let cols: Columns = "x y z nx ny nz".parse().unwrap();
        let c = parse_cloud(b"1 2 3 2 0 0\n", Some(&cols)).unwrap();
        assert_eq!(c.normals, Some(vec![[2.0, 0.0, 0.0]]));
        let e = parse_cloud(b"1 2 3 4\n", Some(&cols))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "line 1: --columns x,y,z,nx,ny,nz names 6 columns, the line has 4"
        );
        assert!("x,y"
            .parse::<Columns>()
            .unwrap_err()
            .contains("no 'z' column"));
        assert!("x,y,z,nx"
            .parse::<Columns>()
            .unwrap_err()
            .contains("all three"));
        assert!("x,y,z,x".parse::<Columns>().unwrap_err().contains("twice"));
        assert!("x,y,z,w"
            .parse::<Columns>()
            .unwrap_err()
            .contains("unknown column \"w\""));
    }

    #[test]
    fn column_count_must_match_first_line() {
        assert_eq!(
            err("1 2 3\n4 5 6 7\n"),
            "line 2: expected 3 numbers like line 1, found 4"
        );
        assert!(
            err("1 2 3 4 5\n").starts_with("line 1: expected 3, 4, 6, 7, 9 or 10 numbers, found 5")
        );
    }

    #[test]
    fn six_columns_neither_normals_nor_colours_ask_for_the_layout() {
        let e = err("1 2 3 0 0 1\n4 5 6 0.5 -3 2\n");
        assert!(
            e.starts_with("line 1: 6 columns: columns 4-6 are neither unit normals nor colours"),
            "{e}"
        );
        assert!(
            e.contains("line 2 has 0.5 -3 2") && e.contains("--columns x,y,z,_,_,_"),
            "{e}"
        );
    }

    #[test]
    fn nan_position_names_line_and_vertex() {
        assert_eq!(err("#c\n1 2 3\n1 nan 3\n"), "line 3: vertex 1: y is NaN");
    }

    #[test]
    fn garbage_token_is_named() {
        assert_eq!(
            err("1 2 3\n1 2 abc\n"),
            "line 2: column 3: \"abc\" is not a number"
        );
    }

    #[test]
    fn only_comments_is_no_points() {
        assert!(err("# nothing\n\n").contains("no points"));
        assert!(err("x y z\n").contains("no points"));
    }
}
