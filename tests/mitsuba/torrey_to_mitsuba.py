#!/usr/bin/env python3
"""Converts a torrey-dialect scene (version 0.5/0.6, camelCase) into a Mitsuba 3 scene
(version 3.0.0, snake_case) that renders the same picture under torrey's conventions
(docs/conventions.md, shared CONVENTIONS.md).

Usage:
  python3 tests/mitsuba/torrey_to_mitsuba.py SCENE.xml [-o OUT.xml] [--width W] [--height H]
          [--spp N] [--max-depth D]
Standard library only; make_references.py imports `convert` from here.

What it changes (each applied change is reported in the returned `conversions` list):
  * names camelCase -> snake_case (toWorld -> to_world, ...), <lookAt> -> <lookat>;
  * every bsdf but a dielectric is wrapped in `twosided` (torrey shades both sides); shapes without a bsdf get
    a two-sided diffuse 0.5 (Mitsuba's default bsdf, made two-sided);
  * <background> -> `constant` emitter; 0.5 grey when the tag is absent and the scene has no
    `envmap` or `constant` emitter (torrey's parser drops the implicit background then too);
  * `envmap` emitters, both syntaxes: Mitsuba style (`filename`, `scale`) and seed style (a nested
    bitmap `<texture>`, e.g. name="reflectance", and `intensity_scale`) -> Mitsuba 3 `envmap` with
    an absolute `filename`, `scale` = scale * intensity_scale and `to_world` kept as is (Mitsuba 3's
    envmap orientation is the one torrey uses, so no extra rotation);
  * film: box rfilter, rgb float32; sampler: `independent`; width/height/spp/max_depth overrides;
  * torrey `mirror` with reflectance 1 -> `conductor` with material "none" (identical);
    other mirrors and plastic/phong/blinn/blinn_microfacet -> the Python plugins
    torrey_mirror/torrey_plastic/torrey_phong/torrey_blinn/torrey_blinn_microfacet
    (tests/mitsuba/torrey_bsdfs.py must be imported and registered before loading);
  * bitmap uscale/vscale/uoffset/voffset -> to_uv (uv' = scale * uv + offset);
  * relative file names are made absolute so the output can live anywhere.
"""
import argparse
import os
import re
import sys
import xml.etree.ElementTree as ET

TORREY_PLUGIN_BSDFS = {
    "mirror": "torrey_mirror",
    "plastic": "torrey_plastic",
    "phong": "torrey_phong",
    "blinn": "torrey_blinn",
    "blinnphong": "torrey_blinn",
    "blinn_microfacet": "torrey_blinn_microfacet",
    "microfacet": "torrey_blinn_microfacet",
}
PARAM_TAGS = {"float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector",
              "transform", "ref", "srgb"}
TRANSFORM_TAGS = {"lookat", "translate", "rotate", "scale", "matrix"}


def snake(name):
    """camelCase -> snake_case (a run of capitals is one word: intIOR -> int_ior); names already
    in snake_case are unchanged."""
    return re.sub(r"(?<=[a-z0-9])([A-Z]+)(?![a-z])|(?<=[a-z0-9])([A-Z])",
                  lambda m: "_" + (m.group(1) or m.group(2)).lower(), name)


