//! Mitsuba's document-level elements, handled before any plugin is read: `<include>` (another
//! scene file's children spliced in place, at the top level or inside an object), `<path>`
//! (a folder searched for included and referenced files), and `<default>` (a `$name` parameter's
//! value, allowed anywhere; the first definition wins, `-D` overrides win over all). Then `$name`
//! is substituted in every attribute.
//!
//! Every position remembers its file ([`Pos::file`]); [`Sources`] turns positions into
//! `file:line:column` and appends the chain of includes to error messages.
//!
//! Relative file names are found as Mitsuba 3.9.1's file resolver finds them (its
//! `src/core/parser.cpp`; every rule below was checked against Mitsuba 3.9.1 on a test layout,
//! see `crates/parser/tests/resolver.rs`). A resolver is a list of folders, searched in order;
//! the current working directory always comes last.
//! - The scene file's resolver starts as [the scene file's folder]. A `<path>` (only as a
//!   direct child of a file's `<scene>`) is put in front of the resolver of the file that holds
//!   it, so later `<path>`s are searched first.
//! - A `<path value>` is taken relative to the folder of the file that holds it; if that folder
//!   does not exist, it is looked up with that file's resolver (so an included file's
//!   `../../common` may also be found from the scene file's folder). A folder found nowhere is an
//!   error.
//! - `<include filename>` is looked up in the folder of the file that holds it, then with that
//!   file's resolver. The included file is read with that list ([the including file's folder] +
//!   the including file's resolver) as its resolver; its own `<path>`s go in front of it and are
//!   forgotten when the include ends.
//! - Plugin file names (meshes, textures, environment maps, volumes) are resolved when Mitsuba
//!   instantiates the objects, after the whole document is read: with the scene file's final
//!   resolver (every `<path>` of the scene file itself, the last first, wherever it stands, then
//!   the scene file's folder), whichever file names them. An included file's own folder and its
//!   `<path>`s do not count.
//! - A `<spectrum filename>` is read while parsing, with the resolver in effect at that point
//!   (in an included file: the including file's folder and resolver, with the included file's
//!   `<path>`s so far).

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

/// The files of a scene and the resolvers that find the files they name (module docs).
#[derive(Clone, Debug)]
pub(crate) struct Sources {
    pub files: Vec<SourceFile>,
    /// The scene file's final resolver, searched first to last (then the working directory):
    /// its `<path>` folders, the last one first, then its own folder. Plugin file names are
    /// looked up here.
    pub resolver: Vec<PathBuf>,
    /// The resolver in effect where each `<spectrum filename>` stands (keyed by the position of
    /// the `filename` value): spectrum files are read while Mitsuba parses.
    spectrum_resolvers: std::collections::HashMap<Pos, std::rc::Rc<Vec<PathBuf>>>,
}

/// The first existing `folder/name` of `folders`, then of the working directory; `None` when
/// there is none. An absolute `name` is itself or nothing.
fn find_in(folders: &[PathBuf], name: &str) -> Option<PathBuf> {
    let p = Path::new(name);
    if p.is_absolute() {
        return p.exists().then(|| p.to_path_buf());
    }
    folders
        .iter()
        .map(|d| d.join(p))
        .chain(std::env::current_dir().ok().map(|d| d.join(p)))
        .find(|c| c.exists())
}

/// Where `name` was looked for, for messages: "'a/x', 'b/x' and 'x' (the working directory)".
fn looked_for(folders: &[PathBuf], name: &str) -> String {
    let p = Path::new(name);
    if p.is_absolute() {
        return format!("'{}'", p.display());
    }
    let mut all: Vec<String> = folders
        .iter()
        .map(|d| format!("'{}'", d.join(p).display()))
        .collect();
    if let Ok(cwd) = std::env::current_dir() {
        all.push(format!(
            "'{}' (the working directory)",
            cwd.join(p).display()
        ));
    }
    match all.len() {
        0 => String::new(),
        1 => all.remove(0),
        n => format!("{} and {}", all[..n - 1].join(", "), all[n - 1]),
    }
}

fn absolute_dir(file: &Path) -> PathBuf {
    let parent = file.parent().unwrap_or(Path::new(""));
    std::path::absolute(parent).unwrap_or_else(|_| parent.to_path_buf())
}

