//! A small element tree with source positions, built with quick-xml. Scene files are tiny, so
//! a tree is simpler than streaming, and it lets plugins look at their children in any order.

use crate::error::{ParseError, Result};
use crate::scene::SourceLocation;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;
use std::path::Path;

/// A 1-based line and column (columns count characters, a tab is one column), and which file
/// of the scene it is in: 0 is the scene file, others are `<include>`d files (see
/// `include::Sources`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub(crate) struct Pos {
    pub line: u32,
    pub column: u32,
    pub file: u32,
}

/// One attribute with the position of its value's first character.
#[derive(Clone, Debug)]
pub(crate) struct Attr {
    pub name: String,
    pub value: String,
    pub value_pos: Pos,
}

/// One element: tag name, attributes in document order, child elements, and where it starts.
#[derive(Clone, Debug)]
pub(crate) struct Element {
    pub tag: String,
    pub attrs: Vec<Attr>,
    pub children: Vec<Element>,
    pub pos: Pos,
}

impl Element {
    /// The attribute called `name`, if present.
    pub fn attr(&self, name: &str) -> Option<&Attr> {
        self.attrs.iter().find(|a| a.name == name)
    }

    /// The attribute's value, if present.
    pub fn attr_value(&self, name: &str) -> Option<&str> {
        self.attr(name).map(|a| a.value.as_str())
    }
}

/// Maps byte offsets to line:column. Columns count characters, so finding one means counting
/// from somewhere on its line: the index remembers the last answer and counts on from there
/// when the next offset is further along the same line (the parser asks in document order), so
/// a 10 MB line costs one pass, not one pass per element on it.
pub(crate) struct LineIndex<'a> {
    text: &'a str,
    starts: Vec<usize>,
    /// The last answer: (byte offset, line index, 0-based column).
    last: std::cell::Cell<(usize, usize, usize)>,
}

impl<'a> LineIndex<'a> {
    pub fn new(text: &'a str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex {
            text,
            starts,
            last: std::cell::Cell::new((0, 0, 0)),
        }
    }

    pub fn pos(&self, offset: usize) -> Pos {
        let offset = offset.min(self.text.len());
        let line = self.starts.partition_point(|&s| s <= offset) - 1;
        let start = self.starts[line];
        let (last_offset, last_line, last_column) = self.last.get();
        let (from, base) = if last_line == line && last_offset <= offset {
            (last_offset, last_column)
        } else {
            (start, 0)
        };
        let column = base
            + self
                .text
                .get(from..offset)
                .map_or(offset - from, |s| s.chars().count());
        self.last.set((offset, line, column));
        Pos {
            line: (line + 1).min(u32::MAX as usize) as u32,
            column: (column + 1).min(u32::MAX as usize) as u32,
            file: 0,
        }
    }
}

pub(crate) fn location(file: &Path, pos: Pos) -> SourceLocation {
    SourceLocation {
        file: file.to_path_buf(),
        line: pos.line,
        column: pos.column,
    }
}

fn error(file: &Path, pos: Pos, message: impl Into<String>) -> ParseError {
    ParseError {
        location: location(file, pos),
        message: message.into(),
    }
}

/// Byte offset of `part` inside `whole`, when `part` is a sub-slice of it.
fn offset_in(whole: &str, part: &str) -> Option<usize> {
    let w = whole.as_ptr() as usize;
    let p = part.as_ptr() as usize;
    (p >= w && p + part.len() <= w + whole.len()).then(|| p - w)
}

fn element(
    text: &str,
    lines: &LineIndex,
    file: &Path,
    start: &BytesStart,
    offset: usize,
) -> Result<Element> {
    let pos = lines.pos(offset);
    let tag = start.name().as_ref().to_string();
    let mut attrs = Vec::new();
    for attr in start.attributes() {
        let attr =
            attr.map_err(|e| error(file, pos, format!("malformed attribute in <{tag}>: {e}")))?;
        let name = attr.key.as_ref().to_string();
        let name_pos = offset_in(text, attr.key.as_ref()).map_or(pos, |o| lines.pos(o));
        let value_pos = offset_in(text, &attr.value).map_or(name_pos, |o| lines.pos(o));
        let value = attr
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|e| {
                error(
                    file,
                    value_pos,
                    format!("malformed value of attribute '{name}' in <{tag}>: {e}"),
                )
            })?
            .into_owned();
        attrs.push(Attr {
            name,
            value,
            value_pos,
        });
    }
    Ok(Element {
        tag,
        attrs,
        children: Vec::new(),
        pos,
    })
}

