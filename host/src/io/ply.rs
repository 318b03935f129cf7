//! PLY (Stanford polygon file): `ascii 1.0`, `binary_little_endian 1.0`,
//! `binary_big_endian 1.0`.
//!
//! The header becomes a list of elements with typed properties; the body is then walked
//! element by element in header order, every property of every row parsed (lists too,
//! since in binary their lengths decide where the next row starts) and only the wanted
//! ones kept. In ASCII each row is one line. Before a binary element is walked its
//! count times its minimum row size is checked against the bytes left, so a lying
//! header fails in O(1) without reserving anything.
//!
//! Cost: O(file size) time; memory is the output plus one row.

use super::{
    check_finite, push_fan, safe_capacity, At, Cloud, Lines, Mesh, ReadErrorKind, Scalar, Shown,
};

type Result<T> = core::result::Result<T, ReadErrorKind>;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    BinaryLe,
    BinaryBe,
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Scalar(Scalar),
    List { len: Scalar, item: Scalar },
}

impl Kind {
    /// Bytes of the property in a binary row (a list's length only, when
    /// empty).
    fn min_bytes(self) -> usize {
        match self {
            Kind::Scalar(t) => t.size(),
            Kind::List { len, .. } => len.size(),
        }
    }
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
    /// Header line declaring the element, for messages.
    line: usize,
}

impl Element {
    fn prop(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|p| p.name == name)
    }

    /// Bytes of a binary row with every list empty.
    fn min_row_bytes(&self) -> usize {
        self.props.iter().map(|p| p.kind.min_bytes()).sum()
    }

    /// `"vertices"` for the vertex element, `"'name' elements"` otherwise.
    fn plural(&self) -> String {
        match self.name.as_str() {
            "vertex" => "vertices".to_string(),
            "face" => "faces".to_string(),
            n => format!("'{n}' elements"),
        }
    }
}

#[derive(Debug)]
struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset where the body starts.
    body: usize,
    /// Line number of the first body line (ASCII).
    body_line: usize,
}

fn scalar_type(name: &str) -> Option<Scalar> {
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

const TYPES: &str = "char uchar short ushort int uint float double, or int8 .. float64";

fn parse_header(data: &[u8]) -> Result<Header> {
    if data.is_empty() {
        return Err(ReadErrorKind::file("file is empty"));
    }
    let mut lines = Lines::new(data, 0, 1);
    let (_, magic) = lines.next_text().unwrap_or(Ok((1, "")))?;
    if magic.trim() != "ply" {
        return Err(ReadErrorKind::line(
            1,
            format!(
                "not a PLY file: first line is {}, expected \"ply\"",
                Shown(magic)
            ),
        ));
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(next) = lines.next_text() else {
            return Err(ReadErrorKind::file(format!(
                "header has no end_header line ({} lines read)",
                lines.next_no() - 1
            )));
        };
        let (n, line) = next?;
        let toks: Vec<&str> = line.split_ascii_whitespace().collect();
        let Some((&key, args)) = toks.split_first() else {
            continue;
        };
        match key {
            "comment" | "obj_info" => {}
            "format" => {
                if encoding.is_some() {
                    return Err(ReadErrorKind::line(n, "second format line"));
                }
                let [fmt, version] = args else {
                    return Err(ReadErrorKind::line(
                        n,
                        "expected \"format <ascii|binary_little_endian|binary_big_endian> 1.0\"",
                    ));
                };
                encoding = Some(match *fmt {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::BinaryLe,
                    "binary_big_endian" => Encoding::BinaryBe,
                    other => {
                        return Err(ReadErrorKind::line(
                            n,
                            format!(
                                "unknown format {} (expected ascii, binary_little_endian \
                                 or binary_big_endian)",
                                Shown(other)
                            ),
                        ))
                    }
                });
                if !matches!(*version, "1.0" | "1") {
                    return Err(ReadErrorKind::unsupported(
                        At::Line(n),
                        format!("PLY version {} (only 1.0)", Shown(version)),
                    ));
                }
            }
            "element" => {
                let [name, count] = args else {
                    return Err(ReadErrorKind::line(
                        n,
                        "expected \"element <name> <count>\"",
                    ));
                };
                let count = count.parse::<u64>().map_err(|_| {
                    ReadErrorKind::line(
                        n,
                        format!(
                            "element {name}: count {} is not a non-negative integer",
                            Shown(count)
                        ),
                    )
                })?;
                elements.push(Element {
                    name: (*name).to_string(),
                    count,
                    props: Vec::new(),
                    line: n,
                });
            }
            "property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(ReadErrorKind::line(n, "property before any element"));
                };
                let ty = |t: &str| {
                    scalar_type(t).ok_or_else(|| {
                        ReadErrorKind::line(
                            n,
                            format!("unknown property type {} (expected {TYPES})", Shown(t)),
                        )
                    })
                };
                let (kind, name) = match args {
                    ["list", len, item, name] => {
                        let len = ty(len)?;
                        if !len.is_int() {
                            return Err(ReadErrorKind::line(
                                n,
                                format!(
                                    "list {name}: length type {} is not an integer",
                                    len.name()
                                ),
                            ));
                        }
                        (
                            Kind::List {
                                len,
                                item: ty(item)?,
                            },
                            name,
                        )
                    }
                    [t, name] if *t != "list" => (Kind::Scalar(ty(t)?), name),
                    _ => {
                        return Err(ReadErrorKind::line(
                            n,
                            "expected \"property <type> <name>\" or \
                             \"property list <length type> <item type> <name>\"",
                        ))
                    }
                };
                el.props.push(Property {
                    name: (*name).to_string(),
                    kind,
                });
            }
            "end_header" => break,
            other if other.parse::<f64>().is_ok() => {
                return Err(ReadErrorKind::line(
                    n,
                    format!(
                        "data line {} before end_header: the end_header line is missing",
                        Shown(line)
                    ),
                ))
            }
            other => {
                return Err(ReadErrorKind::line(
                    n,
                    format!(
                        "unknown header line starting with {} (expected comment, obj_info, \
                         format, element, property or end_header)",
                        Shown(other)
                    ),
                ))
            }
        }
    }
    let encoding = encoding.ok_or_else(|| ReadErrorKind::file("header has no \"format\" line"))?;
    Ok(Header {
        encoding,
        elements,
        body: lines.pos(),
        body_line: lines.next_no(),
    })
}

