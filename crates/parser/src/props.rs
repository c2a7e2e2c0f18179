//! A plugin's children as a property bag, Mitsuba style: plugin parsers take the parameters
//! they know by (snake_case) name, and whatever is left over becomes one warning each.

use crate::context::Ctx;
use crate::error::Result;
use crate::spectrum::{self, SpectrumUse};
use crate::transform::parse_transform;
use crate::values;
use crate::xml::{Attr, Element, Pos};
use glam::{Mat4, Vec3};

/// Tags that hold a named value.
const VALUE_TAGS: &[&str] = &[
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "srgb",
    "spectrum",
    "blackbody",
    "point",
    "vector",
    "transform",
];
/// Tags that are nested plugins or references (a `name` is optional).
const OBJECT_TAGS: &[&str] = &[
    "bsdf",
    "texture",
    "ref",
    "emitter",
    "sampler",
    "film",
    "rfilter",
    "shape",
    "sensor",
    "integrator",
    "medium",
    "phase",
    "volume",
];
/// Things a scene may carry that we do not render: warned about and skipped.
pub(crate) const SKIPPED_TAGS: &[&str] = &["phase", "volume", "subsurface"];

struct Item<'a> {
    name: Option<String>,
    elem: &'a Element,
    used: bool,
}

/// The parameters and nested objects of one plugin element.
pub(crate) struct Props<'a> {
    /// "bsdf 'diffuse'": how messages name the plugin.
    pub owner: String,
    items: Vec<Item<'a>>,
    /// Spectra here are emission (the plugin is an `<emitter>` in a Mitsuba-dialect scene).
    illuminant: bool,
}

fn value_attr<'e>(ctx: &Ctx, elem: &'e Element) -> Result<&'e Attr> {
    elem.attr("value").ok_or_else(|| {
        ctx.err(
            elem.pos,
            format!("missing required attribute 'value' on {}", describe(elem)),
        )
    })
}

/// `<float name="fov">` for messages.
pub(crate) fn describe(elem: &Element) -> String {
    match elem.attr_value("name") {
        Some(n) => format!("<{} name=\"{}\">", elem.tag, n),
        None => format!("<{}>", elem.tag),
    }
}

impl<'a> Props<'a> {
    /// Sorts `elem`'s children into named values and nested objects. Unknown tags are errors;
    /// unsupported-but-harmless ones (`<subsurface>`) are warned about and dropped.
    pub fn new(ctx: &mut Ctx, elem: &'a Element, owner: String) -> Result<Self> {
        let mut items: Vec<Item<'a>> = Vec::new();
        // First position of each value name: a hash, so that a plugin with 100,000 parameters
        // is not checked pairwise.
        let mut seen: std::collections::HashMap<String, Pos> = std::collections::HashMap::new();
        for child in &elem.children {
            let tag = child.tag.as_str();
            let name = child.attr_value("name").map(values::snake_case);
            if VALUE_TAGS.contains(&tag) {
                let Some(name) = name else {
                    return Err(ctx.err(
                        child.pos,
                        format!("missing required attribute 'name' on <{tag}>"),
                    ));
                };
                if let Some(first) = seen.get(&name) {
                    return Err(ctx.err(
                        child.pos,
                        format!(
                            "parameter '{name}' of {owner} is given twice (first at line {}, column {})",
                            first.line, first.column
                        ),
                    ));
                }
                seen.insert(name.clone(), child.pos);
                items.push(Item {
                    name: Some(name),
                    elem: child,
                    used: false,
                });
            } else if OBJECT_TAGS.contains(&tag) {
                items.push(Item {
                    name,
                    elem: child,
                    used: false,
                });
            } else if SKIPPED_TAGS.contains(&tag) {
                ctx.warn_media(child, Some(&owner));
            } else if tag == "default" {
                return Err(ctx.err(child.pos, "<default> must be a direct child of <scene>"));
            } else {
                return Err(ctx.err(child.pos, format!("unknown tag <{tag}> in {owner}")));
            }
        }
        let illuminant = elem.tag == "emitter" && ctx.dialect == crate::scene::Dialect::Mitsuba3;
        Ok(Props {
            owner,
            items,
            illuminant,
        })
    }

