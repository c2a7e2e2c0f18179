#!/usr/bin/env python3
"""Mitsuba 3 references of the torrey course's own scenes (../shared/scenes/torrey), rendered
under the course's conventions, for tests/course_scenes.rs (CI).

    source tests/mitsuba/setup.sh
    tests/mitsuba/.venv/bin/python tests/mitsuba/make_course_references.py [--only a,b] [--spp N]

Writes tests/references/course/<dir>__<name>.exr (float32 RGB, ZIP) and manifest.json. The
scenes are converted by torrey_to_mitsuba.py, which applies the course's rules whatever the file
looks like: every bsdf two-sided, `<background>` (or the course's 0.5 grey when there is none) as a
`constant` emitter, a box pixel filter. The scenes stay in ../shared (third-party data, never
committed); only these small renders of them are. Licences of the scenes: ../shared/DATA.md (the
course's MIT licence; head.obj is CC BY 3.0, Lee Perry-Smith / Infinite Realities).

Each image is two half-spp renders with seeds 0 and 1; `noise_rel` (mean |a - b| / 2 / mean) in
the manifest gives the reference's own noise to the comparison (tests/common).
"""
import argparse
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import mitsuba as mi  # noqa: E402

import make_references  # noqa: E402

# Scene (relative to ../shared/scenes/torrey), width, height, spp. The films are 640 x 480 (cbox:
# 512 x 512); the references keep that shape at 64 x 48 (48 x 48).
COURSE_SCENES = [
    ("hw1_spheres/scene0.xml", 64, 48, 16384),
    ("hw1_spheres/scene0_spherical_light.xml", 64, 48, 16384),
    ("hw2_triangles/single_triangle.xml", 64, 48, 16384),
    ("hw2_triangles/tetrahedron.xml", 64, 48, 16384),
    ("head/head.xml", 64, 48, 16384),
    ("head/head_spherical_light.xml", 64, 48, 16384),
    ("texture_test/texture.xml", 64, 48, 16384),
    ("texture_test/texture_scaled.xml", 64, 48, 16384),
    # Also read with Mitsuba's rules by the old detection (nothing only the course has).
    ("aabb_test/aabb_test.xml", 64, 48, 16384),
    # Scenes with the course's own elements (<background>, its bsdfs): guards for them too.
    ("cbox/cbox.xml", 48, 48, 16384),
    ("cbox/cbox_area_light_spheres.xml", 48, 48, 16384),
    ("hw1_spheres/scene1.xml", 64, 48, 16384),
    ("hw1_spheres/scene1_spherical_light_phong.xml", 64, 48, 16384),
    ("hw1_spheres/scene1_spherical_light_blinn.xml", 64, 48, 16384),
    ("teapot/teapot_textured.xml", 64, 48, 16384),
    ("teapot/teapot_textured_blinn_microfacet.xml", 64, 48, 16384),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", help="comma-separated scene paths (as in COURSE_SCENES) to render")
    ap.add_argument("--spp", type=int, help="override spp")
    a = ap.parse_args()
    variant = make_references.pick_variant()
    from exr_zip import write_exr_zip
    import torrey_bsdfs
    torrey_bsdfs.register()
    shared = os.environ.get("TORREY_SHARED", os.path.join(os.path.dirname(REPO), "shared"))
    only = set(a.only.split(",")) if a.only else None
    out_dir = os.path.join(REPO, "tests", "references", "course")
    os.makedirs(out_dir, exist_ok=True)
    manifest_path = os.path.join(out_dir, "manifest.json")
    manifest = {}
    if os.path.exists(manifest_path):
        with open(manifest_path) as f:
            manifest = json.load(f).get("references", {})
    for rel, w, h, spp in COURSE_SCENES:
        if only and rel not in only:
            continue
        name = rel.replace("/", "__").replace(".xml", "")
        path = os.path.join(shared, "scenes", "torrey", rel)
        img, info = make_references.render(
            path, w, h, a.spp or spp, None,
            os.path.join(REPO, "out", "mitsuba_course", name + "_mitsuba.xml"))
        exr = os.path.join(out_dir, name + ".exr")
        write_exr_zip(exr, img)
        manifest[name] = {
            "shared_source": "scenes/torrey/" + rel, "width": info["width"],
            "height": info["height"], "spp": info["spp"], "max_depth": info["max_depth"],
            "mitsuba_version": mi.__version__, "variant": variant,
            "render_seconds": info["render_seconds"], "noise_rel": info["noise_rel"],
            "mean_rgb": info["mean_rgb"], "conversions": info["conversions"],
            "plugins": info["plugins"]}
        print("%-45s %3dx%-3d %5d spp depth %2d  %6.1fs  noise %.5f  %6.1f KB" % (
            rel, info["width"], info["height"], info["spp"], info["max_depth"],
            info["render_seconds"], info["noise_rel"], os.path.getsize(exr) / 1024), flush=True)
    with open(manifest_path, "w") as f:
        json.dump({"generator": "tests/mitsuba/make_course_references.py",
                   "notes": "Mitsuba 3 renders of the torrey course's scenes in ../shared/scenes/torrey "
                            "(third-party data, not in this repository; licences in ../shared/DATA.md), "
                            "converted with the course's conventions by torrey_to_mitsuba.py (two-sided "
                            "bsdfs, <background> or the implicit 0.5 grey as a constant emitter, box "
                            "filter). noise_rel = mean |a-b|/2 / mean for two half-spp renders a, b "
                            "with seeds 0 and 1.",
                   "references": dict(sorted(manifest.items()))}, f, indent=2)
        f.write("\n")


if __name__ == "__main__":
    main()