/// Parses a whole document into its root element. Malformed XML is reported at the position
/// quick-xml detected it. Elements nested deeper than `max_depth` are an error: everything
/// that walks the tree (substitution, plugin parsers, even dropping it) may then recurse
/// without a depth that the input controls.
pub(crate) fn parse_document(text: &str, file: &Path, max_depth: u32) -> Result<Element> {
    let lines = LineIndex::new(text);
    let mut reader = Reader::from_str(text);
    let mut stack: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    loop {
        let offset = reader.buffer_position() as usize;
        let event = reader.read_event().map_err(|e| {
            error(
                file,
                lines.pos(reader.error_position() as usize),
                format!("malformed XML: {e}"),
            )
        })?;
        let finished = match event {
            Event::Start(s) => {
                if stack.len() >= max_depth as usize {
                    return Err(error(
                        file,
                        lines.pos(offset),
                        format!(
                            "elements are nested more than {max_depth} deep (raise with --limit nesting_depth=N)"
                        ),
                    ));
                }
                stack.push(element(text, &lines, file, &s, offset)?);
                None
            }
            Event::Empty(s) => Some(element(text, &lines, file, &s, offset)?),
            Event::End(_) => stack.pop(),
            Event::Text(t) => {
                if !t.trim().is_empty() && stack.is_empty() {
                    return Err(error(
                        file,
                        lines.pos(offset),
                        "malformed XML: text outside the root element",
                    ));
                }
                None
            }
            Event::Eof => {
                if let Some(open) = stack.last() {
                    return Err(error(
                        file,
                        open.pos,
                        format!("malformed XML: <{}> is never closed", open.tag),
                    ));
                }
                break;
            }
            _ => None,
        };
        if let Some(done) = finished {
            match stack.last_mut() {
                Some(parent) => parent.children.push(done),
                None if root.is_some() => {
                    return Err(error(
                        file,
                        done.pos,
                        format!("malformed XML: second root element <{}>", done.tag),
                    ))
                }
                None => root = Some(done),
            }
        }
    }
    root.ok_or_else(|| {
        error(
            file,
            lines.pos(text.len()),
            "malformed XML: the document has no root element",
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_of_elements_and_attributes() {
        let text = "<scene version=\"1\">\n\t<float name=\"fov\" value=\"4\"/>\n</scene>";
        let root = parse_document(text, Path::new("a.xml"), 64).unwrap();
        assert_eq!(
            root.pos,
            Pos {
                line: 1,
                column: 1,
                file: 0
            }
        );
        let f = &root.children[0];
        assert_eq!(f.tag, "float");
        assert_eq!(
            f.pos,
            Pos {
                line: 2,
                column: 2,
                file: 0
            }
        );
        let v = f.attr("value").unwrap();
        assert_eq!(
            v.value_pos,
            Pos {
                line: 2,
                column: 27,
                file: 0
            }
        );
        assert_eq!(v.value, "4");
    }

    #[test]
    fn unclosed_element_is_an_error() {
        let e = parse_document("<scene>\n  <shape>\n</scene>", Path::new("a.xml"), 64).unwrap_err();
        assert!(e.message.starts_with("malformed XML"), "{}", e.message);
        assert_eq!(e.location.line, 3);
    }

    #[test]
    fn columns_on_long_lines_and_out_of_order_queries() {
        let text = "ab\u{e9}cd\nxyz";
        let lines = LineIndex::new(text);
        assert_eq!(
            lines.pos(5),
            Pos {
                line: 1,
                column: 5,
                file: 0
            }
        ); // 'c' after a 2-byte char
        assert_eq!(
            lines.pos(6),
            Pos {
                line: 1,
                column: 6,
                file: 0
            }
        );
        assert_eq!(
            lines.pos(1),
            Pos {
                line: 1,
                column: 2,
                file: 0
            }
        ); // backwards: recounted
        assert_eq!(
            lines.pos(9),
            Pos {
                line: 2,
                column: 3,
                file: 0
            }
        );
        assert_eq!(
            lines.pos(2),
            Pos {
                line: 1,
                column: 3,
                file: 0
            }
        );
    }

    #[test]
    fn nesting_depth_is_capped() {
        let deep = format!("{}{}", "<a>".repeat(100), "</a>".repeat(100));
        let e = parse_document(&deep, Path::new("a.xml"), 64).unwrap_err();
        assert!(
            e.message.contains("nested more than 64 deep"),
            "{}",
            e.message
        );
        assert_eq!((e.location.line, e.location.column), (1, 193));
        assert!(parse_document(&deep, Path::new("a.xml"), 100).is_ok());
    }
}
