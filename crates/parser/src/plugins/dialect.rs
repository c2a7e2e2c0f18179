//! Which rules a scene file is read with (docs/conventions.md, "Scene dialects").
//!
//! `<scene version>` 2.0 and up is Mitsuba 3; 1.x exists only in the torrey course. A 0.x file
//! (Mitsuba 0.5/0.6 syntax, which the course's scenes use too) is a course file exactly when every
//! plugin in it is one the course's renderer reads (BachiLi/torrey_public, `src/parse_scene.cpp`,
//! its last version), plus the envmap of this project's seed scenes:
//!
//! | element | types the course reads |
//! | --- | --- |
//! | `sensor` | `perspective` |
//! | `film`, `sampler` (inside the sensor) | any: the course reads only their size and sample count |
//! | `bsdf` (anywhere) | `diffuse`, `mirror`, `plastic`, `phong`, `blinn`, `blinnphong`, `blinn_microfacet`, `blinnphong_microfacet`, `twosided` |
//! | `emitter` in `<scene>` | `point`; `envmap` (the seeds') |
//! | `emitter` in a `shape` | `area` |
//! | `shape` | `obj`, `ply`, `serialized`, `sphere`, `rectangle` |
//! | `texture` (anywhere) | `bitmap` |
//! | `background` | the course's own element |
//!
//! What the course's parser skips (`integrator`, `rfilter`, `medium`, `phase`, `volume`,
//! `subsurface` and everything inside them; `<ref>`s to media) does not decide. Any other plugin
//! makes the file a Mitsuba 0.6 file, read with Mitsuba's rules.

use crate::error::Result;
use crate::include::Sources;
use crate::props::SKIPPED_TAGS;
use crate::scene::Dialect;
use crate::xml::Element;

/// The bsdf types the course's renderer reads.
pub(crate) const COURSE_BSDFS: &[&str] = &[
    "diffuse",
    "mirror",
    "plastic",
    "phong",
    "blinn",
    "blinnphong",
    "blinn_microfacet",
    "blinnphong_microfacet",
    "twosided",
];

/// The shape types the course's renderer reads.
pub(crate) const COURSE_SHAPES: &[&str] = &["obj", "ply", "serialized", "sphere", "rectangle"];

/// The emitter types the course reads in `<scene>` (`point`; `envmap` is the seeds').
pub(crate) const COURSE_SCENE_EMITTERS: &[&str] = &["point", "envmap"];

/// Why an element is not one the course's renderer reads, or `None` if it is (or does not
/// decide: skipped elements, values, refs, elements without a `type`, which fail later anyway).
/// `parent` is the enclosing element's tag, `None` in `<scene>`.
fn foreign(elem: &Element, parent: Option<&str>) -> Option<String> {
    let ty = elem.attr_value("type")?;
    let (ok, what) = match elem.tag.as_str() {
        "sensor" => (ty == "perspective", format!("sensor '{ty}'")),
        "bsdf" => (COURSE_BSDFS.contains(&ty), format!("bsdf '{ty}'")),
        "shape" => (COURSE_SHAPES.contains(&ty), format!("shape '{ty}'")),
        "texture" => (ty == "bitmap", format!("texture '{ty}'")),
        "emitter" => match parent {
            None => (
                COURSE_SCENE_EMITTERS.contains(&ty),
                format!("emitter '{ty}'"),
            ),
            Some("shape") => (ty == "area", format!("emitter '{ty}' in a shape")),
            Some(t) => (false, format!("emitter '{ty}' inside a <{t}>")),
        },
        _ => return None,
    };
    (!ok).then_some(what)
}

/// Does the course's parser skip this element and everything in it?
fn skipped(elem: &Element) -> bool {
    matches!(
        elem.tag.as_str(),
        "integrator" | "rfilter" | "film" | "sampler" | "medium" | "phase" | "volume"
    ) || SKIPPED_TAGS.contains(&elem.tag.as_str())
}

