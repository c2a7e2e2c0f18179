#!/usr/bin/env python3
"""Regenerates the Mitsuba 3 reference renders of the project's own scenes.

One command (after `source tests/mitsuba/setup.sh`):
    tests/mitsuba/.venv/bin/python tests/mitsuba/make_references.py            # committed refs
    tests/mitsuba/.venv/bin/python tests/mitsuba/make_references.py --shared   # lead's checks
    ... make_references.py --only cbox,materials                              # a subset
    ... make_references.py --shared-env          # tests/scenes/shared_env_*.xml (shared HDRIs)
Default mode writes tests/references/mitsuba/<name>.exr (float32 RGB, ZIP) and manifest.json.
--shared renders the shared torrey scenes (../shared/scenes/torrey or $TORREY_SHARED) into
out/mitsuba_shared/<dir>__<name>.exr with a <..>.json beside each (never committed).
--shared-env renders the test-only scenes tests/scenes/shared_env_*.xml (the shared HDRIs in
../shared/envmaps) into out/mitsuba_shared_env/<name>.exr + <name>.json (never committed);
default 128 px wide, 4096 spp.

Each image is rendered as two halves with different seeds; their difference gives a noise
estimate (`noise_rel`: mean |a - b| / 2 / mean(image), i.e. roughly the relative standard error
of the average) stored in the manifest. Variant llvm_ad_rgb (scalar_rgb as fallback; the Python
BSDF plugins need a JIT variant to be fast).
"""
import argparse
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402
import mitsuba as mi  # noqa: E402

# name: (scene relative to the repo root, width, height, spp, max_depth override or None)
REFERENCES = {
    "cbox": ("scenes/cbox.xml", 64, 64, 16384, None),
    "cbox_depth2": ("scenes/cbox.xml", 64, 64, 16384, 2),
    "cbox_spheres": ("scenes/cbox_spheres.xml", 64, 64, 16384, None),
    "materials": ("scenes/materials.xml", 96, 66, 8192, None),
    "textured_mesh": ("scenes/textured_mesh.xml", 96, 72, 4096, None),
    "envmap_sky": ("scenes/envmap_sky.xml", 96, 60, 16384, None),
    "envmap_rotated": ("scenes/envmap_rotated.xml", 96, 60, 16384, None),
    "glass": ("scenes/glass.xml", 96, 54, 16384, None),
}

SHARED_SCENES = [
    "cbox/cbox.xml", "cbox/cbox_point_light.xml", "cbox/cbox_point_light_spheres.xml",
    "cbox/cbox_area_light_spheres.xml", "cbox/cbox_area_light_spheres_phong.xml",
    "cbox/cbox_area_light_spheres_blinn.xml", "cbox/cbox_area_light_spheres_blinn_microfacet.xml",
    "hw1_spheres/scene0.xml", "hw1_spheres/scene0_spherical_light.xml", "hw1_spheres/scene1.xml",
    "hw1_spheres/scene1_spherical_light.xml", "hw1_spheres/scene1_spherical_light_phong.xml",
    "hw1_spheres/scene1_spherical_light_blinn.xml", "hw1_spheres/scene2.xml",
    "hw1_spheres/scene3.xml", "hw1_spheres/scene4.xml",
    "hw2_triangles/single_triangle.xml", "hw2_triangles/tetrahedron.xml",
    "aabb_test/aabb_test.xml",
    "texture_test/texture.xml", "texture_test/texture_scaled.xml",
    "teapot/teapot_constant.xml", "teapot/teapot_textured.xml", "teapot/teapot_textured_phong.xml",
    "teapot/teapot_textured_blinn.xml", "teapot/teapot_textured_blinn_microfacet.xml",
    "teapot/teapot_textured_phong_grazing_view.xml", "teapot/teapot_textured_blinn_grazing_view.xml",
    "teapot/teapot_textured_blinn_microfacet_grazing_view.xml",
    "veach_mi/mi.xml", "head/head.xml", "head/head_spherical_light.xml",
]


def pick_variant():
    for v in ("llvm_ad_rgb", "scalar_rgb"):
        try:
            mi.set_variant(v)
            return v
        except Exception as e:  # noqa: BLE001 (missing libLLVM, say)
            print("variant %s unavailable: %s" % (v, e), file=sys.stderr)
    raise SystemExit("no usable Mitsuba variant")


