#!/usr/bin/env python3
"""Render a torrey-dialect XML scene with Blender Cycles (CPU, headless) as an independent reference.

Why: torrey must agree with other renderers; Cycles is a second, unrelated implementation of the
same light transport. This script rebuilds a torrey scene in Blender under torrey's / Mitsuba 3's
conventions (docs/conventions.md, shared CONVENTIONS.md) and writes a linear float EXR.

Run (after `bash tests/blender/setup.sh`):

    tests/blender/.venv/bin/python tests/blender/torrey_to_blender.py scenes/cbox.xml -o cbox.exr \
        --width 96 --spp 1024 --threads 2
    python3 tests/blender/torrey_to_blender.py scenes/materials.xml --check   # parse only, no bpy

What is expressible: perspective camera (fov + fovAxis, toWorld/lookAt), obj / ply / sphere /
rectangle shapes with toWorld and flipNormals, diffuse (constant, bitmap or checkerboard),
torrey's Schlick mirror, normal maps, area / point / envmap emitters, <background>.
Anything else (phong, blinn, blinn_microfacet, plastic, Mitsuba-3 dialect scenes, non-box pixel
filters, max_depth < 2) is refused with exit status 2 and a message: never approximated.

Known, documented differences from torrey / Mitsuba:
- spheres are UV-sphere meshes (SPHERE_SEGMENTS x SPHERE_RINGS) with exact radial normals; the
  polygon lies inside the true sphere by at most r (1 - cos(pi / SPHERE_SEGMENTS)) (~7.5e-5 r).
- Cycles' path termination differs from Mitsuba's Russian roulette (both unbiased).
- envmap rows are texel-centred (Mitsuba uses point samples at theta = pi j / (H - 1)).
- normal maps: where the perturbed normal is grazing, Cycles adjusts the shading normal and
  Mitsuba does not (a bump test came out 1.3% darker in Cycles, all of it at such pixels).
"""

import argparse
import math
import os
import struct
import sys
import time
import xml.etree.ElementTree as ET

SPHERE_SEGMENTS = 256
SPHERE_RINGS = 128
UNBOUNDED_BOUNCES = 1024


class Unsupported(Exception):
    """The scene uses something this converter refuses to approximate."""


# --------------------------------------------------------------------------------------------
# small linear algebra on 4x4 row-major lists (no numpy needed for parsing)


def mat_identity():
    return [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def mat_apply_point(m, p):
    return [m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3] for i in range(3)]


def vsub(a, b):
    return [a[i] - b[i] for i in range(3)]


def vdot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def vcross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def vnorm(a):
    n = math.sqrt(vdot(a, a))
    if n == 0.0:
        raise ValueError("zero-length vector")
    return [x / n for x in a]


