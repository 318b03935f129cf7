//! XYZ text clouds (`.xyz`, `.xyzn`, `.txt`, `.pts`): one point per line, 3 numbers
//! (`x y z`) or 6 (`x y z nx ny nz`), separated by whitespace and/or commas. Blank lines
//! and lines starting with `#` are skipped; every data line has the column count of the
//! first one.
//!
//! Cost: one pass over the bytes; memory is the output (capacity bounded by the number
//! of newlines, never by anything the file claims).

use super::{check_finite, parse_f64, Cloud, Lines, ReadErrorKind};

/// Parses an XYZ cloud.
pub fn parse_cloud(data: &[u8]) -> Result<Cloud, ReadErrorKind> {
    if data.is_empty() {
        return Err(ReadErrorKind::file("file is empty"));
    }
    // Each point needs a line of at least 6 bytes ("0 0 0\n"): reserve no more rows
    // than there are lines, nor than the bytes allow (a file of newlines reserves little).
    let newlines = data.iter().filter(|&&b| b == b'\n').count();
    let max_rows = (newlines + 1).min(data.len() / 6 + 1);
    let mut positions: Vec<[f64; 3]> = Vec::with_capacity(max_rows);
    let mut normals: Vec<[f64; 3]> = Vec::new();
    // (column count, line it was set by)
    let mut columns: Option<(usize, usize)> = None;
    let mut row = [0.0f64; 6];
    for next in Lines::new(data, 0, 1).texts() {
        let (n, line) = next?;
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut found = 0;
        for tok in line
            .split(|c: char| c.is_ascii_whitespace() || c == ',')
            .filter(|t| !t.is_empty())
        {
            if found < 6 {
                row[found] = parse_f64(tok, n, format_args!("column {}", found + 1))?;
            }
            found += 1;
        }
        match columns {
            None if found == 3 || found == 6 => {
                columns = Some((found, n));
                if found == 6 {
                    normals.reserve_exact(max_rows);
                }
            }
            None => {
                return Err(ReadErrorKind::line(
                    n,
                    format!("expected 3 or 6 numbers, found {found}"),
                ))
            }
            Some((c, first)) if c != found => {
                return Err(ReadErrorKind::line(
                    n,
                    format!("expected {c} numbers like line {first}, found {found}"),
                ))
            }
            Some(_) => {}
        }
        let p = [row[0], row[1], row[2]];
        check_finite(p, positions.len() as u64, Some(n))?;
        positions.push(p);
        if found == 6 {
            normals.push([row[3], row[4], row[5]]);
        }
    }
    match columns {
        None => Err(ReadErrorKind::file(
            "no points: the file has only blank or comment lines",
        )),
        Some((c, _)) => Ok(Cloud {
            positions,
            normals: (c == 6).then_some(normals),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(data: &str) -> String {
        parse_cloud(data.as_bytes()).unwrap_err().to_string()
    }

    #[test]
    fn comments_commas_and_crlf() {
        let c = parse_cloud(b"# head\r\n\r\n1,2,3,0,0,1\r\n  4 5 6 0 1 0  \r\n").unwrap();
        assert_eq!(c.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!(c.normals, Some(vec![[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]));
    }

    #[test]
    fn column_count_must_match_first_line() {
        assert_eq!(
            err("1 2 3\n4 5 6 7\n"),
            "line 2: expected 3 numbers like line 1, found 4"
        );
        assert_eq!(err("1 2 3 4\n"), "line 1: expected 3 or 6 numbers, found 4");
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
    }
}
