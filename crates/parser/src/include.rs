//! Mitsuba's document-level elements, handled before any plugin is read: `<include>` (another
//! scene file's children spliced in place, at the top level or inside an object), `<path>`
//! (a folder searched for included and referenced files), and `<default>` (a `$name` parameter's
//! value, allowed anywhere; the first definition wins, `-D` overrides win over all). Then `$name`
//! is substituted in every attribute.
//!
//! Every position remembers its file ([`Pos::file`]); [`Sources`] turns positions into
//! `file:line:column` and appends the chain of includes to error messages.

use crate::error::{ParseError, Result};
use crate::limits::Limits;
use crate::scene::{SourceLocation, Warning};
use crate::values;
use crate::xml::{parse_document, Element, Pos};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Includes nested deeper than this are an error (a cycle is caught earlier by name).
const MAX_INCLUDE_DEPTH: usize = 32;

/// Value tags: inside a nested `<include>` Mitsuba keeps only the included objects.
const VALUE_TAGS: &[&str] = &[
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "srgb",
    "spectrum",
    "point",
    "vector",
    "transform",
];

/// One file of the scene: the scene file (index 0) or an included one.
#[derive(Clone, Debug)]
pub(crate) struct SourceFile {
    pub path: PathBuf,
    /// Absolute folder of the file: relative names inside it are looked up here first.
    pub dir: PathBuf,
    /// The `<include>` that brought this file in.
    pub included_at: Option<Pos>,
}

/// The files of a scene and the `<path>` search folders.
#[derive(Clone, Debug)]
pub(crate) struct Sources {
    pub files: Vec<SourceFile>,
    /// Folders from `<path>`, in document order (later ones are searched first, as Mitsuba
    /// prepends them to its file resolver).
    pub search: Vec<PathBuf>,
}

fn absolute_dir(file: &Path) -> PathBuf {
    let parent = file.parent().unwrap_or(Path::new(""));
    std::path::absolute(parent).unwrap_or_else(|_| parent.to_path_buf())
}

impl Sources {
    pub fn new(main: &Path) -> Self {
        Sources {
            files: vec![SourceFile {
                path: main.to_path_buf(),
                dir: absolute_dir(main),
                included_at: None,
            }],
            search: Vec::new(),
        }
    }

    pub fn location(&self, pos: Pos) -> SourceLocation {
        let file = self.files.get(pos.file as usize).unwrap_or(&self.files[0]);
        SourceLocation {
            file: file.path.clone(),
            line: pos.line,
            column: pos.column,
        }
    }

    /// " (included from b.xml:3:5, included from main.xml:9:3)" for positions in included files.
    pub fn chain(&self, pos: Pos) -> String {
        let mut out = String::new();
        let mut at = self
            .files
            .get(pos.file as usize)
            .and_then(|f| f.included_at);
        let mut guard = 0;
        while let Some(p) = at {
            out.push_str(if out.is_empty() { " (" } else { ", " });
            out.push_str(&format!("included from {}", self.location(p)));
            at = self.files.get(p.file as usize).and_then(|f| f.included_at);
            guard += 1;
            if guard > MAX_INCLUDE_DEPTH {
                break;
            }
        }
        if !out.is_empty() {
            out.push(')');
        }
        out
    }

    pub fn err(&self, pos: Pos, message: impl Into<String>) -> ParseError {
        ParseError {
            location: self.location(pos),
            message: format!("{}{}", message.into(), self.chain(pos)),
        }
    }

    pub fn warning(&self, pos: Pos, message: impl Into<String>) -> Warning {
        Warning {
            location: self.location(pos),
            message: format!("{}{}", message.into(), self.chain(pos)),
        }
    }

    /// Finds a file named in the scene at `pos`: absolute names as they are; relative ones in
    /// the folder of the file that names them, then in the `<path>` folders (last first), then
    /// in the scene file's folder. When none exists, the first candidate (for messages).
    pub fn resolve(&self, name: &str, pos: Pos) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        let own = self
            .files
            .get(pos.file as usize)
            .unwrap_or(&self.files[0])
            .dir
            .join(p);
        let candidates = std::iter::once(own.clone())
            .chain(self.search.iter().rev().map(|d| d.join(p)))
            .chain(std::iter::once(self.files[0].dir.join(p)));
        for c in candidates {
            if c.exists() {
                return c;
            }
        }
        own
    }
}

