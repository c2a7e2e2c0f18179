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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
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

/// Maps byte offsets to line:column.
pub(crate) struct LineIndex<'a> {
    text: &'a str,
    starts: Vec<usize>,
}

impl<'a> LineIndex<'a> {
    pub fn new(text: &'a str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { text, starts }
    }

    pub fn pos(&self, offset: usize) -> Pos {
        let offset = offset.min(self.text.len());
        let line = self.starts.partition_point(|&s| s <= offset) - 1;
        let start = self.starts[line];
        let column = self
            .text
            .get(start..offset)
            .map_or(offset - start, |s| s.chars().count());
        Pos {
            line: line as u32 + 1,
            column: column as u32 + 1,
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
/// quick-xml detected it.
pub(crate) fn parse_document(text: &str, file: &Path) -> Result<Element> {
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
        let root = parse_document(text, Path::new("a.xml")).unwrap();
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
        let e = parse_document("<scene>\n  <shape>\n</scene>", Path::new("a.xml")).unwrap_err();
        assert!(e.message.starts_with("malformed XML"), "{}", e.message);
        assert_eq!(e.location.line, 3);
    }
}
