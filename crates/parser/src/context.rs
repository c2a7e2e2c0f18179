//! Parsing state shared by the plugin parsers: the scene file (for positions and relative
//! paths), the growing texture and bsdf tables, the id namespace, and the warnings.

use crate::error::{ParseError, Result};
use crate::include::Sources;
use crate::limits::Limits;
use crate::scene::{Bsdf, BsdfId, Dialect, SourceLocation, Texture, TextureId, Warning};
use crate::xml::{Element, Pos};
use std::collections::HashMap;
use std::path::PathBuf;

/// What an `id` names. Mitsuba has one id namespace for all objects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum IdTarget {
    Bsdf(BsdfId),
    Texture(TextureId),
    /// Index into [`Ctx::shape_groups`].
    ShapeGroup(usize),
    /// Index into [`Ctx::area_emitters`]: an `area` emitter declared outside a shape, attached
    /// by a `<ref>` inside one.
    AreaEmitter(usize),
    /// Index into [`Ctx::media`]: a shape's `interior`/`exterior`, a sensor's medium.
    Medium(crate::media::MediumId),
    /// Shapes, sensors, emitters...: may carry ids but cannot be referenced here.
    Other,
}

pub(crate) struct Ctx {
    /// The scene's files (for positions) and `<path>` folders (for file names).
    pub sources: Sources,
    pub dialect: Dialect,
    pub warnings: Vec<Warning>,
    pub textures: Vec<Texture>,
    pub bsdfs: Vec<Bsdf>,
    /// Every `shapegroup`, and every `instance` placing one.
    pub shape_groups: Vec<crate::scene::ShapeGroup>,
    pub instances: Vec<crate::scene::Instance>,
    /// Area emitters declared with an id outside shapes: radiance (1 with a texture) and texture.
    pub area_emitters: Vec<(glam::Vec3, Option<TextureId>)>,
    /// Every `<medium>`, in the order read.
    pub media: Vec<crate::media::Medium>,
    /// Values of the grid volumes read so far, against `limits.volume_values`.
    pub volume_values: u64,
    /// Every file name resolved so far, in order: [`crate::Scene::files`].
    pub files: std::cell::RefCell<Vec<PathBuf>>,
    ids: HashMap<String, (IdTarget, Pos, String)>,
    media_warned: bool,
    pub limits: Limits,
    /// Warnings given once per scene: kind → (index in `warnings`, occurrences).
    once: HashMap<&'static str, (usize, usize)>,
    /// Triangles and vertices of the meshes loaded so far, against `limits`.
    pub triangles: u64,
    pub vertices: u64,
    /// Textures used by the bsdf being parsed (and those nested in it), innermost last, each
    /// with whether a float parameter reads it.
    pub texture_uses: Vec<Vec<(crate::scene::TextureId, bool)>>,
    /// The textures each parsed bsdf uses, to check `mesh_attribute`s against the shapes.
    pub bsdf_textures: HashMap<crate::scene::BsdfId, Vec<(crate::scene::TextureId, bool)>>,
}

impl Ctx {
    pub fn new(sources: Sources, dialect: Dialect, limits: &Limits) -> Self {
        Ctx {
            sources,
            dialect,
            warnings: Vec::new(),
            textures: Vec::new(),
            bsdfs: Vec::new(),
            shape_groups: Vec::new(),
            instances: Vec::new(),
            area_emitters: Vec::new(),
            media: Vec::new(),
            volume_values: 0,
            texture_uses: Vec::new(),
            bsdf_textures: HashMap::new(),
            files: Default::default(),
            ids: HashMap::new(),
            media_warned: false,
            once: HashMap::new(),
            limits: limits.clone(),
            triangles: 0,
            vertices: 0,
        }
    }

    /// An error at `pos`; in an included file the message names the chain of includes.
    pub fn err(&self, pos: Pos, message: impl Into<String>) -> ParseError {
        self.sources.err(pos, message)
    }

    /// `<subsurface>` (and a `<phase>` or `<volume>` outside a medium) is not rendered: the
    /// first one gives one warning, the others are dropped silently.
    pub fn warn_media(&mut self, elem: &Element, owner: Option<&str>) {
        if self.media_warned {
            return;
        }
        self.media_warned = true;
        let what = crate::props::describe(elem);
        let place = owner.map_or(String::new(), |o| format!(" in {o}"));
        self.warn(
            elem.pos,
            format!("{what}{place} is not supported; ignored, with every other such element of the scene"),
        );
    }

    pub fn warn(&mut self, pos: Pos, message: impl Into<String>) {
        let w = self.sources.warning(pos, message);
        self.warnings.push(w);
    }

    /// `file:line:column` of a position (in whichever file of the scene it is).
    pub fn location(&self, pos: Pos) -> SourceLocation {
        self.sources.location(pos)
    }

    /// Makes `<alias id="a" as="b"/>`: `b` names what `a` names.
    pub fn alias(&mut self, elem: &Element) -> Result<()> {
        let get = |n: &str| {
            elem.attr(n).ok_or_else(|| {
                self.err(
                    elem.pos,
                    format!("missing required attribute '{n}' on <alias>"),
                )
            })
        };
        let (id, alias) = (get("id")?, get("as")?);
        let Some(&(target, _, ref tag)) = self.ids.get(&id.value) else {
            return Err(self.err(
                id.value_pos,
                format!("<alias> of undefined id '{}'", id.value),
            ));
        };
        let tag = tag.clone();
        if let Some((_, first, t)) = self.ids.get(&alias.value) {
            return Err(self.err(
                alias.value_pos,
                format!(
                    "duplicate id '{}' (a <{}> already has it at line {}, column {})",
                    alias.value, t, first.line, first.column
                ),
            ));
        }
        self.ids
            .insert(alias.value.clone(), (target, elem.pos, tag));
        Ok(())
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

    /// Resolves a file name given at `pos`: see [`Sources::resolve`] (the naming file's folder,
    /// the `<path>` folders, the scene file's folder), and records it in [`Ctx::files`].
    pub fn resolve(&self, name: &str, pos: Pos) -> PathBuf {
        let resolved = self.sources.resolve(name, pos);
        self.files.borrow_mut().push(resolved.clone());
        resolved
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
