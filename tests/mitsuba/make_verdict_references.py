#!/usr/bin/env python3
"""Mitsuba 3 references for the statistical verdict (tests/mitsuba_verdict.rs).

    tests/mitsuba/.venv/bin/python tests/mitsuba/make_verdict_references.py [--only a,b] [--spp N]

Renders every scene tests/scenes/mitsuba/*.xml as Mitsuba 3.9.1 reads it (no conversion: the scenes
are Mitsuba 3 syntax and wrap their integrator in `moment`), and writes, as Mitsuba's own
src/render/tests/test_renders.py does:
  tests/references/verdict/<name>.exr      the image, linear sRGB
  tests/references/verdict/<name>_var.exr  the per-sample variance: the moment integrator's second
                                           moment minus the squared mean, computed in XYZ and
                                           written through Mitsuba's XYZ -> sRGB matrix (the test
                                           converts it back with sRGB -> XYZ, recovering the XYZ
                                           variance exactly)
and tests/references/verdict/manifest.json (sizes, spp, the test's spp, render times).

Scenes whose film splats with a filter that has negative lobes (mitchell, catmullrom, lanczos) get
another variance image: the moment integrator's second moment minus the squared mean is the
filter-weighted spread of the samples, which a negative lobe makes too small, or negative, next to
a high-contrast edge (a pixel whose negative lobe sees the bright side: -n (1 + n) (b - a)^2, with n
the lobe's weight), so that Mitsuba's own renders would fail the test there. For these scenes
<name>_var.exr is the spread of VARIANCE_RENDERS independent Mitsuba renders at the test's spp
(seeds 1000...), times that spp: the per-sample variance the verdict's z-test divides by the spp.
Also (re)writes the scenes' own textures tests/scenes/mitsuba/textures/gradient_sky.exr,
sun_sky.exr, emission_pattern.exr (radiance) and spot_pattern.png, the sdfgrid scene's grids
tests/scenes/mitsuba/volumes/*.vol (sdf_volumes.py) and the grid medium cloud.vol.
Variant llvm_ad_rgb (scalar_rgb as fallback). Seed 0, as Mitsuba's reference renders.
"""
import argparse
import glob
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SCENES = os.path.join(REPO, "tests", "scenes", "mitsuba")
OUT = os.path.join(REPO, "tests", "references", "verdict")
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402
import mitsuba as mi  # noqa: E402

# The reference's own noise is not part of the test (only its variance image is), so the reference
# gets many more samples than the test's 2,000,000 / pixels: REF_SAMPLES / pixels per pixel.
REF_SAMPLES = 48_000_000
# Independent renders at the test's spp whose spread is the variance image of scenes with filters
# that have negative lobes (see the docstring); 64 give the variance to about 18%.
VARIANCE_RENDERS = 64


def pick_variant():
    for v in ("llvm_ad_rgb", "scalar_rgb"):
        try:
            mi.set_variant(v)
            return v
        except Exception as e:  # noqa: BLE001
            print("variant %s unavailable: %s" % (v, e), file=sys.stderr)
    raise SystemExit("no usable Mitsuba variant")


def gradient_sky(path, width=64, height=32):
    """A smooth sky of our own: blue zenith, bright warm horizon band, a broad warm lobe (no sharp
    sun, so that the verdict's per-pixel test is about the integrator, not about one texel)."""
    from exr_zip import write_exr_zip
    v, u = np.meshgrid((np.arange(height) + 0.5) / height, (np.arange(width) + 0.5) / width,
                       indexing="ij")
    theta, phi = np.pi * v, 2 * np.pi * u
    up = np.cos(theta)
    d = np.stack([np.sin(theta) * np.cos(phi), up, np.sin(theta) * np.sin(phi)], -1)
    lobe_dir = np.array([0.6, 0.5, 0.3]) / np.linalg.norm([0.6, 0.5, 0.3])
    lobe = np.exp(6.0 * (d @ lobe_dir - 1.0))
    sky = np.where(up[..., None] > 0,
                   np.array([0.35, 0.55, 1.0]) * (0.4 + 0.6 * up[..., None])
                   + np.array([1.0, 0.85, 0.6]) * (1 - up[..., None]) ** 4,
                   np.array([0.25, 0.22, 0.2]) * (1 + up[..., None]))
    img = sky + np.array([3.0, 2.4, 1.6]) * lobe[..., None]
    os.makedirs(os.path.dirname(path), exist_ok=True)
    write_exr_zip(path, img.astype(np.float32))