def rotation(axis, degrees):
    x, y, z = vnorm(axis)
    t = math.radians(degrees)
    c, s, C = math.cos(t), math.sin(t), 1.0 - math.cos(t)
    return [
        [c + x * x * C, x * y * C - z * s, x * z * C + y * s, 0.0],
        [y * x * C + z * s, c + y * y * C, y * z * C - x * s, 0.0],
        [z * x * C - y * s, z * y * C + x * s, c + z * z * C, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]


def look_at(origin, target, up):
    """Mitsuba's lookat: camera space +z forward, +x left, +y up."""
    d = vnorm(vsub(target, origin))
    left = vnorm(vcross(up, d))
    new_up = vcross(d, left)
    return [
        [left[0], new_up[0], d[0], origin[0]],
        [left[1], new_up[1], d[1], origin[1]],
        [left[2], new_up[2], d[2], origin[2]],
        [0.0, 0.0, 0.0, 1.0],
    ]


# --------------------------------------------------------------------------------------------
# XML reading


def _floats(text):
    return [float(t) for t in text.replace(",", " ").split()]


def _where(el, path):
    return f"{path}: <{el.tag}{(' name=' + repr(el.get('name'))) if el.get('name') else ''}>"


def parse_vec3(el, default=0.0):
    if el.get("value") is not None:
        v = _floats(el.get("value"))
        return v * 3 if len(v) == 1 else v[:3]
    return [float(el.get(k, default)) for k in "xyz"]


def parse_transform(el, path):
    m = mat_identity()
    for op in el:
        tag = op.tag
        if tag == "translate":
            v = parse_vec3(op, 0.0)
            t = mat_identity()
            for i in range(3):
                t[i][3] = v[i]
        elif tag == "scale":
            v = parse_vec3(op, 1.0)
            t = mat_identity()
            for i in range(3):
                t[i][i] = v[i]
        elif tag == "rotate":
            axis = _floats(op.get("axis")) if op.get("axis") else [float(op.get(k, 0)) for k in "xyz"]
            t = rotation(axis, float(op.get("angle", 0)))
        elif tag == "matrix":
            v = _floats(op.get("value"))
            if len(v) == 9:
                t = [v[0:3] + [0.0], v[3:6] + [0.0], v[6:9] + [0.0], [0.0, 0.0, 0.0, 1.0]]
            else:
                t = [v[0:4], v[4:8], v[8:12], v[12:16]]
        elif tag.lower() == "lookat":
            t = look_at(_floats(op.get("origin")), _floats(op.get("target")),
                        _floats(op.get("up", "0 1 0")))
        else:
            raise Unsupported(f"{_where(op, path)}: unknown transform operation")
        m = mat_mul(t, m)
    return m


def params(el):
    """name -> element for the direct property children of a plugin element."""
    return {c.get("name"): c for c in el if c.get("name") is not None}


def pget(ps, *names):
    for n in names:
        if n in ps:
            return ps[n]
    return None


def pfloat(ps, default, *names):
    e = pget(ps, *names)
    return float(e.get("value")) if e is not None else default


def pstr(ps, default, *names):
    e = pget(ps, *names)
    return e.get("value") if e is not None else default


def pbool(ps, default, *names):
    e = pget(ps, *names)
    return e.get("value").strip().lower() == "true" if e is not None else default


class SceneReader:
    """Reads a torrey XML file into plain dicts (no Blender types), resolving refs and defaults."""

    def __init__(self, path):
        self.path = os.path.abspath(path)
        self.dir = os.path.dirname(self.path)
        self.textures = {}
        self.bsdfs = {}
        self.warnings = []

    def resolve(self, filename):
        return filename if os.path.isabs(filename) else os.path.normpath(os.path.join(self.dir, filename))

    def read(self):
        root = ET.parse(self.path).getroot()
        if root.tag != "scene":
            raise Unsupported(f"{self.path}: root element is <{root.tag}>, not <scene>")
        version = [int(x) for x in root.get("version", "0.6.0").split(".")[:3]]
        if version[0] >= 2:
            raise Unsupported(f"{self.path}: Mitsuba {root.get('version')} dialect (one-sided bsdfs) "
                              "is not supported; this converter reads torrey-dialect scenes")
        scene = {
            "path": self.path,
            "camera": None,
            "max_depth": -1,
            "shapes": [],
            "lights": [],
            "background": [0.5, 0.5, 0.5],
        }
        for el in root:
            tag = el.tag
            if tag == "integrator":
                ps = params(el)
                kind = el.get("type", "path")
                if kind not in ("path", "direct"):
                    raise Unsupported(f"{self.path}: integrator '{kind}' is not supported")
                scene["max_depth"] = int(pfloat(ps, -1 if kind == "path" else 2, "maxDepth", "max_depth"))
            elif tag == "sensor":
                scene["camera"] = self.read_sensor(el)
            elif tag == "texture":
                self.textures[el.get("id")] = self.read_texture(el)
            elif tag == "bsdf":
                b = self.read_bsdf(el)
                self.bsdfs[el.get("id")] = b
            elif tag == "shape":
                scene["shapes"].append(self.read_shape(el))
            elif tag == "emitter":
                self.read_emitter(el, scene)
            elif tag == "background":
                ps = params(el)
                scene["background"] = parse_color(pget(ps, "radiance"))
            elif tag in ("default",):
                raise Unsupported(f"{self.path}: <default> parameters are not supported")
            else:
                self.warnings.append(f"ignored top-level <{tag}>")
        if scene["camera"] is None:
            raise Unsupported(f"{self.path}: no <sensor>")
        md = scene["max_depth"]
        if 0 <= md < 2:
            raise Unsupported(f"{self.path}: max_depth {md} (emitters only) has no Cycles equivalent")
        return scene

    def read_sensor(self, el):
        if el.get("type", "perspective") != "perspective":
            raise Unsupported(f"{self.path}: sensor type '{el.get('type')}' is not supported")
        ps = params(el)
        cam = {
            "fov": pfloat(ps, 39.3077, "fov"),
            "fov_axis": pstr(ps, "x", "fovAxis", "fov_axis").lower(),
            "to_world": mat_identity(),
            "width": 768,
            "height": 576,
            "spp": 4,
            "near": pfloat(ps, 1e-2, "nearClip", "near_clip"),
            "far": pfloat(ps, 1e4, "farClip", "far_clip"),
        }
        if pget(ps, "focalLength", "focal_length") is not None:
            raise Unsupported(f"{self.path}: focal_length is not supported; use fov")
        t = pget(ps, "toWorld", "to_world")
        if t is not None:
            cam["to_world"] = parse_transform(t, self.path)
        for c in el:
            if c.tag == "film":
                fps = params(c)
                cam["width"] = int(pfloat(fps, 768, "width"))
                cam["height"] = int(pfloat(fps, 576, "height"))
                for f in c:
                    if f.tag == "rfilter" and f.get("type", "box") != "box":
                        raise Unsupported(f"{self.path}: pixel filter '{f.get('type')}' is not supported (box only)")
            elif c.tag == "sampler":
                cam["spp"] = int(pfloat(params(c), 4, "sampleCount", "sample_count"))
        return cam

    def read_texture(self, el):
        kind = el.get("type")
        ps = params(el)
        if kind == "bitmap":
            filename = pstr(ps, None, "filename")
            if filename is None:
                raise Unsupported(f"{_where(el, self.path)}: bitmap without filename")
            us, vs = pfloat(ps, 1.0, "uscale"), pfloat(ps, 1.0, "vscale")
            uo, vo = pfloat(ps, 0.0, "uoffset"), pfloat(ps, 0.0, "voffset")
            if pget(ps, "to_uv", "toUV") is not None:
                raise Unsupported(f"{_where(el, self.path)}: to_uv transforms are not supported")
            return {
                "kind": "bitmap",
                "filename": self.resolve(filename),
                "uv_scale": [us, vs],
                "uv_offset": [uo, vo],
                "raw": pbool(ps, False, "raw"),
                "filter": pstr(ps, "bilinear", "filter_type", "filterType"),
                "wrap": pstr(ps, "repeat", "wrap_mode", "wrapMode"),
            }
        if kind == "checkerboard":
            return {
                "kind": "checkerboard",
                "color0": parse_color(pget(ps, "color0")) if pget(ps, "color0") is not None else [0.4] * 3,
                "color1": parse_color(pget(ps, "color1")) if pget(ps, "color1") is not None else [0.2] * 3,
                "uv_scale": [pfloat(ps, 1.0, "uscale"), pfloat(ps, 1.0, "vscale")],
                "uv_offset": [pfloat(ps, 0.0, "uoffset"), pfloat(ps, 0.0, "voffset")],
            }
        raise Unsupported(f"{_where(el, self.path)}: texture type '{kind}' is not supported")

    def color_param(self, el, name, default):
        """A constant colour or a texture (inline <texture> or <ref name=... id=...>)."""
        for c in el:
            if c.get("name") != name:
                continue
            if c.tag in ("rgb", "spectrum", "float", "srgb"):
                return {"constant": parse_color(c)}
            if c.tag == "texture":
                return {"texture": self.read_texture(c)}
            if c.tag == "ref":
                if c.get("id") not in self.textures:
                    raise Unsupported(f"{self.path}: unknown texture id '{c.get('id')}'")
                return {"texture": self.textures[c.get("id")]}
        return {"constant": list(default)}

    def read_bsdf(self, el):
        kind = el.get("type")
        if kind == "twosided":  # torrey shades both sides anyway
            inner = [c for c in el if c.tag == "bsdf"]
            if len(inner) != 1:
                raise Unsupported(f"{_where(el, self.path)}: twosided needs exactly one bsdf")
            b = self.read_bsdf(inner[0])
            return b
        normal_map = None
        for c in el:
            if c.tag == "texture" and c.get("name") in ("normal_map", "normalmap"):
                normal_map = self.read_texture(c)
                normal_map["raw"] = True
        if kind == "normalmap":  # Mitsuba 3 wrapper: <texture name="normalmap"> + inner bsdf
            inner = [c for c in el if c.tag == "bsdf"]
            b = self.read_bsdf(inner[0])
            b["normal_map"] = normal_map
            return b
        if kind == "diffuse":
            return {"kind": "diffuse", "reflectance": self.color_param(el, "reflectance", [0.5] * 3),
                    "normal_map": normal_map}
        if kind == "mirror":
            return {"kind": "mirror", "reflectance": self.color_param(el, "reflectance", [1.0] * 3),
                    "normal_map": normal_map}
        # phong, blinn, blinn_microfacet, plastic, ...: refuse rather than approximate.
        return {"kind": "unsupported", "type": kind, "where": _where(el, self.path)}

    def read_shape(self, el):
        kind = el.get("type")
        ps = params(el)
        shape = {
            "kind": kind,
            "to_world": mat_identity(),
            "bsdf": {"kind": "diffuse", "reflectance": {"constant": [0.5] * 3}, "normal_map": None},
            "emitter": None,
            "flip_normals": pbool(ps, False, "flipNormals", "flip_normals"),
            "face_normals": pbool(ps, False, "faceNormals", "face_normals"),
            "where": _where(el, self.path),
        }
        t = pget(ps, "toWorld", "to_world")
        if t is not None:
            shape["to_world"] = parse_transform(t, self.path)
        if kind in ("obj", "ply"):
            shape["filename"] = self.resolve(pstr(ps, None, "filename"))
        elif kind == "sphere":
            c = pget(ps, "center")
            shape["center"] = parse_vec3(c) if c is not None else [0.0, 0.0, 0.0]
            shape["radius"] = pfloat(ps, 1.0, "radius")
        elif kind != "rectangle":
            raise Unsupported(f"{shape['where']}: shape type '{kind}' is not supported")
        for c in el:
            if c.tag == "bsdf":
                shape["bsdf"] = self.read_bsdf(c)
            elif c.tag == "ref" and c.get("name") in (None, "bsdf"):
                if c.get("id") not in self.bsdfs:
                    raise Unsupported(f"{shape['where']}: unknown bsdf id '{c.get('id')}'")
                shape["bsdf"] = self.bsdfs[c.get("id")]
            elif c.tag == "emitter":
                if c.get("type") != "area":
                    raise Unsupported(f"{shape['where']}: shape emitter '{c.get('type')}' is not supported")
                shape["emitter"] = parse_color(pget(params(c), "radiance"))
        if shape["bsdf"]["kind"] == "unsupported":
            raise Unsupported(f"{shape['bsdf']['where']}: bsdf '{shape['bsdf']['type']}' has no exact "
                              "Cycles equivalent (used by " + shape["where"] + ")")
        return shape

    def read_emitter(self, el, scene):
        kind = el.get("type")
        ps = params(el)
        if kind == "point":
            p = pget(ps, "position")
            pos = parse_vec3(p) if p is not None else [0.0, 0.0, 0.0]
            t = pget(ps, "toWorld", "to_world")
            if t is not None:
                pos = mat_apply_point(parse_transform(t, self.path), pos)
            scene["lights"].append({"kind": "point", "position": pos,
                                    "intensity": parse_color(pget(ps, "intensity"))})
        elif kind in ("constant",):
            scene["background"] = parse_color(pget(ps, "radiance"))
        elif kind == "envmap":
            t = pget(ps, "toWorld", "to_world")
            scene["lights"].append({
                "kind": "envmap",
                "filename": self.resolve(pstr(ps, None, "filename")),
                "scale": pfloat(ps, 1.0, "scale", "intensity_scale", "intensityScale"),
                "to_world": parse_transform(t, self.path) if t is not None else mat_identity(),
            })
            scene["background"] = None
        else:
            raise Unsupported(f"{_where(el, self.path)}: emitter '{kind}' is not supported")


def parse_color(el):
    if el is None:
        return [1.0, 1.0, 1.0]
    if el.tag == "srgb":
        raise Unsupported("<srgb> colours are not supported")
    v = _floats(el.get("value"))
    return v * 3 if len(v) == 1 else v[:3]


def horizontal_fov(cam):
    """Full horizontal fov in degrees from fov + fovAxis and the film aspect (Mitsuba semantics)."""
    w, h = cam["width"], cam["height"]
    axis = cam["fov_axis"]
    if axis == "smaller":
        axis = "x" if w <= h else "y"
    elif axis == "larger":
        axis = "x" if w >= h else "y"
    t = math.tan(math.radians(cam["fov"]) / 2)
    if axis == "x":
        tx = t
    elif axis == "y":
        tx = t * w / h
    elif axis == "diagonal":
        tx = t * w / math.hypot(w, h)
    else:
        raise Unsupported(f"unknown fovAxis '{cam['fov_axis']}'")
    return math.degrees(2 * math.atan(tx))


def read_scene(path):
    reader = SceneReader(path)
    scene = reader.read()
    scene["warnings"] = reader.warnings
    return scene


# --------------------------------------------------------------------------------------------
# mesh readers (Mitsuba conventions: OBJ v flipped, PLY not)


def read_obj(path):
    """Triangles with per-corner positions, uvs (Mitsuba convention: v flipped) and normals."""
    vs, vts, vns = [], [], []
    corners = []  # triangles of (vi, ti, ni)
    with open(path, "r", errors="replace") as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                vs.append([float(x) for x in parts[1:4]])
            elif parts[0] == "vt":
                vts.append([float(x) for x in parts[1:3]])
            elif parts[0] == "vn":
                vns.append([float(x) for x in parts[1:4]])
            elif parts[0] == "f":
                idx = []
                for p in parts[1:]:
                    fields = p.split("/")

                    def ix(k, n):
                        if len(fields) <= k or fields[k] == "":
                            return None
                        i = int(fields[k])
                        return i - 1 if i > 0 else n + i

                    idx.append((ix(0, len(vs)), ix(1, len(vts)), ix(2, len(vns))))
                for k in range(1, len(idx) - 1):
                    corners.append((idx[0], idx[k], idx[k + 1]))
    # Mitsuba dedups vertices by (v, vt, vn) triple; do the same so smooth normals match.
    keymap, pos, uv, nrm, tris = {}, [], [], [], []
    has_uv = all(c[1] is not None for t in corners for c in t) and len(vts) > 0
    has_n = all(c[2] is not None for t in corners for c in t) and len(vns) > 0
    for t in corners:
        tri = []
        for c in t:
            key = (c[0], c[1] if has_uv else None, c[2] if has_n else None)
            if key not in keymap:
                keymap[key] = len(pos)
                pos.append(vs[c[0]])
                if has_uv:
                    u, v = vts[c[1]]
                    uv.append([u, 1.0 - v])
                if has_n:
                    nrm.append(vns[c[2]])
            tri.append(keymap[key])
        tris.append(tri)
    return {"positions": pos, "uvs": uv if has_uv else None, "normals": nrm if has_n else None, "tris": tris}


def read_ply(path):
    """ASCII / binary little- or big-endian PLY: x y z, optional normals and uvs, polygon faces."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header")
    header = data[:end].decode("ascii", "replace").splitlines()
    body_start = data.index(b"\n", end) + 1
    fmt = None
    elements = []
    for line in header:
        p = line.split()
        if not p:
            continue
        if p[0] == "format":
            fmt = p[1]
        elif p[0] == "element":
            elements.append({"name": p[1], "count": int(p[2]), "props": []})
        elif p[0] == "property":
            if p[1] == "list":
                elements[-1]["props"].append((p[4], "list", p[2], p[3]))
            else:
                elements[-1]["props"].append((p[2], p[1], None, None))
    types = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
             "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
             "float": "f", "float32": "f", "double": "d", "float64": "d"}
    values = {}
    if fmt == "ascii":
        tokens = data[body_start:].split()
        pos = 0
        for el in elements:
            rows = []
            for _ in range(el["count"]):
                row = {}
                for name, kind, ct, it in el["props"]:
                    if kind == "list":
                        n = int(tokens[pos])
                        row[name] = [int(float(t)) for t in tokens[pos + 1:pos + 1 + n]]
                        pos += 1 + n
                    else:
                        row[name] = float(tokens[pos])
                        pos += 1
                rows.append(row)
            values[el["name"]] = rows
    else:
        endian = "<" if fmt == "binary_little_endian" else ">"
        off = body_start
        for el in elements:
            rows = []
            for _ in range(el["count"]):
                row = {}
                for name, kind, ct, it in el["props"]:
                    if kind == "list":
                        (n,) = struct.unpack_from(endian + types[ct], data, off)
                        off += struct.calcsize(types[ct])
                        row[name] = list(struct.unpack_from(endian + types[it] * n, data, off))
                        off += struct.calcsize(types[it]) * n
                    else:
                        (row[name],) = struct.unpack_from(endian + types[kind], data, off)
                        off += struct.calcsize(types[kind])
                rows.append(row)
            values[el["name"]] = rows
    verts = values.get("vertex", [])
    pos = [[r["x"], r["y"], r["z"]] for r in verts]
    normals = [[r["nx"], r["ny"], r["nz"]] for r in verts] if verts and "nx" in verts[0] else None
    uvs = None
    for un, vn in (("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")):
        if verts and un in verts[0]:
            uvs = [[r[un], r[vn]] for r in verts]
            break
    tris = []
    for r in values.get("face", []):
        idx = r.get("vertex_indices", r.get("vertex_index"))
        for k in range(1, len(idx) - 1):
            tris.append([idx[0], idx[k], idx[k + 1]])
    return {"positions": pos, "uvs": uvs, "normals": normals, "tris": tris}


def smooth_normals(mesh):
    """Area-weighted vertex normals, as torrey computes them when a mesh has none."""
    acc = [[0.0, 0.0, 0.0] for _ in mesh["positions"]]
    P = mesh["positions"]
    for a, b, c in mesh["tris"]:
        n = vcross(vsub(P[b], P[a]), vsub(P[c], P[a]))  # length = 2 * area
        for i in (a, b, c):
            for k in range(3):
                acc[i][k] += n[k]
    out = []
    for n in acc:
        ln = math.sqrt(vdot(n, n))
        out.append([x / ln for x in n] if ln > 0 else [0.0, 0.0, 1.0])
    return out


def sphere_mesh(center, radius):
    """UV sphere in Mitsuba's parameterisation: u = phi / 2pi, v = theta / pi, pole axis +z."""
    pos, uv, nrm, tris = [], [], [], []
    n_s, n_r = SPHERE_SEGMENTS, SPHERE_RINGS
    for j in range(n_r + 1):
        theta = math.pi * j / n_r
        for i in range(n_s + 1):
            phi = 2 * math.pi * i / n_s
            d = [math.cos(phi) * math.sin(theta), math.sin(phi) * math.sin(theta), math.cos(theta)]
            pos.append([center[k] + radius * d[k] for k in range(3)])
            nrm.append(d)
            # at the poles put u at the segment middle so each pole triangle gets a sensible uv
            uu = (i + 0.5) / n_s if j in (0, n_r) else i / n_s
            uv.append([uu, j / n_r])
    row = n_s + 1
    for j in range(n_r):
        for i in range(n_s):
            a, b = j * row + i, j * row + i + 1
            c, d = (j + 1) * row + i + 1, (j + 1) * row + i
            # outward winding: with phi increasing east and theta increasing south, (a, d, c, b)
            if j != 0:
                tris.append([a, d, b])
            if j != n_r - 1:
                tris.append([b, d, c])
    return {"positions": pos, "uvs": uv, "normals": nrm, "tris": tris}


def rectangle_mesh():
    pos = [[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]]
    uv = [[(p[0] + 1) / 2, (p[1] + 1) / 2] for p in pos]
    return {"positions": pos, "uvs": uv, "normals": None, "tris": [[0, 1, 2], [0, 2, 3]]}


# --------------------------------------------------------------------------------------------
# Blender side


def build_blender(scene, width=None, height=None, spp=None, threads=2, seed=0, max_depth=None):
    """Builds the parsed scene in a fresh Blender session; optional size / spp / depth overrides."""
    import bpy  # imported here so that parsing works without Blender

    if max_depth is not None:
        if 0 <= max_depth < 2:
            raise Unsupported(f"max_depth {max_depth} (emitters only) has no Cycles equivalent")
        scene = dict(scene, max_depth=max_depth)

    cam = dict(scene["camera"])
    if width is not None or height is not None:
        w0, h0 = cam["width"], cam["height"]
        if width is None:
            width = max(1, round(w0 * height / h0))
        if height is None:
            height = max(1, round(h0 * width / w0))
        if abs(width / height - w0 / h0) > 1e-6 * (w0 / h0):
            raise Unsupported(f"size {width}x{height} changes the aspect ratio of {w0}x{h0}")
        cam["width"], cam["height"] = width, height
    if spp is not None:
        cam["spp"] = spp

    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = cam["spp"]
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = seed
    md = scene["max_depth"]
    bounces = UNBOUNDED_BOUNCES if md < 0 else md - 2
    for attr in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
                 "volume_bounces", "transparent_max_bounces"):
        setattr(cy, attr, bounces)
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.light_sampling_threshold = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    sc.render.threads_mode = "FIXED"
    sc.render.threads = threads
    sc.render.resolution_x = cam["width"]
    sc.render.resolution_y = cam["height"]
    sc.render.resolution_percentage = 100
    sc.render.pixel_aspect_x = sc.render.pixel_aspect_y = 1.0
    sc.render.film_transparent = False
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    im = sc.render.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGB"
    im.color_depth = "32"
    im.exr_codec = "ZIP"

    # camera: Blender looks down local -z with +x right; Mitsuba looks down +z with +x left.
    cd = bpy.data.cameras.new("camera")
    cd.sensor_fit = "HORIZONTAL"
    cd.sensor_width = 36.0
    cd.lens = 18.0 / math.tan(math.radians(horizontal_fov(cam)) / 2)
    cd.clip_start = cam["near"]
    cd.clip_end = cam["far"]
    co = bpy.data.objects.new("camera", cd)
    flip = [[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]]
    co.matrix_world = _bmat(mat_mul(cam["to_world"], flip))
    sc.collection.objects.link(co)
    sc.camera = co

    images = {}
    for k, shape in enumerate(scene["shapes"]):
        _add_shape(bpy, sc, k, shape, images)
    for k, light in enumerate(scene["lights"]):
        if light["kind"] == "point":
            ld = bpy.data.lights.new(f"point{k}", "POINT")
            ld.color = (1.0, 1.0, 1.0)
            i = light["intensity"]
            m = max(i)
            # Blender point light of power P has radiant intensity P / (4 pi) W/sr.
            ld.energy = 4 * math.pi * m
            ld.color = tuple(x / m for x in i) if m > 0 else (0.0, 0.0, 0.0)
            ld.shadow_soft_size = 0.0
            if hasattr(ld, "use_soft_falloff"):
                ld.use_soft_falloff = False
            lo = bpy.data.objects.new(f"point{k}", ld)
            lo.location = light["position"]
            sc.collection.objects.link(lo)
    world = bpy.data.worlds.new("world")
    sc.world = world
    world.use_nodes = True
    nt = world.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputWorld")
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = 1.0
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    envs = [l for l in scene["lights"] if l["kind"] == "envmap"]
    if len(envs) > 1:
        raise Unsupported("more than one envmap")
    if envs:
        _envmap_nodes(bpy, nt, envs[0], bg, images)
    else:
        bg.inputs["Color"].default_value = (*scene["background"], 1.0)
    return sc