/// What the caller wants from each property of an element.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Skip,
    /// Store this scalar in row slot `k`.
    Slot(usize),
    /// Collect this list's items.
    List,
}

/// Where a row came from, for messages raised by the row callback.
#[derive(Clone, Copy, Debug)]
enum Loc {
    Line(usize),
    Byte(usize),
}

impl Loc {
    fn at(self) -> At {
        match self {
            Loc::Line(n) => At::Line(n),
            Loc::Byte(b) => At::Byte(b),
        }
    }

    fn line(self) -> Option<usize> {
        match self {
            Loc::Line(n) => Some(n),
            Loc::Byte(_) => None,
        }
    }
}

/// One row handed to the callback: element index, row index, slot values, list items.
struct Row<'r> {
    element: usize,
    index: u64,
    slots: &'r [f64],
    list: &'r [f64],
    loc: Loc,
}

/// Walks the whole body, calling `on_row` for rows of elements with any wanted property.
/// `roles[e][p]` says what to do with property `p` of element `e`.
fn walk(
    data: &[u8],
    h: &Header,
    roles: &[Vec<Role>],
    on_row: &mut dyn FnMut(Row<'_>) -> Result<()>,
) -> Result<()> {
    match h.encoding {
        Encoding::Ascii => walk_ascii(data, h, roles, on_row),
        Encoding::BinaryLe => walk_binary(data, h, roles, on_row, false),
        Encoding::BinaryBe => walk_binary(data, h, roles, on_row, true),
    }
}

/// Slots a row needs: one past the highest.
fn n_slots(roles: &[Role]) -> usize {
    roles
        .iter()
        .filter_map(|r| match r {
            Role::Slot(k) => Some(k + 1),
            _ => None,
        })
        .max()
        .unwrap_or(0)
}

fn walk_binary(
    data: &[u8],
    h: &Header,
    roles: &[Vec<Role>],
    on_row: &mut dyn FnMut(Row<'_>) -> Result<()>,
    big: bool,
) -> Result<()> {
    let mut pos = h.body;
    let mut slots = Vec::new();
    let mut list = Vec::new();
    for (ei, el) in h.elements.iter().enumerate() {
        if el.count == 0 || el.props.is_empty() {
            continue;
        }
        let remaining = data.len() - pos;
        let min_row = el.min_row_bytes();
        let has_lists = el.props.iter().any(|p| matches!(p.kind, Kind::List { .. }));
        let fits = el
            .count
            .checked_mul(min_row as u64)
            .is_some_and(|need| need <= remaining as u64);
        if !fits {
            return Err(ReadErrorKind::invalid(
                At::Byte(pos),
                format!(
                    "header declares {} {} of {}{} bytes but only {} bytes of data follow",
                    el.count,
                    el.plural(),
                    if has_lists { "at least " } else { "" },
                    min_row,
                    remaining
                ),
            ));
        }
        let wanted = roles[ei].iter().any(|r| *r != Role::Skip);
        if !wanted && !has_lists {
            // Checked above: count * min_row <= remaining, so this cannot overflow.
            pos += el.count as usize * min_row;
            continue;
        }
        slots.clear();
        slots.resize(n_slots(&roles[ei]), 0.0);
        if !has_lists {
            // Rows of one size (checked above to fit): each wanted scalar
            // read at its offset in the row, the others not decoded at all.
            let mut wanted = Vec::new();
            let mut offset = 0;
            for (p, role) in el.props.iter().zip(&roles[ei]) {
                if let (Kind::Scalar(t), Role::Slot(k)) = (p.kind, *role) {
                    wanted.push((offset, t, k));
                }
                offset += p.kind.min_bytes();
            }
            // Checked above: count * min_row <= remaining.
            let body = &data[pos..pos + el.count as usize * min_row];
            for (index, row) in body.chunks_exact(min_row.max(1)).enumerate() {
                for &(at, t, k) in &wanted {
                    // In range: `at + t.size()` is at most the row's size.
                    slots[k] = t.decode(&row[at..], big).unwrap_or(0.0);
                }
                on_row(Row {
                    element: ei,
                    index: index as u64,
                    slots: &slots,
                    list: &list,
                    loc: Loc::Byte(pos + index * min_row),
                })?;
            }
            pos += body.len();
            continue;
        }
        for index in 0..el.count {
            let start = pos;
            list.clear();
            for (p, role) in el.props.iter().zip(&roles[ei]) {
                let truncated = |pos: usize| {
                    ReadErrorKind::invalid(
                        At::Byte(pos),
                        format!(
                            "{} {index}: file ends inside property '{}'",
                            el.name, p.name
                        ),
                    )
                };
                match p.kind {
                    Kind::Scalar(t) => {
                        let v = t.decode(&data[pos..], big).ok_or_else(|| truncated(pos))?;
                        pos += t.size();
                        if let Role::Slot(k) = *role {
                            slots[k] = v;
                        }
                    }
                    Kind::List { len, item } => {
                        let n = len
                            .decode(&data[pos..], big)
                            .ok_or_else(|| truncated(pos))?;
                        if n < 0.0 {
                            return Err(ReadErrorKind::invalid(
                                At::Byte(pos),
                                format!(
                                    "{} {index}: list '{}' has negative length {n}",
                                    el.name, p.name
                                ),
                            ));
                        }
                        pos += len.size();
                        let left = data.len() - pos;
                        let need = n * item.size() as f64;
                        if need > left as f64 {
                            return Err(ReadErrorKind::invalid(
                                At::Byte(pos),
                                format!(
                                    "{} {index}: list '{}' of length {n} needs {need} bytes \
                                     but only {left} remain",
                                    el.name, p.name
                                ),
                            ));
                        }
                        // need <= left, an in-memory length: exact in f64 and in usize.
                        let n = n as usize;
                        if *role == Role::List {
                            for _ in 0..n {
                                list.push(item.decode(&data[pos..], big).unwrap_or(0.0));
                                pos += item.size();
                            }
                        } else {
                            pos += n * item.size();
                        }
                    }
                }
            }
            if wanted {
                on_row(Row {
                    element: ei,
                    index,
                    slots: &slots,
                    list: &list,
                    loc: Loc::Byte(start),
                })?;
            }
        }
    }
    Ok(())
}

fn walk_ascii(
    data: &[u8],
    h: &Header,
    roles: &[Vec<Role>],
    on_row: &mut dyn FnMut(Row<'_>) -> Result<()>,
) -> Result<()> {
    let mut lines = Lines::new(data, h.body, h.body_line);
    let mut toks: Vec<&str> = Vec::new();
    let mut slots = Vec::new();
    let mut list = Vec::new();
    for (ei, el) in h.elements.iter().enumerate() {
        if el.count == 0 || el.props.is_empty() {
            continue;
        }
        let wanted = roles[ei].iter().any(|r| *r != Role::Skip);
        slots.clear();
        slots.resize(n_slots(&roles[ei]), 0.0);
        for index in 0..el.count {
            let (n, line) = loop {
                let Some(next) = lines.next_text() else {
                    return Err(ReadErrorKind::line(
                        lines.next_no(),
                        format!("file ends after {index} of {} {}", el.count, el.plural()),
                    ));
                };
                let (n, line) = next?;
                if !line.trim().is_empty() {
                    break (n, line);
                }
            };
            toks.clear();
            toks.extend(line.split_ascii_whitespace());
            let mut it = toks.iter();
            list.clear();
            for (p, role) in el.props.iter().zip(&roles[ei]) {
                let missing = || {
                    ReadErrorKind::line(
                        n,
                        format!(
                            "{} {index}: line ends before property '{}' ({} values on the line)",
                            el.name,
                            p.name,
                            toks.len()
                        ),
                    )
                };
                let value = |t: Scalar, tok: &str| {
                    t.parse_text(tok).ok_or_else(|| {
                        ReadErrorKind::line(
                            n,
                            format!(
                                "{} {index}: property '{}': {} is not a valid {}",
                                el.name,
                                p.name,
                                Shown(tok),
                                t.name()
                            ),
                        )
                    })
                };
                match p.kind {
                    Kind::Scalar(t) => {
                        let v = value(t, it.next().ok_or_else(missing)?)?;
                        if let Role::Slot(k) = *role {
                            slots[k] = v;
                        }
                    }
                    Kind::List { len, item } => {
                        let tok = it.next().ok_or_else(missing)?;
                        let count = value(len, tok)?;
                        if count < 0.0 || count > it.len() as f64 {
                            return Err(ReadErrorKind::line(
                                n,
                                format!(
                                    "{} {index}: list '{}' has length {count} but {} values \
                                     follow on the line",
                                    el.name,
                                    p.name,
                                    it.len()
                                ),
                            ));
                        }
                        for tok in it.by_ref().take(count as usize) {
                            let v = value(item, tok)?;
                            if *role == Role::List {
                                list.push(v);
                            }
                        }
                    }
                }
            }
            if it.len() > 0 {
                return Err(ReadErrorKind::line(
                    n,
                    format!(
                        "{} {index}: {} values on the line, the header declares {}",
                        el.name,
                        toks.len(),
                        toks.len() - it.len()
                    ),
                ));
            }
            if wanted {
                on_row(Row {
                    element: ei,
                    index,
                    slots: &slots,
                    list: &list,
                    loc: Loc::Line(n),
                })?;
            }
        }
    }
    Ok(())
}

/// The vertex element, its `x y z` slots (0-2), whether it has `nx ny nz` (slots
/// 3-5) and the types of its colour, when it has `red green blue` (slots 6-8).
struct VertexPlan {
    element: usize,
    roles: Vec<Role>,
    normals: bool,
    colors: Option<[Scalar; 3]>,
}

/// Names of a vertex colour, the first set found wins.
const COLOR_NAMES: [[&str; 3]; 3] = [
    ["red", "green", "blue"],
    ["r", "g", "b"],
    ["diffuse_red", "diffuse_green", "diffuse_blue"],
];

/// A colour channel of type `ty` as 8 bits: 8-bit integers as they are, wider ones
/// scaled from their full range (16 bits: 65535 is 255), floats from 0-1; out of
/// range values are clamped.
fn channel(ty: Scalar, v: f64) -> u8 {
    let full = match ty {
        Scalar::I8 | Scalar::U8 => 255.0,
        Scalar::I16 | Scalar::U16 => 65535.0,
        Scalar::I32 | Scalar::U32 | Scalar::I64 | Scalar::U64 => 4_294_967_295.0,
        Scalar::F32 | Scalar::F64 => 1.0,
    };
    let c = (v / full * 255.0).round();
    if c >= 255.0 {
        255
    } else if c > 0.0 {
        c as u8
    } else {
        0
    }
}

/// The plan of the vertex element; a cloud (`cloud`) also takes normals and colours.
fn vertex_plan(h: &Header, cloud: bool) -> Result<VertexPlan> {
    let element = h
        .elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| ReadErrorKind::file("header has no \"element vertex\""))?;
    let el = &h.elements[element];
    let mut roles = vec![Role::Skip; el.props.len()];
    let mut assign = |names: [&str; 3], first_slot: usize, required: bool| -> Result<bool> {
        let found = names.map(|name| el.prop(name));
        if found.iter().all(Option::is_none) && !required {
            return Ok(false);
        }
        for (k, (name, idx)) in names.iter().zip(found).enumerate() {
            let Some(idx) = idx else {
                return Err(ReadErrorKind::line(
                    el.line,
                    format!("element vertex has no property '{name}'"),
                ));
            };
            if let Kind::List { .. } = el.props[idx].kind {
                return Err(ReadErrorKind::line(
                    el.line,
                    format!("vertex property '{name}' is a list, expected a number"),
                ));
            }
            roles[idx] = Role::Slot(first_slot + k);
        }
        Ok(true)
    };
    assign(["x", "y", "z"], 0, true)?;
    let normals = cloud && assign(["nx", "ny", "nz"], 3, false)?;
    let mut colors = None;
    if cloud {
        // A colour is all three channels or none: a lone `red` is an extra property.
        for names in COLOR_NAMES {
            if names.iter().all(|n| el.prop(n).is_some()) && assign(names, 6, false)? {
                // `assign` checked that each is a scalar.
                colors = Some(
                    names.map(|name| match el.prop(name).map(|i| el.props[i].kind) {
                        Some(Kind::Scalar(t)) => t,
                        _ => Scalar::U8,
                    }),
                );
                break;
            }
        }
    }
    Ok(VertexPlan {
        element,
        roles,
        normals,
        colors,
    })
}

fn body_len(data: &[u8], h: &Header) -> usize {
    data.len() - h.body
}

/// Parses a PLY point cloud: `x y z` and, if present, `nx ny nz` and
/// `red green blue` (or `r g b`, `diffuse_red ..`) of element `vertex`.
pub fn parse_cloud(data: &[u8]) -> Result<Cloud> {
    let h = parse_header(data)?;
    let plan = vertex_plan(&h, true)?;
    let el = &h.elements[plan.element];
    if el.count == 0 {
        return Err(ReadErrorKind::line(
            el.line,
            "element vertex declares 0 vertices",
        ));
    }
    let min_row = match h.encoding {
        Encoding::Ascii => 2 * el.props.len(),
        _ => el.min_row_bytes(),
    };
    let cap = safe_capacity(el.count, body_len(data, &h), min_row);
    let mut positions = Vec::with_capacity(cap);
    let mut normals = Vec::with_capacity(if plan.normals { cap } else { 0 });
    let mut colors = Vec::with_capacity(if plan.colors.is_some() { cap } else { 0 });
    let mut roles: Vec<Vec<Role>> = h
        .elements
        .iter()
        .map(|e| vec![Role::Skip; e.props.len()])
        .collect();
    roles[plan.element] = plan.roles;
    walk(data, &h, &roles, &mut |row| {
        let p = [row.slots[0], row.slots[1], row.slots[2]];
        check_finite(p, row.index, row.loc.line())?;
        positions.push(p);
        if plan.normals {
            normals.push([row.slots[3], row.slots[4], row.slots[5]]);
        }
        if let Some(types) = plan.colors {
            colors.push([0, 1, 2].map(|k| channel(types[k], row.slots[6 + k])));
        }
        Ok(())
    })?;
    Ok(Cloud {
        positions,
        normals: plan.normals.then_some(normals),
        colors: plan.colors.map(|_| colors),
        invalid: 0,
    })
}

/// Parses a PLY mesh: vertex `x y z` and element `face` with list `vertex_indices`
/// (or `vertex_index`), polygons triangulated as fans.
pub fn parse_mesh(data: &[u8]) -> Result<Mesh> {
    let h = parse_header(data)?;
    let plan = vertex_plan(&h, false)?;
    let nv = h.elements[plan.element].count;
    let fi = h
        .elements
        .iter()
        .position(|e| e.name == "face")
        .ok_or_else(|| ReadErrorKind::file("header has no \"element face\""))?;
    let fel = &h.elements[fi];
    let li = fel
        .prop("vertex_indices")
        .or_else(|| fel.prop("vertex_index"))
        .ok_or_else(|| {
            ReadErrorKind::line(
                fel.line,
                "element face has no list property 'vertex_indices'",
            )
        })?;
    match fel.props[li].kind {
        Kind::List { item, .. } if item.is_int() => {}
        _ => {
            return Err(ReadErrorKind::line(
                fel.line,
                format!(
                    "face property '{}' is not a list of integers",
                    fel.props[li].name
                ),
            ))
        }
    }
    let mut roles: Vec<Vec<Role>> = h
        .elements
        .iter()
        .map(|e| vec![Role::Skip; e.props.len()])
        .collect();
    roles[plan.element] = plan.roles;
    roles[fi][li] = Role::List;
    let body = body_len(data, &h);
    let min_row = |e: &Element| match h.encoding {
        Encoding::Ascii => 2 * e.props.len(),
        _ => e.min_row_bytes(),
    };
    let mut vertices =
        Vec::with_capacity(safe_capacity(nv, body, min_row(&h.elements[plan.element])));
    let mut triangles = Vec::with_capacity(safe_capacity(fel.count, body, min_row(fel)));
    let mut poly: Vec<u32> = Vec::new();
    walk(data, &h, &roles, &mut |row| {
        if row.element == plan.element {
            let p = [row.slots[0], row.slots[1], row.slots[2]];
            check_finite(p, row.index, row.loc.line())?;
            vertices.push(p);
            return Ok(());
        }
        if row.list.len() < 3 {
            return Err(ReadErrorKind::invalid(
                row.loc.at(),
                format!(
                    "face {}: {} vertex indices, a face needs at least 3",
                    row.index,
                    row.list.len()
                ),
            ));
        }
        poly.clear();
        for &v in row.list {
            if !(v >= 0.0 && v < nv as f64) {
                return Err(ReadErrorKind::invalid(
                    row.loc.at(),
                    format!(
                        "face {}: vertex index {v} is out of range (the file has {nv} vertices)",
                        row.index
                    ),
                ));
            }
            // 0 <= v < nv; only a file with more than u32::MAX vertices can fail here.
            poly.push(u32::try_from(v as u64).map_err(|_| {
                ReadErrorKind::invalid(
                    row.loc.at(),
                    format!(
                        "face {}: vertex index {v} does not fit in 32 bits",
                        row.index
                    ),
                )
            })?);
        }
        push_fan(&poly, &mut triangles);
        Ok(())
    })?;
    Ok((vertices, triangles))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(data: &[u8]) -> String {
        parse_cloud(data).unwrap_err().to_string()
    }

    #[test]
    fn ascii_with_comments_crlf_and_trailing_list_element() {
        let data = b"ply\r\nformat ascii 1.0\r\ncomment hi\r\nobj_info x 1\r\n\
            element vertex 2\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n\
            property uchar red\r\nelement range_grid 3\r\nproperty list uchar int vertex_indices\r\n\
            end_header\r\n1 2 3 255\r\n4 5 6 0\r\n1 0\r\n0\r\n2 5 6\r\n";
        let c = parse_cloud(data).unwrap();
        assert_eq!(c.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!(c.normals, None);
    }

    #[test]
    fn binary_skips_lists_inside_vertex_rows() {
        let mut data = b"ply\nformat binary_big_endian 1.0\nelement vertex 2\n\
            property list uchar short junk\nproperty double x\nproperty double y\n\
            property double z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n"
            .to_vec();
        for (i, n) in [(0.5f64, 2u8), (1.5, 0)] {
            data.push(n);
            for _ in 0..n {
                data.extend_from_slice(&7i16.to_be_bytes());
            }
            for v in [i, -i, 2.0 * i] {
                data.extend_from_slice(&v.to_be_bytes());
            }
            for v in [0.0f32, f32::NAN, 1.0] {
                data.extend_from_slice(&v.to_be_bytes());
            }
        }
        let c = parse_cloud(&data).unwrap();
        assert_eq!(c.positions, vec![[0.5, -0.5, 1.0], [1.5, -1.5, 3.0]]);
        let n = c.normals.unwrap();
        assert_eq!(n.len(), 2);
        assert!(n[1][1].is_nan(), "normals are passed through unchanged");
    }

    #[test]
    fn binary_rows_without_lists_read_each_wanted_scalar_at_its_offset() {
        // Fixed-size rows (the fast path): skipped scalars of several sizes
        // between and around the wanted ones, both byte orders, and an element
        // before the vertices that is skipped whole.
        for big in [false, true] {
            let order = if big { "big" } else { "little" };
            let mut data = format!(
                "ply\nformat binary_{order}_endian 1.0\nelement camera 1\nproperty int id\n\
                 element vertex 3\nproperty uchar flag\nproperty double x\nproperty short junk\n\
                 property float y\nproperty float z\nproperty double more\n\
                 property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
            )
            .into_bytes();
            data.extend_from_slice(&9i32.to_le_bytes());
            for i in 0..3u8 {
                let x = f64::from(i) + 0.25;
                let (y, z) = (-f32::from(i), 1e-3 * f32::from(i));
                data.push(200);
                data.extend_from_slice(&if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
                data.extend_from_slice(&[0x7f, 0x01]);
                for v in [y, z] {
                    data.extend_from_slice(&if big {
                        v.to_be_bytes()
                    } else {
                        v.to_le_bytes()
                    });
                }
                data.extend_from_slice(&[0xAB; 8]);
                data.extend_from_slice(&[i, 10 * i, 255 - i]);
            }
            let c = parse_cloud(&data).unwrap();
            let want: Vec<[f64; 3]> = (0..3u8)
                .map(|i| {
                    let i = f32::from(i);
                    [f64::from(i) + 0.25, f64::from(-i), f64::from(1e-3 * i)]
                })
                .collect();
            assert_eq!(c.positions, want, "{order} endian");
            assert_eq!(
                c.colors,
                Some(vec![[0, 0, 255], [1, 10, 254], [2, 20, 253]]),
                "{order} endian"
            );
        }
    }

    #[test]
    fn lying_binary_count_fails_before_allocating() {
        let mut data = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n\
            property float x\nproperty float y\nproperty float z\nend_header\n"
            .to_vec();
        data.extend_from_slice(&[0u8; 120]);
        let e = err(&data);
        assert!(
            e.contains("header declares 4000000000 vertices of 12 bytes but only 120 bytes"),
            "{e}"
        );
    }

    #[test]
    fn header_errors_name_the_line() {
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty flaot x\nend_header\n");
        assert!(
            e.starts_with("line 4: unknown property type \"flaot\""),
            "{e}"
        );
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
        assert!(e.contains("no end_header"), "{e}");
        let e = err(b"ply\nformat binary_middle_endian 1.0\nend_header\n");
        assert!(e.contains("line 2: unknown format"), "{e}");
        let e = err(
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n\
            property float y\nend_header\n1 2\n",
        );
        assert!(e.contains("no property 'z'"), "{e}");
    }

    #[test]
    fn ascii_list_length_larger_than_line_is_an_error() {
        let e = err(
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n\
            property float y\nproperty float z\nproperty list int int l\nend_header\n\
            1 2 3 -1\n",
        );
        assert!(
            e.contains("line 9: vertex 0: list 'l' has length -1"),
            "{e}"
        );
    }

    #[test]
    fn mesh_faces_are_fans_and_indices_checked() {
        let head = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
            property float y\nproperty float z\nelement face 1\n\
            property list uchar int vertex_indices\nend_header\n\
            0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
        let (v, t) = parse_mesh(format!("{head}4 0 1 2 3\n").as_bytes()).unwrap();
        assert_eq!(v.len(), 4);
        assert_eq!(t, vec![[0, 1, 2], [0, 2, 3]]);
        let e = parse_mesh(format!("{head}3 0 1 4\n").as_bytes())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 14: face 0: vertex index 4 is out of range"),
            "{e}"
        );
    }
}