def spot_pattern(path, width=24, height=16):
    """An asymmetric 8-bit sRGB pattern for the projected spot texture: four quadrants of
    different colours and a white bar along the top rows, so that a flipped or transposed
    projection shows."""
    img = np.zeros((height, width, 3), np.uint8)
    top, left = np.arange(height)[:, None] < height // 2, np.arange(width)[None, :] < width // 2
    img[top & left] = (230, 60, 40)
    img[top & ~left] = (60, 200, 70)
    img[~top & left] = (50, 90, 230)
    img[~top & ~left] = (200, 200, 60)
    img[:2, :] = 255
    os.makedirs(os.path.dirname(path), exist_ok=True)
    mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(path)


def sun_sky(path, width=32, height=16):
    """A low-resolution sky with a small sun well above the horizon: a 2 x 2 block of bright
    texels (rows 3-4 of 16, about 40-50 degrees of elevation) over a dim gradient. Where a
    renderer places the texel rows decides how high the sun stands, so this sky tells texel
    placements apart (envmap_sun.xml)."""
    from exr_zip import write_exr_zip
    rows = np.arange(height)[:, None, None] / (height - 1)
    up = np.cos(np.pi * rows)
    sky = np.where(up > 0, np.array([0.2, 0.3, 0.6]) * (0.3 + 0.7 * up),
                   np.array([0.15, 0.12, 0.1]))
    img = np.broadcast_to(sky, (height, width, 3)).copy()
    img[3:5, 5:7] = [60.0, 50.0, 35.0]
    os.makedirs(os.path.dirname(path), exist_ok=True)
    write_exr_zip(path, img.astype(np.float32))


def emission_pattern(path, width=16, height=8):
    """A small radiance texture for textured area emitters (area_textured.xml): dim coloured
    stripes, one bright 2 x 1 spot and black texels, so that sampling by the texture matters and
    a texture read upside down or mirrored shows."""
    from exr_zip import write_exr_zip
    img = np.zeros((height, width, 3), np.float32)
    for x in range(width):
        img[:, x] = [0.5 + 0.5 * (x % 3 == 0), 0.3 + 0.4 * (x % 4 == 1), 0.4 + 0.6 * (x % 5 == 2)]
    img[:, 6:8] = 0.0
    img[2, 10:12] = [30.0, 24.0, 12.0]
    img[6, 1] = [0.0, 8.0, 16.0]
    os.makedirs(os.path.dirname(path), exist_ok=True)
    write_exr_zip(path, img)


def cloud_volume(path, n=24):
    """A sparse cloud of our own for the grid-medium scene: a few soft blobs (about 10% of the
    voxels above 1% of the peak) in an n^3 grid, one channel, Mitsuba's .vol layout
    (x fastest; bounding box the unit cube)."""
    import struct
    z, y, x = np.meshgrid(*(3 * [(np.arange(n) + 0.5) / n]), indexing="ij")
    density = np.zeros((n, n, n))
    for cx, cy, cz, r, a in [(0.35, 0.4, 0.45, 0.18, 1.0), (0.62, 0.55, 0.5, 0.14, 0.8),
                             (0.5, 0.3, 0.65, 0.1, 1.2), (0.45, 0.68, 0.35, 0.09, 0.6)]:
        d2 = ((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / r ** 2
        density += a * np.exp(-2.0 * d2) * (d2 < 2.5)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]) + struct.pack("<iiiii", 1, n, n, n, 1))
        f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(density.astype("<f4").tobytes())


def render(path, spp):
    scene = mi.load_file(path, spp=spp)
    t0 = time.time()
    scene.integrator().render(scene, seed=0, spp=spp, develop=False)
    seconds = time.time() - t0
    bmp = scene.sensors()[0].film().bitmap(raw=False)
    parts = dict(bmp.split())
    keys = [k for k in parts if k != "<root>"]
    if len(keys) != 2:
        raise RuntimeError("%s: expected the moment integrator's two AOVs, found %s" % (path, keys))
    m1 = np.array(parts[keys[0]], copy=True)
    m2 = np.array(parts[keys[1]], copy=True)
    var_xyz = m2 - m1 * m1

    def to_rgb(a):
        b = mi.Bitmap(np.ascontiguousarray(a, dtype=np.float32), mi.Bitmap.PixelFormat.XYZ)
        return np.array(b.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False))

    return to_rgb(m1), to_rgb(var_xyz), seconds