impl Sources {
    pub fn new(main: &Path) -> Self {
        let dir = absolute_dir(main);
        Sources {
            files: vec![SourceFile {
                path: main.to_path_buf(),
                dir: dir.clone(),
                included_at: None,
            }],
            resolver: vec![dir],
            spectrum_resolvers: Default::default(),
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

    /// Finds a plugin's file named in the scene at `pos` as Mitsuba does (module docs): with the
    /// scene file's resolver, whichever file names it. `Err` says where it was looked for (and
    /// that it exists next to the included file naming it, if it does: Mitsuba does not look
    /// there).
    pub fn resolve(&self, name: &str, pos: Pos) -> std::result::Result<PathBuf, String> {
        find_in(&self.resolver, name).ok_or_else(|| self.not_found(&self.resolver, name, pos))
    }

    /// Finds the file of a `<spectrum filename>` at `pos` with the resolver in effect there.
    pub fn resolve_spectrum(&self, name: &str, pos: Pos) -> std::result::Result<PathBuf, String> {
        let folders = self
            .spectrum_resolvers
            .get(&pos)
            .map_or(&self.resolver[..], |r| &r[..]);
        find_in(folders, name).ok_or_else(|| self.not_found(folders, name, pos))
    }

    fn not_found(&self, folders: &[PathBuf], name: &str, pos: Pos) -> String {
        let mut m = format!("looked for {}", looked_for(folders, name));
        let file = self.files.get(pos.file as usize).unwrap_or(&self.files[0]);
        if pos.file != 0 && Path::new(name).is_relative() && file.dir.join(name).exists() {
            m += &format!(
                "; it is next to the included file '{}', but Mitsuba looks for file names only in the scene file's folder and the scene file's <path> folders",
                file.path.display()
            );
        }
        m
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
    /// The resolver of the file being read (front first; the working directory comes last):
    /// the scene file's grows into [`Sources::resolver`]; an included file's is pushed on top
    /// while it is read.
    resolvers: Vec<std::rc::Rc<Vec<PathBuf>>>,
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

    /// The resolver of the file being read.
    fn resolver(&self) -> &[PathBuf] {
        self.resolvers.last().map_or(&[][..], |r| &r[..])
    }

    /// Reads the file an `<include>` names. Returns its root and the resolver to read it with:
    /// the including file's folder in front of the including file's resolver.
    fn include(&mut self, inc: &Element, depth: usize) -> Result<(Element, Vec<PathBuf>)> {
        let attr = self.attr(inc, "filename")?;
        let name = self.substituted(attr, "include")?;
        let mut resolver = vec![self.sources.files[inc.pos.file as usize].dir.clone()];
        resolver.extend(self.resolver().iter().cloned());
        let Some(path) = find_in(&resolver, &name) else {
            return Err(self.sources.err(
                attr.value_pos,
                format!(
                    "cannot read included file '{name}': not found (looked for {})",
                    looked_for(&resolver, &name)
                ),
            ));
        };
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
        Ok((root, resolver))
    }

    /// `<path value>`: the folder relative to the file holding it, else found with that file's
    /// resolver; put in front of that resolver.
    fn path(&mut self, child: &Element, file_top: bool) -> Result<()> {
        let attr = self.attr(child, "value")?;
        let value = self.substituted(attr, "path")?;
        if !file_top {
            return Err(self.sources.err(
                child.pos,
                "<path> must be a direct child of <scene> (as in Mitsuba)",
            ));
        }
        let p = Path::new(&value);
        let own = self.sources.files[child.pos.file as usize].dir.join(p);
        let dir = if p.is_absolute() {
            p.exists().then(|| p.to_path_buf())
        } else if own.exists() {
            Some(own.clone())
        } else {
            find_in(self.resolver(), &value)
        };
        let Some(dir) = dir else {
            let mut places = vec![self.sources.files[child.pos.file as usize].dir.clone()];
            places.extend(self.resolver().iter().cloned());
            return Err(self.sources.err(
                attr.value_pos,
                format!(
                    "<path> folder '{value}' does not exist (looked for {})",
                    looked_for(&places, &value)
                ),
            ));
        };
        if !dir.is_dir() {
            self.warnings.push(self.sources.warning(
                attr.value_pos,
                format!(
                    "<path> '{value}' is not a folder ('{}'); nothing is found in it",
                    dir.display()
                ),
            ));
        }
        let top = self.resolvers.last_mut().expect("a resolver per file");
        std::rc::Rc::make_mut(top).insert(0, dir);
        Ok(())
    }

    /// Expands `elem`'s children in document order; `nested` is true inside objects, `file_top`
    /// for the children of a file's `<scene>`.
    fn children(
        &mut self,
        elem: &mut Element,
        nested: bool,
        file_top: bool,
        depth: usize,
    ) -> Result<()> {
        let children = std::mem::take(&mut elem.children);
        let mut out = Vec::with_capacity(children.len());
        for mut child in children {
            match child.tag.as_str() {
                "path" => self.path(&child, file_top)?,
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
                    let (mut root, resolver) = self.include(&child, depth)?;
                    self.resolvers.push(std::rc::Rc::new(resolver));
                    let expanded = self.children(&mut root, nested, true, depth + 1);
                    self.resolvers.pop();
                    expanded?;
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
                tag => {
                    if tag == "spectrum" {
                        if let Some(a) = child.attr("filename") {
                            let r = self.resolvers.last().expect("a resolver per file").clone();
                            self.sources.spectrum_resolvers.insert(a.value_pos, r);
                        }
                    }
                    self.children(&mut child, true, false, depth)?;
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
    let sources = Sources::new(path);
    let mut ex = Expander {
        resolvers: vec![std::rc::Rc::new(sources.resolver.clone())],
        sources,
        defaults: overrides.iter().cloned().collect(),
        warnings: Vec::new(),
        defined: Default::default(),
        limits,
        growth: limits.scene_bytes,
    };
    ex.children(&mut root, false, true, 0)?;
    ex.sources.resolver = ex.resolvers.pop().map(|r| (*r).clone()).unwrap_or_default();
    ex.substitute(&mut root)?;
    Ok(Expanded {
        root,
        sources: ex.sources,
        warnings: ex.warnings,
    })
}