def render(scene_path, width=None, height=None, spp=None, max_depth=None, out_xml=None):
    from torrey_to_mitsuba import convert
    text, info = convert(scene_path, width, height, spp, max_depth)
    xml_path = out_xml or os.path.join(REPO, "out", "mitsuba_tmp.xml")
    os.makedirs(os.path.dirname(xml_path), exist_ok=True)
    with open(xml_path, "w") as f:
        f.write(text)
    scene = mi.load_file(xml_path)
    half = max(1, info["spp"] // 2)
    t0 = time.time()
    a = np.array(mi.render(scene, seed=0, spp=half))[..., :3]
    b = np.array(mi.render(scene, seed=1, spp=half))[..., :3]
    seconds = time.time() - t0
    img = 0.5 * (a + b)
    noise = float(np.mean(np.abs(a - b)) / 2 / max(float(np.mean(img)), 1e-12))
    info.update(spp=2 * half, render_seconds=round(seconds, 2), noise_rel=round(noise, 5),
                mean_rgb=[round(float(x), 6) for x in img.mean(axis=(0, 1))])
    return img, info


def main():
    ap = argparse.ArgumentParser(description="Mitsuba 3 references for torrey")
    ap.add_argument("--shared", action="store_true", help="render the shared torrey scenes instead")
    ap.add_argument("--only", help="comma-separated names (or shared paths) to render")
    ap.add_argument("--spp", type=int, help="override spp")
    ap.add_argument("--shared-env", action="store_true",
                    help="render tests/scenes/shared_env_*.xml into out/mitsuba_shared_env/")
    ap.add_argument("--width", type=int, help="--shared/--shared-env: image width (256/128)")
    a = ap.parse_args()
    variant = pick_variant()
    from exr_zip import write_exr_zip
    if variant.startswith("llvm") or variant.startswith("scalar"):
        import torrey_bsdfs
        torrey_bsdfs.register()
    only = set(a.only.split(",")) if a.only else None

    if a.shared:
        shared = os.environ.get("TORREY_SHARED", os.path.join(os.path.dirname(REPO), "shared"))
        out_dir = os.path.join(REPO, "out", "mitsuba_shared")
        os.makedirs(out_dir, exist_ok=True)
        import xml.etree.ElementTree as ET
        for rel in SHARED_SCENES:
            if only and rel not in only:
                continue
            path = os.path.join(shared, "scenes", "torrey", rel)
            root = ET.parse(path).getroot()
            film = root.find("sensor/film")
            w0 = int(next(c.get("value") for c in film if c.get("name") == "width"))
            h0 = int(next(c.get("value") for c in film if c.get("name") == "height"))
            width = a.width or 256
            height = max(1, round(h0 * width / w0))
            name = rel.replace("/", "__").replace(".xml", "")
            try:
                img, info = render(path, width, height, a.spp or 1024, None,
                                   os.path.join(out_dir, name + "_mitsuba.xml"))
            except Exception as e:  # noqa: BLE001
                print("FAILED %s: %s" % (rel, e), file=sys.stderr)
                continue
            write_exr_zip(os.path.join(out_dir, name + ".exr"), img)
            info.update(source=os.path.relpath(path, REPO), mitsuba_version=mi.__version__, variant=variant)
            with open(os.path.join(out_dir, name + ".json"), "w") as f:
                json.dump(info, f, indent=2)
            print("%-55s %4dx%-4d %5d spp depth %3d  %6.1fs noise %.4f" % (
                rel, info["width"], info["height"], info["spp"], info["max_depth"],
                info["render_seconds"], info["noise_rel"]), flush=True)
        return

    if a.shared_env:
        import glob
        import xml.etree.ElementTree as ET
        out_dir = os.path.join(REPO, "out", "mitsuba_shared_env")
        os.makedirs(out_dir, exist_ok=True)
        for path in sorted(glob.glob(os.path.join(REPO, "tests", "scenes", "shared_env_*.xml"))):
            name = os.path.basename(path)[:-4]
            if only and name not in only:
                continue
            film = ET.parse(path).getroot().find("sensor/film")
            w0 = int(next(c.get("value") for c in film if c.get("name") == "width"))
            h0 = int(next(c.get("value") for c in film if c.get("name") == "height"))
            width = a.width or 128
            height = max(1, round(h0 * width / w0))
            try:
                img, info = render(path, width, height, a.spp or 4096, None,
                                   os.path.join(out_dir, name + "_mitsuba.xml"))
            except Exception as e:  # noqa: BLE001
                print("FAILED %s: %s" % (name, e), file=sys.stderr)
                continue
            write_exr_zip(os.path.join(out_dir, name + ".exr"), img)
            info.update(source=os.path.relpath(path, REPO), mitsuba_version=mi.__version__, variant=variant)
            with open(os.path.join(out_dir, name + ".json"), "w") as f:
                json.dump(info, f, indent=2)
            print("%-28s %4dx%-4d %5d spp depth %3d  %6.1fs noise %.4f" % (
                name, info["width"], info["height"], info["spp"], info["max_depth"],
                info["render_seconds"], info["noise_rel"]), flush=True)
        return

    out_dir = os.path.join(REPO, "tests", "references", "mitsuba")
    os.makedirs(out_dir, exist_ok=True)
    manifest_path = os.path.join(out_dir, "manifest.json")
    manifest = {}
    if os.path.exists(manifest_path):
        with open(manifest_path) as f:
            manifest = json.load(f).get("references", {})
    for name, (scene, w, h, spp, depth) in REFERENCES.items():
        if only and name not in only:
            continue
        img, info = render(os.path.join(REPO, scene), w, h, a.spp or spp, depth,
                           os.path.join(REPO, "out", "mitsuba_refs", name + "_mitsuba.xml"))
        exr = os.path.join(out_dir, name + ".exr")
        write_exr_zip(exr, img)
        entry = {"source": scene, "width": info["width"], "height": info["height"], "spp": info["spp"],
                 "max_depth": info["max_depth"], "mitsuba_version": mi.__version__, "variant": variant,
                 "render_seconds": info["render_seconds"], "noise_rel": info["noise_rel"],
                 "mean_rgb": info["mean_rgb"], "conversions": info["conversions"],
                 "plugins": info["plugins"]}
        manifest[name] = entry
        print("%-15s %3dx%-3d %5d spp depth %2d  %6.1fs  noise %.5f  %6.1f KB" % (
            name, info["width"], info["height"], info["spp"], info["max_depth"], info["render_seconds"],
            info["noise_rel"], os.path.getsize(exr) / 1024), flush=True)
    with open(manifest_path, "w") as f:
        json.dump({"generator": "tests/mitsuba/make_references.py",
                   "notes": "Mitsuba 3 renders of torrey scenes converted by torrey_to_mitsuba.py; "
                            "torrey's own materials via torrey_bsdfs.py. noise_rel = mean |a-b|/2 / mean "
                            "for two half-spp renders a, b with seeds 0 and 1.",
                   "references": dict(sorted(manifest.items()))}, f, indent=2)
        f.write("\n")


if __name__ == "__main__":
    main()
