#!/usr/bin/env python3
"""Mitsuba 3 references for the BSDF verdict test (tests/mitsuba_bsdfs.rs).

    export DRJIT_LIBLLVM_PATH=...   (see tests/mitsuba/README.md)
    tests/mitsuba/.venv/bin/python tests/mitsuba/make_bsdf_references.py [--only a,b] [--sky]
        [--textures]

Renders every tests/scenes/mitsuba_bsdfs/*.xml with Mitsuba's `moment` integrator wrapping the
scene's `path` integrator (variant llvm_ad_rgb), seed 0, at REF_FACTOR times the test's sample
count (the test renders spp = 2,000,000 / pixels, as Mitsuba's test_renders.py), and writes
tests/references/verdict_bsdfs/<name>.exr (the mean, linear RGB) and <name>_var.exr (the
per-sample variance in CIE XYZ, which is what `moment` records: second moment minus squared
first moment of the XYZ radiance) plus manifest.json. The reference is
rendered with more samples than the test so that its own noise stays small against the test's.

--sky regenerates tests/scenes/mitsuba_bsdfs/soft_sky.exr, the scenes' environment map: a
256x8 lat-long sky that varies with the azimuth only (a blue gradient and a bright band 0.25 rad
wide, peak 12, towards azimuth 2.2): soft, so that caustics through glass stay within what a
2-million-sample render resolves, and the same under torrey's and Mitsuba's row placement.

--textures regenerates the small 8-bit maps of the bumpmap and normalmap scenes (read raw):
bump_height.png, a 32x16 grey height field 0.5 + 0.4 sin(8πu) sin(6πv), and normal_map.png,
a 32x16 tangent-space normal map (x = 0.45 sin(6πu), y = 0.45 cos(4πv), z = 1, normalised,
stored as (n + 1) / 2).
"""
import argparse
import glob
import json
import math
import os
import time

import numpy as np
import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SCENES = os.path.join(REPO, "tests", "scenes", "mitsuba_bsdfs")
OUT = os.path.join(REPO, "tests", "references", "verdict_bsdfs")
REF_FACTOR = 8


def make_sky(path):
    # Radiance depends on the azimuth only: torrey and Mitsuba place lat-long rows half a texel
    # apart (crates/light/src/envmap/mod.rs), which a sky varying with elevation would show.
    w, h = 256, 8
    img = np.zeros((h, w, 3), dtype=np.float32)
    for j in range(w):
        phi = 2 * math.pi * (j + 0.5) / w
        c = np.array([0.45, 0.6, 1.0]) * (0.7 + 0.3 * math.cos(phi))
        dphi = math.remainder(phi - 2.2, 2 * math.pi)
        c = c + np.array([1.0, 0.85, 0.65]) * 12.0 * math.exp(-0.5 * (dphi / 0.25) ** 2)
        img[:, j] = c
    mi.Bitmap(img).write(path)


def make_textures(folder):
    w, h = 32, 16
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    uu, vv = np.meshgrid(u, v)
    height = 0.5 + 0.4 * np.sin(8 * math.pi * uu) * np.sin(6 * math.pi * vv)
    img = np.round(height * 255).astype(np.uint8)[:, :, None]
    mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.Y).write(
        os.path.join(folder, "bump_height.png"))
    n = np.stack([0.45 * np.sin(6 * math.pi * uu), 0.45 * np.cos(4 * math.pi * vv),
                  np.ones_like(uu)], axis=2)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    img = np.round((n + 1) / 2 * 255).astype(np.uint8)
    mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(
        os.path.join(folder, "normal_map.png"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="")
    ap.add_argument("--sky", action="store_true")
    ap.add_argument("--textures", action="store_true")
    args = ap.parse_args()
    mi.set_variant("llvm_ad_rgb")
    if args.sky:
        make_sky(os.path.join(SCENES, "soft_sky.exr"))
    if args.textures:
        make_textures(SCENES)
    os.makedirs(OUT, exist_ok=True)
    manifest_path = os.path.join(OUT, "manifest.json")
    manifest = json.load(open(manifest_path)) if os.path.exists(manifest_path) else {}
    only = set(filter(None, args.only.split(",")))
    for path in sorted(glob.glob(os.path.join(SCENES, "*.xml"))):
        name = os.path.splitext(os.path.basename(path))[0]
        if only and name not in only:
            continue
        scene = mi.load_file(path)
        film = scene.sensors()[0].film()
        w, h = film.crop_size()
        spp = 2_000_000 // (w * h)
        inner = scene.integrator()
        max_depth = mi.traverse(inner).get("max_depth", None) if False else None
        props = {"type": "moment", "nested": inner}
        integrator = mi.load_dict(props)
        t = time.time()
        img = np.array(mi.render(scene, integrator=integrator, spp=spp * REF_FACTOR, seed=0))
        dt = time.time() - t
        # moment: the image (RGB) then its AOVs: the first moment of the nested integrator's
        # radiance in CIE XYZ ("nested.X", ...) and the second ("m2_nested.X", ...).
        names = integrator.aov_names()
        ch = {n: i for i, n in enumerate(names)}
        nested = img.shape[2] - len(names)
        mean = img[:, :, 0:3]
        m1 = np.stack([img[:, :, nested + ch[f"nested.{c}"]] for c in "XYZ"], axis=2)
        m2 = np.stack([img[:, :, nested + ch[f"m2_nested.{c}"]] for c in "XYZ"], axis=2)
        var = np.maximum(m2 - m1 * m1, 0.0)
        xyz = mean @ np.array([[0.412453, 0.357580, 0.180423],
                               [0.212671, 0.715160, 0.072169],
                               [0.019334, 0.119193, 0.950227]]).T
        assert np.allclose(xyz, m1, rtol=1e-3, atol=1e-4), "moment AOVs are not XYZ"
        mi.Bitmap(mean.astype(np.float32)).write(os.path.join(OUT, f"{name}.exr"))
        mi.Bitmap(var.astype(np.float32)).write(os.path.join(OUT, f"{name}_var.exr"))
        manifest[name] = {"scene": os.path.relpath(path, REPO), "width": w, "height": h,
                          "test_spp": spp, "reference_spp": spp * REF_FACTOR, "seed": 0,
                          "variant": mi.variant(), "mitsuba": mi.__version__,
                          "seconds": round(dt, 2), "mean": [float(x) for x in mean.mean(axis=(0, 1))]}
        print(f"{name}: {w}x{h} {spp * REF_FACTOR} spp {dt:.1f} s mean {mean.mean(axis=(0, 1))} "
              f"aovs {names}", flush=True)
    json.dump(manifest, open(manifest_path, "w"), indent=1, sort_keys=True)


if __name__ == "__main__":
    main()