def _bmat(m):
    from mathutils import Matrix

    return Matrix([list(map(float, r)) for r in m])


def _add_shape(bpy, sc, k, shape, images):
    kind = shape["kind"]
    if kind == "obj":
        mesh = read_obj(shape["filename"])
    elif kind == "ply":
        mesh = read_ply(shape["filename"])
    elif kind == "sphere":
        mesh = sphere_mesh(shape["center"], shape["radius"])
    else:
        mesh = rectangle_mesh()
    tris = mesh["tris"]
    if shape["flip_normals"]:
        tris = [[a, c, b] for a, b, c in tris]
    normals = mesh["normals"]
    if shape["face_normals"]:
        normals = None
    elif normals is None and kind in ("obj", "ply"):
        normals = smooth_normals(mesh)
    if normals is not None and shape["flip_normals"]:
        normals = [[-x for x in n] for n in normals]

    me = bpy.data.meshes.new(f"shape{k}")
    me.from_pydata(mesh["positions"], [], tris)
    me.update()
    if mesh["uvs"] is not None:
        uvl = me.uv_layers.new(name="UVMap")
        flat = []
        for poly in me.polygons:
            for li in poly.loop_indices:
                flat.extend(mesh["uvs"][me.loops[li].vertex_index])
        uvl.data.foreach_set("uv", flat)
    if normals is not None:
        me.shade_smooth()
        me.normals_split_custom_set_from_vertices(normals)
    else:
        me.shade_flat()
    ob = bpy.data.objects.new(f"shape{k}", me)
    ob.matrix_world = _bmat(shape["to_world"])
    sc.collection.objects.link(ob)
    mat = _material(bpy, f"mat{k}", shape, images, has_uv=mesh["uvs"] is not None)
    me.materials.append(mat)


