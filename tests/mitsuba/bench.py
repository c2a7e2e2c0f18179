#!/usr/bin/env python3
"""Measures Mitsuba 3's render speed on a torrey scene, for comparison with torrey's.
Usage (after `source tests/mitsuba/setup.sh`):
  tests/mitsuba/.venv/bin/python tests/mitsuba/bench.py [SCENE] [--variants scalar_rgb,llvm_ad_rgb]
      [--size 512] [--spp 64] [--max-depth 8] [--runs 3]
SCENE defaults to ../shared/scenes/torrey/cbox/cbox.xml. The scene is converted with
torrey_to_mitsuba.py (box filter, independent sampler), loaded once per variant, then rendered
--runs times; the time excludes scene loading (the first llvm run includes JIT compilation, later
ones reuse drjit's kernel cache). Prints per-run seconds, the median and samples/s. Each variant
runs in its own subprocess.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))


def child(args):
    import mitsuba as mi
    mi.set_variant(args.variant)
    sys.path.insert(0, HERE)
    from torrey_to_mitsuba import convert
    text, info = convert(args.scene, args.size, args.size, args.spp, args.max_depth)
    xml = os.path.join(REPO, "out", "bench_%s.xml" % args.variant)
    os.makedirs(os.path.dirname(xml), exist_ok=True)
    with open(xml, "w") as f:
        f.write(text)
    t = time.time()
    scene = mi.load_file(xml)
    load = time.time() - t
    times = []
    for i in range(args.runs):
        t = time.time()
        img = mi.render(scene, seed=i, spp=args.spp)
        _ = float(img.numpy().mean()) if hasattr(img, "numpy") else None  # force evaluation
        times.append(time.time() - t)
    print(json.dumps({"variant": args.variant, "load_seconds": load, "runs": times}))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default=os.path.join(os.path.dirname(REPO), "shared", "scenes",
                                                            "torrey", "cbox", "cbox.xml"))
    ap.add_argument("--variants", default="scalar_rgb,llvm_ad_rgb")
    ap.add_argument("--variant")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--runs", type=int, default=3)
    a = ap.parse_args()
    if a.variant:
        return child(a)
    samples = a.size * a.size * a.spp
    for v in a.variants.split(","):
        out = subprocess.run([sys.executable, __file__, a.scene, "--variant", v, "--size", str(a.size),
                              "--spp", str(a.spp), "--max-depth", str(a.max_depth), "--runs", str(a.runs)],
                             capture_output=True, text=True)
        if out.returncode != 0:
            print("%s failed:\n%s" % (v, out.stderr[-2000:]))
            continue
        r = json.loads(out.stdout.strip().splitlines()[-1])
        med = statistics.median(r["runs"])
        print("%-12s load %.2fs  runs %s  median %.2fs  %.2f Msamples/s" % (
            v, r["load_seconds"], " ".join("%.2f" % x for x in r["runs"]), med, samples / med / 1e6))


if __name__ == "__main__":
    main()
