//! The PLY header: `ply`, `format <encoding> 1.0`, `comment`/`obj_info` lines, then elements
//! (`element <name> <count>`) each with its properties (`property <type> <name>` or `property
//! list <count type> <item type> <name>`), up to `end_header`.

use super::super::decode::Scalar;
use super::super::text::Lines;
use super::super::{Fault, Format};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Property {
    Scalar(Scalar),
    /// A length of type `count`, then that many `item`s.
    List {
        count: Scalar,
        item: Scalar,
    },
}

pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: usize,
    pub(super) properties: Vec<(String, Property)>,
    /// Line of the `element` declaration.
    pub(super) line: usize,
}

impl Element {
    /// Record size in bytes when no property is a list.
    pub(super) fn fixed_size(&self) -> Option<usize> {
        self.properties.iter().try_fold(0usize, |acc, (_, p)| match p {
            Property::Scalar(s) => acc.checked_add(s.size()),
            Property::List { .. } => None,
        })
    }

    /// Fewest bytes a binary record can take (every list empty).
    pub(super) fn min_size(&self) -> usize {
        let size = |p: &Property| match p {
            Property::Scalar(s) | Property::List { count: s, .. } => s.size(),
        };
        self.properties.iter().map(|(_, p)| size(p)).sum()
    }
}

/// The encoding, the elements in file order, and the lines positioned at the start of the data.
pub(super) fn parse_header(bytes: &[u8]) -> Result<(Format, Vec<Element>, Lines<'_>), Fault> {
    let mut lines = Lines::new(bytes, 1, 0);
    if lines.next().map(|(_, l)| l.trim_ascii()) != Some(b"ply") {
        return Err(Fault::line(1, "not a PLY file: the first line must be 'ply'"));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (n, raw) in &mut lines {
        // Comments are skipped unread: some writers put Latin-1 text there.
        let raw = raw.trim_ascii_start();
        if raw.starts_with(b"comment") || raw.starts_with(b"obj_info") {
            continue;
        }
        let text = std::str::from_utf8(raw)
            .map_err(|_| Fault::line(n, "header is not valid UTF-8 text"))?;
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        match words[..] {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["end_header"] => {
                let format =
                    format.ok_or_else(|| Fault::line(n, "no format line before end_header"))?;
                return Ok((format, elements, lines));
            }
            ["format", kind, _] => {
                format = Some(match kind {
                    "ascii" => Format::PlyAscii,
                    "binary_little_endian" => Format::PlyBinaryLittleEndian,
                    "binary_big_endian" => Format::PlyBinaryBigEndian,
                    _ => return Err(Fault::line(n, format!("unknown format '{kind}'"))),
                })
            }
            ["element", name, count] => {
                let count = count.parse::<usize>().map_err(|_| {
                    Fault::line(
                        n,
                        format!("element {name} count '{count}' is not a non-negative integer"),
                    )
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                    line: n,
                });
            }
            ["property", ..] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| Fault::line(n, "property before any element"))?;
                let (name, property) = match words[1..] {
                    ["list", count, item, name] => {
                        let count = scalar(n, count)?;
                        if !count.is_integer() {
                            return Err(Fault::line(
                                n,
                                format!("list length type of {name} is not an integer type"),
                            ));
                        }
                        (name, Property::List { count, item: scalar(n, item)? })
                    }
                    [ty, name] => (name, Property::Scalar(scalar(n, ty)?)),
                    _ => return Err(Fault::line(n, format!("malformed property line '{text}'"))),
                };
                element.properties.push((name.to_string(), property));
            }
            // Anything else may declare data we would then misread, so it is an error.
            _ => return Err(Fault::line(n, format!("unknown header line '{}'", text.trim()))),
        }
    }
    Err(Fault::whole("no end_header line: the header never ends"))
}

fn scalar(line: usize, name: &str) -> Result<Scalar, Fault> {
    Ok(match name {
        "char" | "int8" => Scalar::I8,
        "uchar" | "uint8" => Scalar::U8,
        "short" | "int16" => Scalar::I16,
        "ushort" | "uint16" => Scalar::U16,
        "int" | "int32" => Scalar::I32,
        "uint" | "uint32" => Scalar::U32,
        "float" | "float32" => Scalar::F32,
        "double" | "float64" => Scalar::F64,
        _ => return Err(Fault::line(line, format!("unknown property type '{name}'"))),
    })
}