def _image(bpy, images, tex):
    key = (tex["filename"], tex.get("raw", False))
    if key not in images:
        img = bpy.data.images.load(tex["filename"], check_existing=False)
        is_float = img.is_float or tex["filename"].lower().endswith((".exr", ".hdr"))
        if is_float:
            img.colorspace_settings.name = "Linear Rec.709"
        else:
            # Cycles keeps 8-bit sRGB images as bytes and decodes after interpolating, so texel
            # blends would happen in sRGB. Mitsuba and torrey decode first and interpolate linear
            # values: hand Cycles a float image with the decoded texels instead.
            import numpy as np

            img.colorspace_settings.name = "Non-Color"
            w, h = img.size
            px = np.empty(w * h * img.channels, dtype=np.float32)
            img.pixels.foreach_get(px)
            px = px.reshape(h, w, img.channels)
            rgba = np.ones((h, w, 4), dtype=np.float32)
            if img.channels >= 3:
                rgba[..., :3] = px[..., :3]
            else:
                rgba[..., :3] = px[..., :1]
            if not tex.get("raw"):
                c = rgba[..., :3]
                rgba[..., :3] = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
            lin = bpy.data.images.new(os.path.basename(tex["filename"]), w, h, alpha=True, float_buffer=True)
            lin.colorspace_settings.name = "Non-Color" if tex.get("raw") else "Linear Rec.709"
            lin.pixels.foreach_set(rgba.ravel())
            lin.pack()
            img = lin
        images[key] = img
    return images[key]


