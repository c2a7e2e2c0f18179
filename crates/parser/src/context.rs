//! Parsing state shared by the plugin parsers: the scene file (for positions and relative
//! paths), the growing texture and bsdf tables, the id namespace, and the warnings.

use crate::error::{ParseError, Result};
use crate::limits::Limits;
use crate::scene::{Bsdf, BsdfId, Dialect, Texture, TextureId, Warning};
use crate::xml::{location, Element, Pos};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What an `id` names. Mitsuba has one id namespace for all objects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum IdTarget {
    Bsdf(BsdfId),
    Texture(TextureId),
    /// Shapes, sensors, emitters...: may carry ids but cannot be referenced here.
    Other,
}

pub(crate) struct Ctx {
    pub file: PathBuf,
    pub dir: PathBuf,
    pub dialect: Dialect,
    pub warnings: Vec<Warning>,
    pub textures: Vec<Texture>,
    pub bsdfs: Vec<Bsdf>,
    ids: HashMap<String, (IdTarget, Pos, String)>,
    pub limits: Limits,
    /// Warnings given once per scene: kind → (index in `warnings`, occurrences).
    once: HashMap<&'static str, (usize, usize)>,
    /// Triangles and vertices of the meshes loaded so far, against `limits`.
    pub triangles: u64,
    pub vertices: u64,
}

impl Ctx {
    pub fn new(file: &Path, dialect: Dialect, limits: &Limits) -> Self {
        let parent = file.parent().unwrap_or(Path::new(""));
        let dir = std::path::absolute(parent).unwrap_or_else(|_| parent.to_path_buf());
        Ctx {
            file: file.to_path_buf(),
            dir,
            dialect,
            warnings: Vec::new(),
            textures: Vec::new(),
            bsdfs: Vec::new(),
            ids: HashMap::new(),
            once: HashMap::new(),
            limits: limits.clone(),
            triangles: 0,
            vertices: 0,
        }
    }

    pub fn err(&self, pos: Pos, message: impl Into<String>) -> ParseError {
        ParseError {
            location: location(&self.file, pos),
            message: message.into(),
        }
    }

    pub fn warn(&mut self, pos: Pos, message: impl Into<String>) {
        self.warnings.push(Warning {
            location: location(&self.file, pos),
            message: message.into(),
        });
    }

    /// A warning given at the first occurrence of `kind` only; [`Ctx::finish_warnings`] adds
    /// how many more there were, so that a scene with a thousand such values gives one line.
    pub fn warn_once(&mut self, kind: &'static str, pos: Pos, message: impl Into<String>) {
        if let Some((_, n)) = self.once.get_mut(kind) {
            *n += 1;
            return;
        }
        self.once.insert(kind, (self.warnings.len(), 1));
        self.warn(pos, message);
    }

    /// The warnings, with counts appended to those given once.
    pub fn finish_warnings(&mut self) -> Vec<Warning> {
        for &(i, n) in self.once.values() {
            if n > 1 {
                let more = n - 1;
                self.warnings[i].message += &format!(
                    " ({more} more like it in this scene{})",
                    if more == 1 { "" } else { "; not listed" }
                );
            }
        }
        std::mem::take(&mut self.warnings)
    }

    /// Records `elem`'s `id` attribute (if any) as naming `target`; a second definition of the
    /// same id is an error pointing at the new one and naming the first.
    pub fn register_id(&mut self, elem: &Element, target: IdTarget) -> Result<()> {
        let Some(attr) = elem.attr("id") else {
            return Ok(());
        };
        if let Some((_, first, tag)) = self.ids.get(&attr.value) {
            return Err(self.err(
                attr.value_pos,
                format!(
                    "duplicate id '{}' (a <{}> already has it at line {}, column {})",
                    attr.value, tag, first.line, first.column
                ),
            ));
        }
        self.ids
            .insert(attr.value.clone(), (target, elem.pos, elem.tag.clone()));
        Ok(())
    }

    /// Looks up the object a `<ref id="...">` names; a dangling id is an error at the ref.
    pub fn lookup(&self, ref_elem: &Element) -> Result<IdTarget> {
        let attr = ref_elem
            .attr("id")
            .ok_or_else(|| self.err(ref_elem.pos, "missing required attribute 'id' on <ref>"))?;
        self.ids
            .get(&attr.value)
            .map(|(t, _, _)| *t)
            .ok_or_else(|| {
                self.err(
                    attr.value_pos,
                    format!("reference to undefined id '{}'", attr.value),
                )
            })
    }

    /// Resolves a file name from the scene against the scene file's folder.
    pub fn resolve(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.dir.join(p)
        }
    }
}

/// The element's `type` attribute, which every plugin element must have.
pub(crate) fn plugin_type<'a>(ctx: &Ctx, elem: &'a Element) -> Result<&'a str> {
    elem.attr_value("type").ok_or_else(|| {
        ctx.err(
            elem.pos,
            format!("missing required attribute 'type' on <{}>", elem.tag),
        )
    })
}

/// The error for a `type` we do not know, listing the ones we do.
pub(crate) fn unknown_type(ctx: &Ctx, elem: &Element, kind: &str, known: &[&str]) -> ParseError {
    let attr = elem.attr("type");
    let pos = attr.map_or(elem.pos, |a| a.value_pos);
    ctx.err(
        pos,
        format!(
            "unknown {kind} type '{}' (supported: {})",
            attr.map_or("", |a| a.value.as_str()),
            known.join(", ")
        ),
    )
}