/// The first plugin (document order, includes spliced in) that the course's renderer does not
/// read, with a description, and how many plugins were looked at.
fn first_foreign(root: &Element) -> (Option<(&Element, String)>, usize) {
    let mut plugins = 0;
    // Depth first in document order: children are pushed in reverse.
    let mut stack: Vec<(&Element, Option<&str>)> =
        root.children.iter().rev().map(|c| (c, None)).collect();
    while let Some((elem, parent)) = stack.pop() {
        if skipped(elem) {
            continue;
        }
        if elem.attr("type").is_some() {
            plugins += 1;
        }
        if let Some(what) = foreign(elem, parent) {
            return (Some((elem, what)), plugins);
        }
        let inner = Some(elem.tag.as_str());
        stack.extend(elem.children.iter().rev().map(|c| (c, inner)));
    }
    (None, plugins)
}

/// Decides the dialect from `<scene version>` and, for 0.x files, the plugins (module docs).
/// Returns the dialect and why, for the summary line.
pub(crate) fn detect(root: &Element, sources: &Sources) -> Result<(Dialect, String)> {
    let Some(v) = root.attr("version") else {
        return Err(sources.err(root.pos, "missing required attribute 'version' on <scene>"));
    };
    let major = v
        .value
        .split('.')
        .next()
        .and_then(|m| m.trim().parse::<u32>().ok())
        .ok_or_else(|| {
            sources.err(
                v.value_pos,
                format!("cannot parse scene version '{}'", v.value),
            )
        })?;
    Ok(match major {
        2.. => (Dialect::Mitsuba3, format!("scene version {}", v.value)),
        1 => (
            Dialect::Torrey,
            format!("scene version {} (the torrey course's)", v.value),
        ),
        0 => match first_foreign(root) {
            (Some((elem, what)), _) => (
                Dialect::Mitsuba3,
                format!(
                    "scene version {} with {what} at {}, which the torrey course's renderer does not read: Mitsuba's rules",
                    v.value,
                    sources.location(elem.pos)
                ),
            ),
            (None, plugins) => (
                Dialect::Torrey,
                format!(
                    "scene version {}, every plugin ({plugins}) one the torrey course's renderer reads",
                    v.value
                ),
            ),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// The dialect and reason `detect` gives `body` inside `<scene version="0.6.0">`.
    fn detect06(body: &str) -> (Dialect, String) {
        let text = format!("<scene version=\"0.6.0\">\n{body}\n</scene>");
        let path = Path::new("t.xml");
        let root = crate::xml::parse_document(&text, path, 64).unwrap();
        detect(&root, &Sources::new(path)).unwrap()
    }

    #[test]
    fn every_course_plugin_keeps_the_course_rules() {
        // Every plugin the course's parse_scene.cpp reads, where it reads it, and the elements
        // it skips (integrator, rfilter, media) with Mitsuba-only contents: still the course's.
        let body = r#"
  <integrator type="volpath"><integer name="maxDepth" value="3"/></integrator>
  <sensor type="perspective">
    <sampler type="ldsampler"><integer name="sampleCount" value="4"/></sampler>
    <film type="ldrfilm"><rfilter type="lanczos"/></film>
  </sensor>
  <medium type="homogeneous" id="fog"><phase type="hg"/></medium>
  <texture type="bitmap" id="t"><string name="filename" value="a.png"/></texture>
  <bsdf type="diffuse" id="d"><texture type="bitmap" name="reflectance"/></bsdf>
  <bsdf type="mirror"/> <bsdf type="plastic"/> <bsdf type="phong"/> <bsdf type="blinn"/>
  <bsdf type="blinnphong"/> <bsdf type="blinn_microfacet"/> <bsdf type="blinnphong_microfacet"/>
  <bsdf type="twosided"><bsdf type="diffuse"><texture type="bitmap" name="normal_map"/></bsdf></bsdf>
  <emitter type="point"/>
  <emitter type="envmap"><texture type="bitmap" name="reflectance"/></emitter>
  <shape type="obj"><ref id="d"/><ref name="interior" id="fog"/></shape>
  <shape type="ply"/> <shape type="serialized"/> <shape type="rectangle"/>
  <shape type="sphere"><emitter type="area"/><bsdf type="phong"/></shape>
  <background/>"#;
        let (d, why) = detect06(body);
        assert_eq!(d, Dialect::Torrey, "{why}");
        // The sensor, 4 bitmaps, 11 bsdfs, 3 emitters and 5 shapes.
        assert_eq!(
            why,
            "scene version 0.6.0, every plugin (24) one the torrey course's renderer reads"
        );
        // No plugins at all: nothing the course does not read.
        assert_eq!(detect06("").0, Dialect::Torrey);
    }

    #[test]
    fn any_other_plugin_makes_a_mitsuba_file_and_is_named_with_its_position() {
        let course = "<shape type=\"sphere\"><bsdf type=\"diffuse\"/></shape>\n";
        for (foreign, what, column) in [
            ("<bsdf type=\"roughconductor\"/>", "bsdf 'roughconductor'", 1),
            ("<bsdf type=\"dielectric\"/>", "bsdf 'dielectric'", 1),
            ("<bsdf type=\"conductor\"/>", "bsdf 'conductor'", 1),
            ("<bsdf type=\"roughplastic\"/>", "bsdf 'roughplastic'", 1),
            ("<bsdf type=\"mask\"/>", "bsdf 'mask'", 1),
            ("<bsdf type=\"normalmap\"/>", "bsdf 'normalmap'", 1),
            ("<bsdf type=\"roughdiffuse\"/>", "bsdf 'roughdiffuse'", 1),
            ("<shape type=\"cube\"/>", "shape 'cube'", 1),
            ("<shape type=\"disk\"/>", "shape 'disk'", 1),
            ("<shape type=\"shapegroup\"/>", "shape 'shapegroup'", 1),
            ("<sensor type=\"thinlens\"/>", "sensor 'thinlens'", 1),
            ("<sensor type=\"orthographic\"/>", "sensor 'orthographic'", 1),
            ("<emitter type=\"constant\"/>", "emitter 'constant'", 1),
            ("<emitter type=\"spot\"/>", "emitter 'spot'", 1),
            ("<emitter type=\"area\" id=\"a\"/>", "emitter 'area'", 1),
            ("<shape type=\"sphere\"><emitter type=\"point\"/></shape>", "emitter 'point' in a shape", 22),
            ("<texture type=\"checkerboard\"/>", "texture 'checkerboard'", 1),
            // Nested: inside a course bsdf, a twosided, a shape.
            ("<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\"/></bsdf>", "texture 'checkerboard'", 22),
            ("<bsdf type=\"twosided\"><bsdf type=\"conductor\"/></bsdf>", "bsdf 'conductor'", 23),
            ("<shape type=\"obj\"><bsdf type=\"roughplastic\"/></shape>", "bsdf 'roughplastic'", 19),
        ] {
            let (d, why) = detect06(&format!("{course}{foreign}"));
            assert_eq!(d, Dialect::Mitsuba3, "{foreign}: {why}");
            // The foreign element is on line 3 (line 1 is <scene>, line 2 the course shape).
            assert_eq!(
                why,
                format!(
                    "scene version 0.6.0 with {what} at t.xml:3:{column}, which the torrey course's renderer does not read: Mitsuba's rules"
                ),
                "{foreign}"
            );
        }
    }

    #[test]
    fn the_first_foreign_plugin_in_document_order_decides() {
        let (_, why) = detect06(
            "<shape type=\"sphere\"><bsdf type=\"twosided\"><bsdf type=\"dielectric\"/></bsdf></shape>\n<bsdf type=\"conductor\"/>",
        );
        assert!(why.contains("bsdf 'dielectric' at t.xml:2:"), "{why}");
    }

    #[test]
    fn other_versions() {
        let path = Path::new("t.xml");
        let detect_text = |text: &str| {
            let root = crate::xml::parse_document(text, path, 64).unwrap();
            detect(&root, &Sources::new(path))
        };
        let (d, why) =
            detect_text("<scene version=\"3.0.0\"><bsdf type=\"phong\"/></scene>").unwrap();
        assert_eq!(
            (d, why.as_str()),
            (Dialect::Mitsuba3, "scene version 3.0.0")
        );
        let (d, _) =
            detect_text("<scene version=\"1.0\"><bsdf type=\"dielectric\"/></scene>").unwrap();
        assert_eq!(d, Dialect::Torrey);
        let e = detect_text("<scene version=\"x\"/>").unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.xml:1:17: error: cannot parse scene version 'x'"
        );
    }
}