def _math(nt, op, a, b=None, vector=False):
    n = nt.nodes.new("ShaderNodeVectorMath" if vector else "ShaderNodeMath")
    n.operation = op
    for i, v in enumerate((a, b)):
        if v is None:
            continue
        if isinstance(v, (int, float)) and not vector:
            n.inputs[i].default_value = v
        elif isinstance(v, (list, tuple)):
            n.inputs[i].default_value = v
        else:
            nt.links.new(v, n.inputs[i])
    return n.outputs["Vector" if vector and op not in ("DOT_PRODUCT", "LENGTH") else "Value"]


def _uv_socket(nt, tex):
    """Mitsuba uv (stored in the mesh) -> scale/offset -> Blender image coords (v from bottom)."""
    uvn = nt.nodes.new("ShaderNodeUVMap")
    uvn.uv_map = "UVMap"
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    nt.links.new(uvn.outputs["UV"], sep.inputs[0])
    u = _math(nt, "MULTIPLY_ADD", sep.outputs["X"], tex["uv_scale"][0])
    u.node.inputs[2].default_value = tex["uv_offset"][0]
    v = _math(nt, "MULTIPLY_ADD", sep.outputs["Y"], tex["uv_scale"][1])
    v.node.inputs[2].default_value = tex["uv_offset"][1]
    return u, v