def negative_lobed_filter(path):
    """Whether the scene's film uses a reconstruction filter with negative lobes."""
    import re
    with open(path) as f:
        return re.search(r'<rfilter\s+type="(mitchell|catmullrom|lanczos)"', f.read()) is not None


def spread_variance(path, spp, renders):
    """Per-sample variance from the spread of independent renders at `spp`, in sRGB (the spread of
    the XYZ images brought through XYZ -> sRGB, as the moment variance is stored)."""
    images = []
    for k in range(renders):
        scene = mi.load_file(path, spp=spp)
        scene.integrator().render(scene, seed=1000 + k, spp=spp, develop=False)
        bmp = scene.sensors()[0].film().bitmap(raw=False)
        parts = dict(bmp.split())
        keys = [key for key in parts if key != "<root>"]
        images.append(np.array(parts[keys[0]], copy=True))
    var_xyz = np.stack(images).astype(np.float64).var(axis=0, ddof=1) * spp
    b = mi.Bitmap(np.ascontiguousarray(var_xyz, dtype=np.float32), mi.Bitmap.PixelFormat.XYZ)
    return np.array(b.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", help="comma-separated scene names")
    ap.add_argument("--samples", type=int, default=REF_SAMPLES, help="total samples per reference")
    a = ap.parse_args()
    variant = pick_variant()
    from exr_zip import write_exr_zip
    gradient_sky(os.path.join(SCENES, "textures", "gradient_sky.exr"))
    spot_pattern(os.path.join(SCENES, "textures", "spot_pattern.png"))
    sun_sky(os.path.join(SCENES, "textures", "sun_sky.exr"))
    emission_pattern(os.path.join(SCENES, "textures", "emission_pattern.exr"))
    import sdf_volumes
    sdf_volumes.write_all(os.path.join(SCENES, "volumes"))
    cloud_volume(os.path.join(SCENES, "textures", "cloud.vol"))
    os.makedirs(OUT, exist_ok=True)
    manifest_path = os.path.join(OUT, "manifest.json")
    manifest = {}
    if os.path.exists(manifest_path):
        with open(manifest_path) as f:
            manifest = json.load(f).get("references", {})
    only = set(a.only.split(",")) if a.only else None
    for path in sorted(glob.glob(os.path.join(SCENES, "*.xml"))):
        name = os.path.basename(path)[:-4]
        if only and name not in only:
            continue
        probe = mi.load_file(path)
        # The rendered pixels: the crop window's (the whole film without one).
        w, h = probe.sensors()[0].film().crop_size()
        pixels = int(w) * int(h)
        spp = a.samples // pixels
        img, var, seconds = render(path, spp)
        variance_from = "moment"
        if negative_lobed_filter(path):
            var = spread_variance(path, 2_000_000 // pixels, VARIANCE_RENDERS)
            variance_from = "spread of %d renders" % VARIANCE_RENDERS
        write_exr_zip(os.path.join(OUT, name + ".exr"), img)
        write_exr_zip(os.path.join(OUT, name + "_var.exr"), var)
        manifest[name] = {"scene": os.path.relpath(path, REPO), "width": int(w), "height": int(h),
                          "spp": spp, "test_spp": 2_000_000 // pixels, "variant": variant,
                          "variance": variance_from,
                          "mitsuba_version": mi.__version__, "render_seconds": round(seconds, 1),
                          "mean_rgb": [round(float(x), 6) for x in img.mean(axis=(0, 1))]}
        print("%-32s %3dx%-3d %6d spp  %6.1fs  mean %s" % (
            name, w, h, spp, seconds, manifest[name]["mean_rgb"]), flush=True)
    with open(manifest_path, "w") as f:
        json.dump({"generator": "tests/mitsuba/make_verdict_references.py",
                   "notes": "Mitsuba 3 renders of tests/scenes/mitsuba/*.xml with the moment "
                            "integrator; <name>_var.exr is the per-sample variance (XYZ variance "
                            "written through XYZ->sRGB, as Mitsuba's test_renders.py stores it).",
                   "references": dict(sorted(manifest.items()))}, f, indent=2)
        f.write("\n")


if __name__ == "__main__":
    main()
