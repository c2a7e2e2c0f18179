#!/usr/bin/env python3
"""A Mitsuba 3.9.1 reference (llvm_ad_rgb) of a scene of this repository, in the layout of
../shared/scenes/mitsuba-real/refs (what bench/clean_image.py reads):

    python3 bench/mitsuba_reference.py scenes/interior_openings.xml --spp 4096 [--passes 16]

renders PASSES passes of SPP/PASSES samples with seeds 0..PASSES-1 and writes
out/refs/<stem>.exr (the passes' mean, linear RGB) and out/refs/<stem>_var.exr (the variance of
that mean: the passes' sample variance, ddof 1, over PASSES), as render_refs.py there does.
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import OUT, log  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--passes", type=int, default=16)
    a = ap.parse_args()
    common.setup_mitsuba()
    common.reexec_in_venv()
    import numpy as np
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    scene = mi.load_file(os.path.abspath(a.scene))
    per = a.spp // a.passes
    acc = acc2 = None
    start = time.monotonic()
    for seed in range(a.passes):
        img = np.array(mi.render(scene, spp=per, seed=seed), dtype=np.float64)[..., :3]
        acc = img if acc is None else acc + img
        acc2 = img * img if acc2 is None else acc2 + img * img
        log("pass %d/%d, %.0f s" % (seed + 1, a.passes, time.monotonic() - start))
    p = a.passes
    mean = acc / p
    var_of_mean = np.maximum(acc2 / p - mean * mean, 0) * p / (p - 1) / p
    os.makedirs(os.path.join(OUT, "..", "refs"), exist_ok=True)
    base = os.path.join(OUT, "..", "refs", os.path.splitext(os.path.basename(a.scene))[0])
    mi.Bitmap(mean.astype(np.float32)).write(base + ".exr")
    mi.Bitmap(var_of_mean.astype(np.float32)).write(base + "_var.exr")
    log("wrote %s.exr and %s_var.exr (%d spp, %.0f s)" % (base, base, per * p, time.monotonic() - start))


if __name__ == "__main__":
    main()