def _texture_color(bpy, nt, tex, images):
    u, v = _uv_socket(nt, tex)
    if tex["kind"] == "checkerboard":
        fu, fv = _math(nt, "FLOOR", u), _math(nt, "FLOOR", v)
        parity = _math(nt, "FLOORED_MODULO", _math(nt, "ADD", fu, fv), 2.0)
        mix = nt.nodes.new("ShaderNodeMix")
        mix.data_type = "RGBA"
        nt.links.new(parity, mix.inputs["Factor"])
        mix.inputs[6].default_value = (*tex["color0"], 1.0)
        mix.inputs[7].default_value = (*tex["color1"], 1.0)
        return mix.outputs[2]
    comb = nt.nodes.new("ShaderNodeCombineXYZ")
    nt.links.new(u, comb.inputs["X"])
    nt.links.new(_math(nt, "SUBTRACT", 1.0, v), comb.inputs["Y"])
    node = nt.nodes.new("ShaderNodeTexImage")
    node.image = _image(bpy, images, tex)
    node.interpolation = "Closest" if tex["filter"] == "nearest" else "Linear"
    node.extension = {"repeat": "REPEAT", "mirror": "MIRROR", "clamp": "EXTEND"}[tex["wrap"]]
    nt.links.new(comb.outputs[0], node.inputs["Vector"])
    return node.outputs["Color"]


