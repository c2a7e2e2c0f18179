//! Parsing state shared by the plugin parsers: the scene file (for positions and relative
//! paths), the growing texture and bsdf tables, the id namespace, and the warnings.
//!
//! Ids are Mitsuba's: every object with an `id` names it, at any depth (a `twosided` nested in
//! an anonymous `bumpmap` too), and a `<ref>` may name an object defined further on, since
//! Mitsuba resolves references after reading the whole document. [`Ctx::declare_ids`] collects
//! every id (and `<alias>`) before any plugin is parsed; an object a `<ref>` names is parsed
//! when first needed ([`Ctx::lookup`]) and reused where it stands ([`Ctx::already`]).

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

pub(crate) struct Ctx<'a> {
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
    /// Every file name resolved so far, in order: [`crate::Scene::files`].
    pub files: std::cell::RefCell<Vec<PathBuf>>,
    /// Every id and alias of the document: the element it names (an alias: its source's).
    declared: HashMap<String, &'a Element>,
    /// Top-level children of `<scene>` (an `area` emitter there can be referenced).
    top_level: std::collections::HashSet<Pos>,
    /// What each element with an id was parsed into, by its position.
    defined: HashMap<Pos, IdTarget>,
    /// Elements a `<ref>` made us parse, innermost last: a `<ref>` back to one is a cycle.
    defining: Vec<(Pos, String)>,
    media_warned: bool,
    pub limits: Limits,
    /// Warnings given once per scene: kind → (index in `warnings`, occurrences).
    once: HashMap<&'static str, (usize, usize)>,
    /// Triangles and vertices of the meshes loaded so far, against `limits`.
    pub triangles: u64,
    pub vertices: u64,
    /// Values of the grid volumes loaded so far, against `limits.volume_values`.
    pub volume_values: u64,
    /// Textures used by the bsdf being parsed (and those nested in it), innermost last, each
    /// with whether a float parameter reads it.
    pub texture_uses: Vec<Vec<(crate::scene::TextureId, bool)>>,
    /// The textures each parsed bsdf uses, to check `mesh_attribute`s against the shapes.
    pub bsdf_textures: HashMap<crate::scene::BsdfId, Vec<(crate::scene::TextureId, bool)>>,
}

/// Elements that are objects (and so may carry an id), as opposed to values and references.
const OBJECT_TAGS: &[&str] = &[
    "bsdf",
    "texture",
    "shape",
    "emitter",
    "sensor",
    "film",
    "sampler",
    "rfilter",
    "integrator",
    "medium",
    "phase",
    "volume",
    "subsurface",
];

impl<'a> Ctx<'a> {
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
            texture_uses: Vec::new(),
            bsdf_textures: HashMap::new(),
            files: Default::default(),
            declared: HashMap::new(),
            top_level: Default::default(),
            defined: HashMap::new(),
            defining: Vec::new(),
            media_warned: false,
            once: HashMap::new(),
            limits: limits.clone(),
            triangles: 0,
            vertices: 0,
            volume_values: 0,
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

    /// `a` in `<alias id="a" as="b"/>` or a duplicate id: the error, naming the first holder.
    fn duplicate(&self, attr: &crate::xml::Attr) -> ParseError {
        let first = self.declared[&attr.value];
        let at = if first.pos.file == attr.value_pos.file {
            format!("line {}, column {}", first.pos.line, first.pos.column)
        } else {
            self.location(first.pos).to_string()
        };
        self.err(
            attr.value_pos,
            format!(
                "duplicate id '{}' (a <{}> already has it at {at})",
                attr.value, first.tag
            ),
        )
    }

    /// Collects every id of the document (objects at any depth) and every top-level
    /// `<alias id="a" as="b"/>` (`b` names what `a` names; `a` must be declared before it, as
    /// Mitsuba reads in document order), before any plugin is parsed. A second definition of
    /// an id is an error pointing at it and naming the first.
    pub fn declare_ids(&mut self, root: &'a Element) -> Result<()> {
        for child in &root.children {
            self.top_level.insert(child.pos);
        }
        self.declare_in(root, true)
    }