class Converter:
    def __init__(self, src, width=None, height=None, spp=None, max_depth=None):
        self.src = os.path.abspath(src)
        self.base = os.path.dirname(self.src)
        self.width, self.height, self.spp, self.max_depth = width, height, spp, max_depth
        self.conversions = []
        self.uses_plugins = set()
        self.has_environment = False  # an envmap or constant emitter replaces the implicit background

    def note(self, what):
        if what not in self.conversions:
            self.conversions.append(what)

    # ---- generic copy -------------------------------------------------------------------
    def copy(self, e):
        tag = e.tag
        if tag.lower() == "lookat":
            if tag != "lookat":
                self.note("lookAt -> lookat")
            tag = "lookat"
        out = ET.Element(tag)
        for k, v in e.attrib.items():
            if k == "name" and tag in PARAM_TAGS | {"texture", "bsdf"}:
                nv = snake(v)
                if nv != v:
                    self.note("camelCase names -> snake_case")
                v = nv
            out.set(k, v)
        if tag == "string" and out.get("name") == "filename":
            out.set("value", self.abspath(out.get("value")))
        for c in e:
            if isinstance(c.tag, str):
                out.append(self.convert_child(c))
        return out

    def abspath(self, p):
        return p if os.path.isabs(p) else os.path.normpath(os.path.join(self.base, p))

    def convert_child(self, c):
        if c.tag == "emitter" and c.get("type") == "envmap":
            return self.envmap(c)
        if c.tag == "bsdf":
            return self.bsdf(c)
        if c.tag == "texture":
            return self.texture(c)
        return self.copy(c)

    # ---- bsdfs --------------------------------------------------------------------------
    def param(self, e, name):
        for c in e:
            if isinstance(c.tag, str) and c.get("name") == name:
                return c
        return None

    def bsdf(self, e):
        t = e.get("type")
        bid = e.get("id")
        name = e.get("name")
        if t == "twosided":
            inner = [c for c in e if isinstance(c.tag, str) and c.tag == "bsdf"]
            core = self.bsdf_core(inner[0]) if inner else self.default_core()
        else:
            core = self.bsdf_core(e)
        if core.get("type") in ("dielectric", "thindielectric", "roughdielectric"):
            # Dielectrics refract on both sides themselves (torrey never mirrors them).
            if bid:
                core.set("id", bid)
            if name:
                core.set("name", name)
            return core
        wrap = ET.Element("bsdf", {"type": "twosided"})
        if bid:
            wrap.set("id", bid)
        if name:
            wrap.set("name", name)
        wrap.append(core)
        self.note("bsdfs wrapped in twosided")
        return wrap

    def default_core(self):
        core = ET.Element("bsdf", {"type": "diffuse"})
        ET.SubElement(core, "rgb", {"name": "reflectance", "value": "0.5, 0.5, 0.5"})
        return core

    def bsdf_core(self, e):
        t = e.get("type")
        core = ET.Element("bsdf", {"type": t})
        kids = [self.convert_child(c) for c in e if isinstance(c.tag, str)]
        if t == "mirror":
            refl = self.param(e, "reflectance")
            if refl is None or (refl.tag == "rgb" and all(
                    abs(float(x) - 1.0) < 1e-6 for x in re.split(r"[,\s]+", refl.get("value").strip()))):
                core.set("type", "conductor")
                ET.SubElement(core, "string", {"name": "material", "value": "none"})
                self.note("mirror(reflectance 1) -> conductor none")
                return core
        if t in TORREY_PLUGIN_BSDFS:
            core.set("type", TORREY_PLUGIN_BSDFS[t])
            self.uses_plugins.add(TORREY_PLUGIN_BSDFS[t])
            self.note("%s -> %s (Python plugin)" % (t, TORREY_PLUGIN_BSDFS[t]))
        elif t != "diffuse":
            self.note("bsdf %s passed through unchanged" % t)
        for k in kids:
            core.append(k)
        return core

    # ---- environment map ----------------------------------------------------------------
    def envmap(self, e):
        out = ET.Element("emitter", {k: v for k, v in e.attrib.items()})
        filename = None
        scale = 1.0
        transform = None
        for c in e:
            if not isinstance(c.tag, str):
                continue
            n = c.get("name")
            if c.tag == "string" and n == "filename":
                filename = c.get("value")
            elif c.tag == "float" and n in ("scale", "intensity_scale", "intensityScale"):
                scale *= float(c.get("value"))
            elif c.tag == "transform" and n in ("toWorld", "to_world"):
                transform = self.copy(c)
                transform.set("name", "to_world")
            elif c.tag == "texture" and filename is None:
                if c.get("type") not in ("bitmap", None):
                    raise ValueError("envmap: nested texture of type %s" % c.get("type"))
                for t in c:
                    if isinstance(t.tag, str) and t.get("name") == "filename":
                        filename = t.get("value")
                    elif isinstance(t.tag, str):
                        self.note("envmap texture parameter %s dropped" % t.get("name"))
                self.note("envmap nested bitmap texture -> filename")
            else:
                self.note("envmap parameter %s dropped" % n)
        if filename is None:
            raise ValueError("envmap without a filename or a nested bitmap texture")
        ET.SubElement(out, "string", {"name": "filename", "value": self.abspath(filename)})
        ET.SubElement(out, "float", {"name": "scale", "value": repr(scale)})
        if transform is not None:
            out.append(transform)
        self.note("envmap (absolute filename, scale, to_world kept)")
        self.has_environment = True
        return out

    # ---- textures -----------------------------------------------------------------------
    def texture(self, e):
        out = ET.Element("texture", {k: (snake(v) if k == "name" else v) for k, v in e.attrib.items()})
        scale = {"uscale": 1.0, "vscale": 1.0, "uoffset": 0.0, "voffset": 0.0}
        have_uv = False
        for c in e:
            if not isinstance(c.tag, str):
                continue
            n = c.get("name")
            if e.get("type") == "bitmap" and n in scale:
                scale[n] = float(c.get("value"))
                have_uv = True
                continue
            out.append(self.convert_child(c))
        if have_uv and (scale["uscale"], scale["vscale"], scale["uoffset"], scale["voffset"]) != (1, 1, 0, 0):
            tr = ET.SubElement(out, "transform", {"name": "to_uv"})
            ET.SubElement(tr, "scale", {"x": repr(scale["uscale"]), "y": repr(scale["vscale"])})
            ET.SubElement(tr, "translate", {"x": repr(scale["uoffset"]), "y": repr(scale["voffset"])})
            self.note("uscale/vscale/uoffset/voffset -> to_uv")
        return out

    # ---- sensor / integrator ------------------------------------------------------------
    def sensor(self, e):
        out = ET.Element("sensor", dict(e.attrib))
        film_src = sampler_src = None
        for c in e:
            if not isinstance(c.tag, str):
                continue
            if c.tag == "film":
                film_src = c
            elif c.tag == "sampler":
                sampler_src = c
            else:
                out.append(self.convert_child(c))
        get_int = lambda el, *names: next((int(float(c.get("value"))) for c in (el if el is not None else [])
                                           if isinstance(c.tag, str) and c.get("name") in names), None)
        width = self.width or get_int(film_src, "width") or 768
        height = self.height or get_int(film_src, "height") or 576
        spp = self.spp or get_int(sampler_src, "sampleCount", "sample_count") or 4
        seed = get_int(sampler_src, "seed")
        sampler = ET.SubElement(out, "sampler", {"type": "independent"})
        ET.SubElement(sampler, "integer", {"name": "sample_count", "value": str(spp)})
        if seed is not None:
            ET.SubElement(sampler, "integer", {"name": "seed", "value": str(seed)})
        film = ET.SubElement(out, "film", {"type": "hdrfilm"})
        ET.SubElement(film, "integer", {"name": "width", "value": str(width)})
        ET.SubElement(film, "integer", {"name": "height", "value": str(height)})
        ET.SubElement(film, "string", {"name": "pixel_format", "value": "rgb"})
        ET.SubElement(film, "string", {"name": "component_format", "value": "float32"})
        ET.SubElement(film, "rfilter", {"type": "box"})
        self.note("film box rfilter, independent sampler")
        self.film_size, self.film_spp = (width, height), spp
        return out

    def integrator(self, e):
        out = ET.Element("integrator", {"type": "path"})
        depth = self.max_depth
        rr = None
        if e is not None:
            if e.get("type") not in ("path", None):
                self.note("integrator %s -> path" % e.get("type"))
            for c in e:
                if isinstance(c.tag, str) and c.get("name") in ("maxDepth", "max_depth") and depth is None:
                    depth = int(c.get("value"))
                if isinstance(c.tag, str) and c.get("name") in ("rrDepth", "rr_depth"):
                    rr = int(c.get("value"))
        if depth is None:
            depth = -1
        ET.SubElement(out, "integer", {"name": "max_depth", "value": str(depth)})
        if rr is not None:
            ET.SubElement(out, "integer", {"name": "rr_depth", "value": str(rr)})
        self.film_depth = depth
        return out

    # ---- scene --------------------------------------------------------------------------
    def run(self):
        root = ET.parse(self.src).getroot()
        if root.tag != "scene":
            raise ValueError("%s: root element is <%s>, not <scene>" % (self.src, root.tag))
        scene = ET.Element("scene", {"version": "3.0.0"})
        if root.get("version", "").split(".")[0] not in ("0", "1"):
            self.note("source is not torrey dialect (version %s)" % root.get("version"))
        integ = next((c for c in root if c.tag == "integrator"), None)
        scene.append(self.integrator(integ))
        background = None
        for c in root:
            if not isinstance(c.tag, str) or c.tag == "integrator":
                continue
            if c.tag == "background":
                background = c
                continue
            if c.tag == "sensor":
                scene.append(self.sensor(c))
            elif c.tag == "shape":
                sh = self.copy(c)
                has_bsdf = any(k.tag in ("bsdf", "ref") for k in sh)
                if not has_bsdf:
                    wrap = ET.SubElement(sh, "bsdf", {"type": "twosided"})
                    wrap.append(self.default_core())
                    self.note("shape without bsdf -> twosided diffuse 0.5")
                scene.append(sh)
            else:
                if c.tag == "emitter" and c.get("type") == "constant":
                    self.has_environment = True
                scene.append(self.convert_child(c))
        if background is not None:
            em = ET.SubElement(scene, "emitter", {"type": "constant"})
            rad = self.param(background, "radiance")
            value = rad.get("value") if rad is not None else "0.5"
            self.note("<background> -> constant emitter")
            ET.SubElement(em, "rgb", {"name": "radiance", "value": value})
        elif self.has_environment:
            self.note("envmap/constant emitter present: no implicit background")
        else:
            em = ET.SubElement(scene, "emitter", {"type": "constant"})
            self.note("no <background> -> constant emitter 0.5")
            ET.SubElement(em, "rgb", {"name": "radiance", "value": "0.5, 0.5, 0.5"})
        ET.indent(scene, "    ")
        xml = ET.tostring(scene, encoding="unicode")
        return '<?xml version="1.0" encoding="utf-8"?>\n<!-- converted from %s by tests/mitsuba/torrey_to_mitsuba.py -->\n%s\n' % (self.src, xml)


def convert(src, width=None, height=None, spp=None, max_depth=None):
    """Returns (mitsuba3_xml_text, info) for a torrey-dialect scene file. info has
    conversions, plugins, width, height, spp, max_depth."""
    c = Converter(src, width, height, spp, max_depth)
    text = c.run()
    info = {"conversions": c.conversions, "plugins": sorted(c.uses_plugins),
            "width": c.film_size[0], "height": c.film_size[1], "spp": c.film_spp,
            "max_depth": c.film_depth}
    return text, info


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("-o", "--output")
    ap.add_argument("--width", type=int)
    ap.add_argument("--height", type=int)
    ap.add_argument("--spp", type=int)
    ap.add_argument("--max-depth", type=int)
    a = ap.parse_args()
    text, info = convert(a.scene, a.width, a.height, a.spp, a.max_depth)
    if a.output:
        with open(a.output, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    print("conversions: " + "; ".join(info["conversions"]), file=sys.stderr)


if __name__ == "__main__":
    main()