def _color_socket(bpy, nt, param, images, has_uv, where):
    if "constant" in param:
        return None, param["constant"]
    if not has_uv:
        raise Unsupported(f"{where}: textured but the mesh has no uvs")
    return _texture_color(bpy, nt, param["texture"], images), None


def _material(bpy, name, shape, images, has_uv):
    b = shape["bsdf"]
    mat = bpy.data.materials.new(name)
    if hasattr(mat, "use_nodes") and not mat.use_nodes:
        mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    out.target = "CYCLES"
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    normal = geo.outputs["Normal"]
    if b.get("normal_map") is not None:
        if not has_uv:
            raise Unsupported(f"{shape['where']}: normal map but the mesh has no uvs")
        # Mitsuba's frame: s = dp/du made orthogonal to n, t = cross(n, s); n' = frame * (2 c - 1).
        c = _texture_color(bpy, nt, b["normal_map"], images)
        tng = nt.nodes.new("ShaderNodeTangent")
        tng.direction_type = "UV_MAP"
        tng.uv_map = "UVMap"
        n = geo.outputs["Normal"]
        tan = tng.outputs["Tangent"]
        dot = _math(nt, "DOT_PRODUCT", tan, n, vector=True)
        proj = nt.nodes.new("ShaderNodeVectorMath")
        proj.operation = "SCALE"
        nt.links.new(n, proj.inputs[0])
        nt.links.new(dot, proj.inputs["Scale"])
        s = _math(nt, "NORMALIZE", _math(nt, "SUBTRACT", tan, proj.outputs["Vector"], vector=True), vector=True)
        t = _math(nt, "CROSS_PRODUCT", n, s, vector=True)
        lin = _math(nt, "MULTIPLY_ADD", c, (2.0, 2.0, 2.0), vector=True)
        lin.node.inputs[2].default_value = (-1.0, -1.0, -1.0)
        sep = nt.nodes.new("ShaderNodeSeparateXYZ")
        nt.links.new(lin, sep.inputs[0])
        acc = None
        for axis, comp in ((s, "X"), (t, "Y"), (n, "Z")):
            sc_ = nt.nodes.new("ShaderNodeVectorMath")
            sc_.operation = "SCALE"
            nt.links.new(axis, sc_.inputs[0])
            nt.links.new(sep.outputs[comp], sc_.inputs["Scale"])
            acc = sc_.outputs["Vector"] if acc is None else _math(nt, "ADD", acc, sc_.outputs["Vector"], vector=True)
        normal = _math(nt, "NORMALIZE", acc, vector=True)
    sock, const = _color_socket(bpy, nt, b["reflectance"], images, has_uv, shape["where"])
    if b["kind"] == "diffuse":
        bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
        bsdf.inputs["Roughness"].default_value = 0.0
    elif b["kind"] == "mirror":
        # torrey mirror: F0 + (1 - F0) (1 - cos)^5 with cos = |n . wi|; Glossy at roughness 0 has no Fresnel.
        bsdf = nt.nodes.new("ShaderNodeBsdfGlossy")
        bsdf.distribution = "GGX"
        bsdf.inputs["Roughness"].default_value = 0.0
        cosv = _math(nt, "ABSOLUTE", _math(nt, "DOT_PRODUCT", normal, geo.outputs["Incoming"], vector=True))
        w = _math(nt, "POWER", _math(nt, "SUBTRACT", 1.0, cosv), 5.0)
        mix = nt.nodes.new("ShaderNodeMix")
        mix.data_type = "RGBA"
        mix.blend_type = "MIX"
        nt.links.new(w, mix.inputs["Factor"])
        if sock is not None:
            nt.links.new(sock, mix.inputs[6])
        else:
            mix.inputs[6].default_value = (*const, 1.0)
        mix.inputs[7].default_value = (1.0, 1.0, 1.0, 1.0)
        sock, const = mix.outputs[2], None
    else:
        raise Unsupported(f"{shape['where']}: bsdf '{b['kind']}'")
    if sock is not None:
        nt.links.new(sock, bsdf.inputs["Color"])
    else:
        bsdf.inputs["Color"].default_value = (*const, 1.0)
    if normal is not geo.outputs["Normal"]:
        nt.links.new(normal, bsdf.inputs["Normal"])
    surface = bsdf.outputs["BSDF"]
    if shape["emitter"] is not None:
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = (*shape["emitter"], 1.0)
        em.inputs["Strength"].default_value = 1.0
        front = nt.nodes.new("ShaderNodeMixShader")  # back faces emit nothing
        nt.links.new(geo.outputs["Backfacing"], front.inputs["Fac"])
        nt.links.new(em.outputs["Emission"], front.inputs[1])
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(surface, add.inputs[0])
        nt.links.new(front.outputs["Shader"], add.inputs[1])
        surface = add.outputs["Shader"]
        mat.cycles.emission_sampling = "FRONT"
    else:
        mat.cycles.emission_sampling = "NONE"
    nt.links.new(surface, out.inputs["Surface"])
    return mat