    fn declare_in(&mut self, elem: &'a Element, top: bool) -> Result<()> {
        for child in &elem.children {
            if child.tag == "alias" && top {
                let get = |n: &str| {
                    child.attr(n).ok_or_else(|| {
                        self.err(
                            child.pos,
                            format!("missing required attribute '{n}' on <alias>"),
                        )
                    })
                };
                let (id, alias) = (get("id")?, get("as")?);
                let Some(&target) = self.declared.get(&id.value) else {
                    return Err(self.err(
                        id.value_pos,
                        format!("<alias> of undefined id '{}'", id.value),
                    ));
                };
                if self.declared.contains_key(&alias.value) {
                    return Err(self.duplicate(alias));
                }
                self.declared.insert(alias.value.clone(), target);
                continue;
            }
            if OBJECT_TAGS.contains(&child.tag.as_str()) {
                if let Some(attr) = child.attr("id") {
                    if self.declared.contains_key(&attr.value) {
                        return Err(self.duplicate(attr));
                    }
                    self.declared.insert(attr.value.clone(), child);
                }
            }
            self.declare_in(child, false)?;
        }
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

    /// Records what `elem` (if it has an id) was parsed into. Ids were checked for duplicates
    /// by [`Ctx::declare_ids`].
    pub fn register_id(&mut self, elem: &Element, target: IdTarget) -> Result<()> {
        if elem.attr("id").is_some() {
            self.defined.insert(elem.pos, target);
        }
        Ok(())
    }

    /// What `elem` was parsed into already, if a `<ref>` to its id made us parse it before its
    /// place in the document: the parsers reuse that instead of parsing it twice.
    pub fn already(&self, elem: &Element) -> Option<IdTarget> {
        elem.attr("id")?;
        self.defined.get(&elem.pos).copied()
    }

    /// Looks up the object a `<ref id="...">` names, parsing it now if it stands further on or
    /// nested somewhere not parsed yet. A dangling id, or a reference cycle, is an error at the
    /// ref.
    pub fn lookup(&mut self, ref_elem: &Element) -> Result<IdTarget> {
        let attr = ref_elem
            .attr("id")
            .ok_or_else(|| self.err(ref_elem.pos, "missing required attribute 'id' on <ref>"))?;
        let Some(&elem) = self.declared.get(&attr.value) else {
            return Err(self.err(
                attr.value_pos,
                format!("reference to undefined id '{}'", attr.value),
            ));
        };
        if let Some(&t) = self.defined.get(&elem.pos) {
            return Ok(t);
        }
        if let Some(i) = self.defining.iter().position(|(p, _)| *p == elem.pos) {
            let mut cycle: Vec<&str> = self.defining[i..].iter().map(|(_, n)| n.as_str()).collect();
            cycle.push(&attr.value);
            return Err(self.err(
                attr.value_pos,
                format!("circular reference: {}", cycle.join(" -> ")),
            ));
        }
        self.defining.push((elem.pos, attr.value.clone()));
        let target = self.define(elem);
        self.defining.pop();
        let target = target?;
        self.defined.insert(elem.pos, target);
        Ok(target)
    }

    /// Parses an element a `<ref>` names before its place in the document. Only what a ref can
    /// use is parsed (bsdfs, textures, shapegroups, area emitters declared outside shapes);
    /// media too; the rest is [`IdTarget::Other`].
    fn define(&mut self, elem: &'a Element) -> Result<IdTarget> {
        let ty = elem.attr_value("type");
        Ok(match elem.tag.as_str() {
            "bsdf" => IdTarget::Bsdf(crate::plugins::bsdf::parse_bsdf(self, elem)?),
            "texture" => IdTarget::Texture(crate::plugins::texture::parse_texture(self, elem)?),
            "shape" if ty == Some("shapegroup") => {
                crate::plugins::shape::parse_shape(self, elem)?;
                self.already(elem).unwrap_or(IdTarget::Other)
            }
            "emitter" if ty == Some("area") && self.top_level.contains(&elem.pos) => {
                crate::plugins::shape::define_area_emitter(self, elem)?
            }
            "medium" => IdTarget::Medium(crate::plugins::medium::parse_medium(self, elem)?),
            _ => IdTarget::Other,
        })
    }

    /// Resolves a plugin's file name given at `pos` as Mitsuba does ([`Sources::resolve`]: the
    /// scene file's `<path>` folders, its folder, the working directory) and records it in
    /// [`Ctx::files`]. `Err` says where it was looked for.
    pub fn resolve(&self, name: &str, pos: Pos) -> std::result::Result<PathBuf, String> {
        let resolved = self.sources.resolve(name, pos)?;
        self.files.borrow_mut().push(resolved.clone());
        Ok(resolved)
    }

    /// [`Ctx::resolve`] for a `<spectrum filename>`, read with the resolver in effect where it
    /// stands ([`Sources::resolve_spectrum`]).
    pub fn resolve_spectrum(&self, name: &str, pos: Pos) -> std::result::Result<PathBuf, String> {
        let resolved = self.sources.resolve_spectrum(name, pos)?;
        self.files.borrow_mut().push(resolved.clone());
        Ok(resolved)
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