/// What [`expand`] produces: the tree with includes spliced in and `$name`s substituted.
pub(crate) struct Expanded {
    pub root: Element,
    pub sources: Sources,
    pub warnings: Vec<Warning>,
}

struct Expander<'l> {
    sources: Sources,
    defaults: HashMap<String, String>,
    warnings: Vec<Warning>,
    /// Names a `<default>` has defined (a `-D` override is not one: it wins silently).
    defined: std::collections::HashSet<String>,
    limits: &'l Limits,
    /// How many bytes included files and `$name` substitution may still add to the document:
    /// a long default referenced a million times must not inflate a small file into gigabytes.
    growth: u64,
}

fn set_file(elem: &mut Element, file: u32) {
    elem.pos.file = file;
    for a in &mut elem.attrs {
        a.value_pos.file = file;
    }
    for c in &mut elem.children {
        set_file(c, file);
    }
}

impl Expander<'_> {
    fn attr<'e>(&self, e: &'e Element, name: &str) -> Result<&'e crate::xml::Attr> {
        e.attr(name).ok_or_else(|| {
            self.sources.err(
                e.pos,
                format!("missing required attribute '{name}' on <{}>", e.tag),
            )
        })
    }

    /// Substitutes the defaults known so far (for `<include>` and `<path>` names).
    fn substituted(&self, a: &crate::xml::Attr, tag: &str) -> Result<String> {
        values::substitute(&a.value, &self.defaults).map_err(|name| {
            self.sources.err(
                a.value_pos,
                format!(
                    "undefined parameter '${name}' in attribute '{}' of <{tag}>",
                    a.name
                ),
            )
        })
    }

    fn include(&mut self, inc: &Element, depth: usize) -> Result<Element> {
        let attr = self.attr(inc, "filename")?;
        let name = self.substituted(attr, "include")?;
        let path = self.sources.resolve(&name, attr.value_pos);
        if depth >= MAX_INCLUDE_DEPTH {
            return Err(self.sources.err(
                inc.pos,
                format!("includes nested more than {MAX_INCLUDE_DEPTH} deep"),
            ));
        }
        let canonical = std::fs::canonicalize(&path).ok();
        let mut at = Some(inc.pos);
        while let Some(p) = at {
            let f = &self.sources.files[p.file as usize];
            if canonical.is_some() && std::fs::canonicalize(&f.path).ok() == canonical {
                return Err(self.sources.err(
                    attr.value_pos,
                    format!("'{name}' includes itself (an include cycle)"),
                ));
            }
            at = f.included_at;
        }
        let cannot_read = |e: String| {
            self.sources.err(
                attr.value_pos,
                format!(
                    "cannot read included file '{name}' (looked for '{}'): {e}",
                    path.display()
                ),
            )
        };
        let size = crate::files::regular_file_size(&path).map_err(cannot_read)?;
        self.growth = self.growth.checked_sub(size).ok_or_else(|| {
            self.sources.err(
                attr.value_pos,
                "the included files make the scene larger than the scene_bytes limit (raise with --limit scene_bytes=N)",
            )
        })?;
        let text = std::fs::read_to_string(&path).map_err(|e| cannot_read(e.to_string()))?;
        let id = self.sources.files.len() as u32;
        self.sources.files.push(SourceFile {
            path: path.clone(),
            dir: absolute_dir(&path),
            included_at: Some(inc.pos),
        });
        let mut root =
            parse_document(&text, &path, self.limits.nesting_depth).map_err(|e| ParseError {
                message: format!(
                    "{}{}",
                    e.message,
                    self.sources.chain(Pos {
                        file: id,
                        ..inc.pos
                    })
                ),
                ..e
            })?;
        set_file(&mut root, id);
        if root.tag != "scene" {
            return Err(self.sources.err(
                root.pos,
                format!(
                    "an included file must have a <scene> root element, found <{}>",
                    root.tag
                ),
            ));
        }
        Ok(root)
    }

    /// Expands `elem`'s children in document order; `nested` is true inside objects.
    fn children(&mut self, elem: &mut Element, nested: bool, depth: usize) -> Result<()> {
        let children = std::mem::take(&mut elem.children);
        let mut out = Vec::with_capacity(children.len());
        for mut child in children {
            match child.tag.as_str() {
                "path" => {
                    let attr = self.attr(&child, "value")?;
                    let value = self.substituted(attr, "path")?;
                    let p = Path::new(&value);
                    let dir = if p.is_absolute() {
                        p.to_path_buf()
                    } else {
                        self.sources.files[child.pos.file as usize].dir.join(p)
                    };
                    if !dir.is_dir() {
                        return Err(self.sources.err(
                            attr.value_pos,
                            format!(
                                "<path> folder '{value}' does not exist (looked for '{}')",
                                dir.display()
                            ),
                        ));
                    }
                    self.sources.search.push(dir);
                }
                "default" => {
                    let name = self.attr(&child, "name")?.value.clone();
                    let value = self.attr(&child, "value")?.value.clone();
                    if !self.defined.insert(name.clone()) {
                        self.warnings.push(self.sources.warning(
                            child.pos,
                            format!(
                                "<default name=\"{name}\"> is given again; the first value is used"
                            ),
                        ));
                    }
                    self.defaults.entry(name).or_insert(value);
                }
                "include" => {
                    let mut root = self.include(&child, depth)?;
                    self.children(&mut root, nested, depth + 1)?;
                    for c in root.children {
                        if nested && VALUE_TAGS.contains(&c.tag.as_str()) {
                            // Mitsuba keeps only objects from an include inside an object.
                            self.warnings.push(self.sources.warning(
                                c.pos,
                                format!(
                                    "{} from a file included inside <{}> is ignored (as Mitsuba does)",
                                    crate::props::describe(&c),
                                    elem.tag
                                ),
                            ));
                        } else {
                            out.push(c);
                        }
                    }
                }
                _ => {
                    self.children(&mut child, true, depth)?;
                    out.push(child);
                }
            }
        }
        elem.children = out;
        Ok(())
    }

    fn substitute(&mut self, elem: &mut Element) -> Result<()> {
        for child in &mut elem.children {
            for a in &mut child.attrs {
                let value = values::substitute(&a.value, &self.defaults).map_err(|name| {
                    self.sources.err(
                        a.value_pos,
                        format!(
                            "undefined parameter '${name}' in attribute '{}' of <{}> (add <default name=\"{name}\" .../> or -D {name}=...)",
                            a.name, child.tag
                        ),
                    )
                })?;
                let added = value.len().saturating_sub(a.value.len()) as u64;
                self.growth = self.growth.checked_sub(added).ok_or_else(|| {
                    self.sources.err(
                        a.value_pos,
                        "substituting <default> values makes the scene larger than the scene_bytes limit (raise with --limit scene_bytes=N)",
                    )
                })?;
                a.value = value;
            }
            self.substitute(child)?;
        }
        Ok(())
    }
}

/// Splices includes, records `<path>` folders and defaults, and substitutes `$name` parameters
/// (with every default of the document: one given after its first use is accepted too).
pub(crate) fn expand(
    mut root: Element,
    path: &Path,
    overrides: &[(String, String)],
    limits: &Limits,
) -> Result<Expanded> {
    let mut ex = Expander {
        sources: Sources::new(path),
        defaults: overrides.iter().cloned().collect(),
        warnings: Vec::new(),
        defined: Default::default(),
        limits,
        growth: limits.scene_bytes,
    };
    ex.children(&mut root, false, 0)?;
    ex.substitute(&mut root)?;
    Ok(Expanded {
        root,
        sources: ex.sources,
        warnings: ex.warnings,
    })
}
