#!/usr/bin/env python3
"""Regenerates the Blender Cycles reference renders of the project's own scenes.

One command (after `bash tests/blender/setup.sh`):

    tests/blender/.venv/bin/python tests/blender/make_references.py              # all
    tests/blender/.venv/bin/python tests/blender/make_references.py --only cbox   # a subset
    ... make_references.py --spp-scale 0.125                                      # quick look

Writes tests/references/blender/<name>.exr (linear float32 RGB, ZIP) and manifest.json (source
scene relative to the repo root, size, spp, max_depth, Blender version, render seconds, a noise
estimate). Sizes match tests/references/mitsuba so the two references compare directly. Scenes
in scenes/*.xml that the converter refuses (plastic, phong, blinn, ...) are listed under
"skipped" in the manifest with the reason.

Each image is rendered as two halves with different seeds and averaged; `noise_rel` =
mean|a - b| / 2 / mean(image) estimates the relative standard error of the average.
Cycles runs on the CPU with --threads (default 2: the machine is shared).
"""
import argparse
import glob
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
OUT = os.path.join(REPO, "tests", "references", "blender")
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402
import OpenEXR  # noqa: E402

import torrey_to_blender as t2b  # noqa: E402

# name: (scene relative to the repo root, width, height, spp, max_depth override or None)
REFERENCES = {
    "cbox": ("scenes/cbox.xml", 64, 64, 8192, None),
    "cbox_depth2": ("scenes/cbox.xml", 64, 64, 8192, 2),
    "cbox_spheres": ("scenes/cbox_spheres.xml", 64, 64, 16384, None),
    "materials": ("scenes/materials.xml", 96, 66, 4096, None),
    "textured_mesh": ("scenes/textured_mesh.xml", 96, 72, 4096, None),
}
# scenes/*.xml not in the table get this width (height from the aspect ratio) and spp.
DEFAULT_WIDTH, DEFAULT_SPP = 96, 4096


def read_exr(path):
    ch = OpenEXR.File(path).channels()
    if "RGB" in ch:
        return np.asarray(ch["RGB"].pixels, dtype=np.float32)
    return np.stack([np.asarray(ch[c].pixels, dtype=np.float32) for c in "RGB"], axis=-1)


def write_exr(path, rgb):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    channels = {"RGB": np.ascontiguousarray(rgb, dtype=np.float32)}
    with OpenEXR.File(header, channels) as f:
        f.write(path)


def jobs(only):
    table = dict(REFERENCES)
    for path in sorted(glob.glob(os.path.join(REPO, "scenes", "*.xml"))):
        name = os.path.splitext(os.path.basename(path))[0]
        if not any(v[0] == f"scenes/{name}.xml" for v in table.values()):
            table[name] = (f"scenes/{name}.xml", DEFAULT_WIDTH, None, DEFAULT_SPP, None)
    if only:
        unknown = set(only) - set(table)
        if unknown:
            sys.exit(f"unknown reference(s): {', '.join(sorted(unknown))}; known: {', '.join(table)}")
        table = {k: v for k, v in table.items() if k in only}
    return table


def main():
    ap = argparse.ArgumentParser(description="Render the Blender Cycles references.")
    ap.add_argument("--only", help="comma-separated names")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--spp-scale", type=float, default=1.0, help="multiply every spp (quick checks)")
    ap.add_argument("--out", default=OUT, help="output folder (default tests/references/blender)")
    args = ap.parse_args()
    import bpy

    os.makedirs(args.out, exist_ok=True)
    manifest_path = os.path.join(args.out, "manifest.json")
    manifest = {"renderer": f"Blender {bpy.app.version_string} Cycles (CPU)", "references": {}, "skipped": {}}
    if os.path.exists(manifest_path):
        with open(manifest_path) as f:
            old = json.load(f)
        manifest["references"].update(old.get("references", {}))
        manifest["skipped"].update(old.get("skipped", {}))
    table = jobs(args.only.split(",") if args.only else None)
    for name, (rel, w, h, spp, md) in table.items():
        spp = max(2, int(spp * args.spp_scale)) // 2 * 2
        scene_path = os.path.join(REPO, rel)
        try:
            scene = t2b.read_scene(scene_path)
        except t2b.Unsupported as e:
            print(f"{name}: skipped: {e}", flush=True)
            manifest["skipped"][name] = {"scene": rel, "reason": str(e).replace(REPO + os.sep, "")}
            manifest["references"].pop(name, None)
            continue
        cam = scene["camera"]
        if h is None:
            h = round(cam["height"] * w / cam["width"])
        halves, secs = [], 0.0
        for seed in (0, 1):
            tmp = os.path.join(args.out, f".{name}_half{seed}.exr")
            try:
                s, _ = t2b.render(scene_path, tmp, w, h, spp // 2, args.threads, seed, md)
            except t2b.Unsupported as e:
                print(f"{name}: skipped: {e}", flush=True)
                manifest["skipped"][name] = {"scene": rel, "reason": str(e).replace(REPO + os.sep, "")}
                break
            secs += s
            halves.append(read_exr(tmp))
            os.remove(tmp)
        if len(halves) != 2:
            continue
        img = (halves[0] + halves[1]) / 2
        noise = float(np.abs(halves[0] - halves[1]).mean() / 2 / max(img.mean(), 1e-12))
        out = os.path.join(args.out, f"{name}.exr")
        write_exr(out, img)
        depth = md if md is not None else scene["max_depth"]
        manifest["skipped"].pop(name, None)
        manifest["references"][name] = {
            "file": f"{name}.exr",
            "scene": rel,
            "width": w,
            "height": h,
            "spp": spp,
            "max_depth": depth,
            "cycles_max_bounces": t2b.UNBOUNDED_BOUNCES if depth < 0 else depth - 2,
            "blender_version": bpy.app.version_string,
            "render_seconds": round(secs, 1),
            "threads": args.threads,
            "noise_rel": round(noise, 6),
            "mean_rgb": [round(float(x), 6) for x in img.reshape(-1, 3).mean(axis=0)],
        }
        print(f"{name}: {w}x{h} {spp} spp depth {depth}: {secs:.1f} s, noise_rel {noise:.4f}, "
              f"{os.path.getsize(out) // 1024} KiB", flush=True)
        with open(manifest_path, "w") as f:
            json.dump(manifest, f, indent=2, sort_keys=True)
            f.write("\n")
    with open(manifest_path, "w") as f:
        json.dump(manifest, f, indent=2, sort_keys=True)
        f.write("\n")


if __name__ == "__main__":
    main()