    /// Takes the unused child named `name` (snake_case), whatever its tag.
    pub fn take(&mut self, name: &str) -> Option<&'a Element> {
        let item = self
            .items
            .iter_mut()
            .find(|i| !i.used && i.name.as_deref() == Some(name))?;
        item.used = true;
        Some(item.elem)
    }

    /// Takes the first child among `names` (aliases), returning the element.
    pub fn take_any(&mut self, names: &[&str]) -> Option<&'a Element> {
        names.iter().find_map(|n| self.take(n))
    }

    /// Takes every unused child with tag `tag` (named or not), in document order.
    pub fn take_tag(&mut self, tag: &str) -> Vec<&'a Element> {
        let mut out = Vec::new();
        for item in self
            .items
            .iter_mut()
            .filter(|i| !i.used && i.elem.tag == tag)
        {
            item.used = true;
            out.push(item.elem);
        }
        out
    }

    fn wrong_type(&self, ctx: &Ctx, elem: &Element, expected: &str) -> crate::error::ParseError {
        ctx.err(
            elem.pos,
            format!(
                "parameter '{}' of {} must be {expected}, found <{}>",
                elem.attr_value("name").unwrap_or(""),
                self.owner,
                elem.tag
            ),
        )
    }

    fn parse_attr<T>(
        &self,
        ctx: &Ctx,
        elem: &Element,
        attr: &Attr,
        f: impl Fn(&str) -> std::result::Result<T, String>,
    ) -> Result<T> {
        f(&attr.value).map_err(|m| {
            ctx.err(
                attr.value_pos,
                format!(
                    "{m} in parameter '{}' of {}",
                    elem.attr_value("name").unwrap_or(&elem.tag),
                    self.owner
                ),
            )
        })
    }

    pub fn opt_float(&mut self, ctx: &Ctx, names: &[&str]) -> Result<Option<f32>> {
        let Some(e) = self.take_any(names) else {
            return Ok(None);
        };
        if e.tag != "float" && e.tag != "integer" {
            return Err(self.wrong_type(ctx, e, "a <float>"));
        }
        let a = value_attr(ctx, e)?;
        self.parse_attr(ctx, e, a, values::float).map(Some)
    }

    /// Like [`Props::opt_float`], also returning where the value is (for range errors).
    pub fn opt_float_pos(&mut self, ctx: &Ctx, names: &[&str]) -> Result<Option<(f32, Pos)>> {
        let Some(e) = self.take_any(names) else {
            return Ok(None);
        };
        if e.tag != "float" && e.tag != "integer" {
            return Err(self.wrong_type(ctx, e, "a <float>"));
        }
        let a = value_attr(ctx, e)?;
        Ok(Some((
            self.parse_attr(ctx, e, a, values::float)?,
            a.value_pos,
        )))
    }

    /// Like [`Props::opt_int`], also returning where the value is (for range errors).
    pub fn opt_int_pos(&mut self, ctx: &Ctx, names: &[&str]) -> Result<Option<(i64, Pos)>> {
        let Some(e) = self.take_any(names) else {
            return Ok(None);
        };
        if e.tag != "integer" && e.tag != "float" {
            return Err(self.wrong_type(ctx, e, "an <integer>"));
        }
        let a = value_attr(ctx, e)?;
        Ok(Some((
            self.parse_attr(ctx, e, a, values::integer)?,
            a.value_pos,
        )))
    }

    /// Takes the child `name` only if it is a `<string>` (for parameters that are a number or
    /// a name, like Mitsuba's `int_ior`).
    pub fn clone_string_if(&mut self, name: &str) -> Option<&'a Attr> {
        let item = self
            .items
            .iter_mut()
            .find(|i| !i.used && i.name.as_deref() == Some(name) && i.elem.tag == "string")?;
        item.used = true;
        item.elem.attr("value")
    }

    /// Whether an unused child has one of these names.
    pub fn has(&self, names: &[&str]) -> bool {
        self.items
            .iter()
            .any(|i| !i.used && i.name.as_deref().is_some_and(|n| names.contains(&n)))
    }

    pub fn float(&mut self, ctx: &Ctx, names: &[&str], default: f32) -> Result<f32> {
        Ok(self.opt_float(ctx, names)?.unwrap_or(default))
    }

    pub fn boolean(&mut self, ctx: &Ctx, names: &[&str], default: bool) -> Result<bool> {
        let Some(e) = self.take_any(names) else {
            return Ok(default);
        };
        if e.tag != "boolean" {
            return Err(self.wrong_type(ctx, e, "a <boolean>"));
        }
        let a = value_attr(ctx, e)?;
        self.parse_attr(ctx, e, a, values::boolean)
    }

    /// A string parameter with the attribute holding it (for positions of file names).
    pub fn string(&mut self, ctx: &Ctx, names: &[&str]) -> Result<Option<&'a Attr>> {
        let Some(e) = self.take_any(names) else {
            return Ok(None);
        };
        if e.tag != "string" {
            return Err(self.wrong_type(ctx, e, "a <string>"));
        }
        value_attr(ctx, e).map(Some)
    }

    /// A `point`/`vector`: `x`, `y`, `z` attributes (missing ones 0) or a `value`.
    pub fn point(&mut self, ctx: &Ctx, names: &[&str]) -> Result<Option<Vec3>> {
        let Some(e) = self.take_any(names) else {
            return Ok(None);
        };
        if e.tag != "point" && e.tag != "vector" {
            return Err(self.wrong_type(ctx, e, "a <point>"));
        }
        self.xyz(ctx, e, 0.0).map(Some)
    }

    /// Reads `x`/`y`/`z` (defaulting to `default`) or `value` from an element.
    pub fn xyz(&self, ctx: &Ctx, e: &Element, default: f32) -> Result<Vec3> {
        if let Some(a) = e.attr("value") {
            return self.parse_attr(ctx, e, a, values::vec3);
        }
        let mut v = Vec3::splat(default);
        for (i, axis) in ["x", "y", "z"].iter().enumerate() {
            if let Some(a) = e.attr(axis) {
                v[i] = self.parse_attr(ctx, e, a, values::float)?;
            }
        }
        Ok(v)
    }

    /// Reads a constant colour from an `rgb`, `srgb`, `spectrum`, `blackbody` or `float`
    /// element; spectra are reduced to RGB as Mitsuba's RGB variants do (see `spectrum.rs`).
    /// Colours are reflectances, radiances or intensities: a negative or non-finite channel is
    /// an error.
    pub fn color_of(&self, ctx: &Ctx, e: &Element) -> Result<Vec3> {
        let c = self.color_value(ctx, e)?;
        if c.min_element() < 0.0 || !c.is_finite() {
            let pos = e.attr("value").map_or(e.pos, |a| a.value_pos);
            return Err(ctx.err(
                pos,
                format!(
                    "parameter '{}' of {} must not be negative, found {} {} {}",
                    e.attr_value("name").unwrap_or(&e.tag),
                    self.owner,
                    c.x,
                    c.y,
                    c.z
                ),
            ));
        }
        Ok(c)
    }

    fn color_value(&self, ctx: &Ctx, e: &Element) -> Result<Vec3> {
        let usage = if self.illuminant {
            SpectrumUse::Illuminant
        } else {
            SpectrumUse::Reflectance
        };
        match e.tag.as_str() {
            "spectrum" => self.spectrum_of(ctx, e, usage),
            "blackbody" => {
                let t = e.attr("temperature").ok_or_else(|| {
                    ctx.err(
                        e.pos,
                        "missing required attribute 'temperature' on <blackbody>",
                    )
                })?;
                let temperature = self.parse_attr(ctx, e, t, values::float)?;
                let scale = match e.attr("scale") {
                    Some(s) => self.parse_attr(ctx, e, s, values::float)?,
                    None => 1.0,
                };
                self.parse_attr(ctx, e, t, |_| spectrum::blackbody(temperature, scale))
            }
            tag => {
                let a = value_attr(ctx, e)?;
                match tag {
                    "rgb" => self.parse_attr(ctx, e, a, values::vec3),
                    "srgb" => self.parse_attr(ctx, e, a, values::srgb),
                    "float" => self.parse_attr(ctx, e, a, values::float).map(Vec3::splat),
                    _ => Err(self.wrong_type(
                        ctx,
                        e,
                        "a colour (<rgb>, <srgb>, <spectrum> or <float>)",
                    )),
                }
            }
        }
    }

    /// `<spectrum>`: a `value` (constant or wavelength:value list), a `filename` (.spd), or
    /// Mitsuba's plugin form `<spectrum type="blackbody">` with a `temperature`.
    fn spectrum_of(&self, ctx: &Ctx, e: &Element, usage: SpectrumUse) -> Result<Vec3> {
        if let Some(a) = e.attr("value") {
            return self.parse_attr(ctx, e, a, |s| spectrum::parse_value(s, usage));
        }
        if let Some(f) = e.attr("filename") {
            let path = ctx
                .resolve_spectrum(&f.value, f.value_pos)
                .map_err(|looked| {
                    ctx.err(
                        f.value_pos,
                        format!(
                            "cannot read spectrum file '{}': not found ({looked})",
                            f.value
                        ),
                    )
                })?;
            let text = std::fs::read_to_string(&path).map_err(|err| {
                ctx.err(
                    f.value_pos,
                    format!(
                        "cannot read spectrum file '{}' (looked for '{}'): {err}",
                        f.value,
                        path.display()
                    ),
                )
            })?;
            return spectrum::read_spd(&text)
                .and_then(|(w, v)| spectrum::list_to_rgb(&w, &v, usage))
                .map_err(|m| ctx.err(f.value_pos, format!("in spectrum file '{}': {m}", f.value)));
        }
        match e.attr_value("type") {
            Some("blackbody") => {
                let mut temperature = None;
                let mut scale = 1.0;
                for c in &e.children {
                    let a = value_attr(ctx, c)?;
                    match c.attr_value("name") {
                        Some("temperature") => {
                            temperature = Some(self.parse_attr(ctx, c, a, values::float)?)
                        }
                        Some("scale") => scale = self.parse_attr(ctx, c, a, values::float)?,
                        _ => {
                            return Err(ctx.err(
                                c.pos,
                                format!("unknown parameter {} of spectrum 'blackbody'", describe(c)),
                            ))
                        }
                    }
                }
                let t = temperature.ok_or_else(|| {
                    ctx.err(
                        e.pos,
                        "missing required parameter 'temperature' of spectrum 'blackbody'",
                    )
                })?;
                spectrum::blackbody(t, scale).map_err(|m| ctx.err(e.pos, m))
            }
            Some(t) => Err(ctx.err(
                e.pos,
                format!("spectrum type '{t}' is not supported (supported: blackbody; or a value or filename)"),
            )),
            None => Err(ctx.err(
                e.pos,
                format!(
                    "{} needs a 'value' or a 'filename' attribute",
                    describe(e)
                ),
            )),
        }
    }

    /// A float parameter that must satisfy `ok` (described by `what`, e.g. "positive"); the
    /// error points at the value.
    pub fn float_where(
        &mut self,
        ctx: &Ctx,
        names: &[&str],
        default: f32,
        what: &str,
        ok: impl Fn(f32) -> bool,
    ) -> Result<f32> {
        // The name the file gives (`alpha` for `exponent`, say), found as `take_any` finds it.
        let name = names
            .iter()
            .find_map(|n| {
                self.items
                    .iter()
                    .find(|i| !i.used && i.name.as_deref() == Some(*n))
            })
            .and_then(|i| i.elem.attr_value("name"))
            .unwrap_or(names[0])
            .to_string();
        match self.opt_float_pos(ctx, names)? {
            None => Ok(default),
            Some((v, _)) if ok(v) => Ok(v),
            Some((v, pos)) => Err(ctx.err(
                pos,
                format!(
                    "parameter '{name}' of {} must be {what}, found {v}",
                    self.owner
                ),
            )),
        }
    }

    pub fn color(&mut self, ctx: &Ctx, names: &[&str], default: Vec3) -> Result<Vec3> {
        match self.take_any(names) {
            Some(e) => self.color_of(ctx, e),
            None => Ok(default),
        }
    }

    /// A `<transform>` parameter (`uv` selects the 2D reading used by `to_uv`).
    pub fn transform(&mut self, ctx: &Ctx, names: &[&str], uv: bool) -> Result<Option<Mat4>> {
        Ok(self.transform_pos(ctx, names, uv)?.map(|(m, _)| m))
    }

    /// Like [`Props::transform`], also returning where the `<transform>` is.
    pub fn transform_pos(
        &mut self,
        ctx: &Ctx,
        names: &[&str],
        uv: bool,
    ) -> Result<Option<(Mat4, Pos)>> {
        let Some(e) = self.take_any(names) else {
            return Ok(None);
        };
        if e.tag != "transform" {
            return Err(self.wrong_type(ctx, e, "a <transform>"));
        }
        Ok(Some((parse_transform(ctx, e, uv)?, e.pos)))
    }

    /// Marks parameters as accepted without effect (e.g. `focus_distance`).
    /// An integer parameter in 1..=`max` (`default` when absent); `limit` names the `--limit`
    /// that raises `max`, if any.
    pub fn positive(
        &mut self,
        ctx: &Ctx,
        name: &str,
        default: i64,
        max: u64,
        limit: Option<&str>,
    ) -> Result<u32> {
        let max = max.min(u32::MAX as u64) as i64;
        match self.opt_int_pos(ctx, &[name])? {
            None => Ok(default as u32),
            Some((v, pos)) if v <= 0 => Err(ctx.err(
                pos,
                format!(
                    "parameter '{name}' of {} must be positive, found {v}",
                    self.owner
                ),
            )),
            Some((v, pos)) if v > max => Err(ctx.err(
                pos,
                format!(
                    "parameter '{name}' of {} must be at most {max}, found {v}{}",
                    self.owner,
                    limit.map_or(String::new(), |l| format!(" (raise with --limit {l}=N)"))
                ),
            )),
            Some((v, _)) => Ok(v as u32),
        }
    }

    /// An optional integer parameter that must not be negative.
    pub fn non_negative(&mut self, ctx: &Ctx, name: &str) -> Result<Option<u32>> {
        match self.opt_int_pos(ctx, &[name])? {
            None => Ok(None),
            Some((v, pos)) if v < 0 || v > u32::MAX as i64 => Err(ctx.err(
                pos,
                format!(
                    "parameter '{name}' of {} must not be negative, found {v}",
                    self.owner
                ),
            )),
            Some((v, _)) => Ok(Some(v as u32)),
        }
    }

    pub fn ignore(&mut self, names: &[&str]) {
        for n in names {
            while self.take(n).is_some() {}
        }
    }

    /// Warns once for every child no parser took.
    pub fn finish(self, ctx: &mut Ctx) {
        for item in self.items.into_iter().filter(|i| !i.used) {
            let msg = match &item.name {
                Some(n) if VALUE_TAGS.contains(&item.elem.tag.as_str()) => {
                    format!("unknown parameter '{n}' of {}; ignored", self.owner)
                }
                _ => format!(
                    "{} in {} is not used; ignored",
                    describe(item.elem),
                    self.owner
                ),
            };
            ctx.warn(item.elem.pos, msg);
        }
    }
}