def _envmap_nodes(bpy, nt, env, bg, images):
    """World colour = scale * max(0, image(u, v)) with Mitsuba's lat-long mapping of toWorld^-1 d."""
    tc = nt.nodes.new("ShaderNodeTexCoord")
    d = _math(nt, "NORMALIZE", tc.outputs["Generated"], vector=True)
    # local = R^T d (toWorld is a rotation): rows of R^T are columns of R
    R = env["to_world"]
    loc = [_math(nt, "DOT_PRODUCT", d, (R[0][c], R[1][c], R[2][c]), vector=True) for c in range(3)]
    u = _math(nt, "DIVIDE", _math(nt, "ARCTAN2", loc[0], _math(nt, "MULTIPLY", loc[2], -1.0)), 2 * math.pi)
    u = _math(nt, "FLOORED_MODULO", u, 1.0)
    v = _math(nt, "DIVIDE", _math(nt, "ARCCOSINE", _math(nt, "MINIMUM", _math(nt, "MAXIMUM", loc[1], -1.0), 1.0)),
              math.pi)
    comb = nt.nodes.new("ShaderNodeCombineXYZ")
    nt.links.new(u, comb.inputs["X"])
    nt.links.new(_math(nt, "SUBTRACT", 1.0, v), comb.inputs["Y"])
    node = nt.nodes.new("ShaderNodeTexImage")
    node.image = _image(bpy, images, {"filename": env["filename"], "raw": False})
    node.interpolation = "Linear"
    node.extension = "REPEAT"
    nt.links.new(comb.outputs[0], node.inputs["Vector"])
    col = _math(nt, "MAXIMUM", node.outputs["Color"], (0.0, 0.0, 0.0), vector=True)
    col = _math(nt, "SCALE", col, None, vector=True)
    col.node.inputs["Scale"].default_value = env["scale"]
    nt.links.new(col, bg.inputs["Color"])


def render(scene_path, out_path, width=None, height=None, spp=None, threads=2, seed=0, max_depth=None):
    """Builds the scene in Blender and renders it to out_path (EXR). Returns (seconds, parsed scene)."""
    import bpy

    scene = read_scene(scene_path)
    sc = build_blender(scene, width, height, spp, threads, seed, max_depth)
    sc.render.filepath = os.path.abspath(out_path)
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    return time.time() - t0, scene


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("-o", "--out", help="output EXR (default: <scene>_blender.exr beside the scene)")
    ap.add_argument("--width", type=int)
    ap.add_argument("--height", type=int)
    ap.add_argument("--spp", type=int)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-depth", type=int, help="override the scene's max_depth (Mitsuba semantics)")
    ap.add_argument("--check", action="store_true", help="only parse and report whether it is expressible")
    args = ap.parse_args(argv)
    try:
        if args.check:
            scene = read_scene(args.scene)
            for w in scene["warnings"]:
                print(f"warning: {w}", file=sys.stderr)
            print(f"{args.scene}: expressible ({len(scene['shapes'])} shapes, {len(scene['lights'])} lights)")
            return 0
        out = args.out or os.path.splitext(args.scene)[0] + "_blender.exr"
        secs, scene = render(args.scene, out, args.width, args.height, args.spp, args.threads, args.seed,
                             args.max_depth)
        print(f"wrote {out} in {secs:.1f} s")
        return 0
    except Unsupported as e:
        print(f"unsupported: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
