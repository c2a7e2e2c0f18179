#!/usr/bin/env python3
"""Mitsuba 3 references for the firefly scenes (tests/scenes/fireflies/, issue 34 section 3).

    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
    tests/mitsuba/.venv/bin/python tests/mitsuba/make_firefly_references.py [--passes 64] [--spp 1024]
    tests/mitsuba/.venv/bin/python tests/mitsuba/make_firefly_references.py --noise 256 --seeds 1,2,3,4 --out DIR

The first form renders each scene in PASSES independent passes of SPP samples (seeds 1000...) and
writes tests/references/fireflies/<name>.exr (the mean) and <name>_var.exr (the variance of that
mean: the passes' sample variance, ddof 1, over the number of passes), both ZIP-compressed.
The second renders each scene once per seed at the given spp into DIR/<name>_mitsuba_<spp>_s<seed>.exr,
to measure Mitsuba's own error at that spp against the reference (`torrey compare`).
Variant llvm_ad_rgb.
"""
import argparse
import glob
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SCENES = os.path.join(REPO, "tests", "scenes", "fireflies")
OUT = os.path.join(REPO, "tests", "references", "fireflies")
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402
import mitsuba as mi  # noqa: E402

from exr_zip import write_exr_zip  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--passes", type=int, default=64)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--only", default="")
    ap.add_argument("--noise", type=int, default=0, help="render at this spp once per seed")
    ap.add_argument("--seeds", default="1,2,3,4")
    ap.add_argument("--out", default="/tmp")
    args = ap.parse_args()
    mi.set_variant("llvm_ad_rgb")
    only = set(filter(None, args.only.split(",")))
    for path in sorted(glob.glob(os.path.join(SCENES, "*.xml"))):
        name = os.path.splitext(os.path.basename(path))[0]
        if only and name not in only:
            continue
        if args.noise:
            scene = mi.load_file(path, spp=args.noise)
            for seed in (int(s) for s in args.seeds.split(",")):
                img = np.array(mi.render(scene, seed=seed))[..., :3]
                out = os.path.join(args.out, "%s_mitsuba_%d_s%d.exr" % (name, args.noise, seed))
                write_exr_zip(out, img)
                print("wrote", out)
            continue
        scene = mi.load_file(path, spp=args.spp)
        start = time.time()
        total = None
        total2 = None
        for k in range(args.passes):
            img = np.array(mi.render(scene, seed=1000 + k), dtype=np.float64)[..., :3]
            total = img if total is None else total + img
            total2 = img * img if total2 is None else total2 + img * img
        n = args.passes
        mean = total / n
        var_of_mean = np.maximum(total2 / n - mean * mean, 0.0) * n / (n - 1) / n
        os.makedirs(OUT, exist_ok=True)
        write_exr_zip(os.path.join(OUT, name + ".exr"), mean.astype(np.float32))
        write_exr_zip(os.path.join(OUT, name + "_var.exr"), var_of_mean.astype(np.float32))
        print("%s: %d x %d spp in %.0f s" % (name, n, args.spp, time.time() - start))


if __name__ == "__main__":
    main()
