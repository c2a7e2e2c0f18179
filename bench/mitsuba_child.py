#!/usr/bin/env python3
"""One Mitsuba 3 benchmark process (run by bench/common.py, under tests/mitsuba/.venv's python).

  mitsuba_child.py --variant llvm_ad_rgb --xml SCENE_mitsuba.xml --spp N --threads T --seed S
                   [--plugins] [--warm] [--out IMAGE.exr] [--budget-s SECONDS --calib-spp N]

Prints one JSON line on stdout:
  import_s   python + mitsuba import and set_variant;
  load_s     mi.load_file (scene load, BVH build, texture loading);
  first_render_s  the first mi.render + dr.eval + dr.sync_thread in this process: for llvm
             variants it includes tracing and LLVM compilation of the kernel (cold kernel cache
             when the caller points HOME to an empty directory);
  *_cpu_s    the same spans' process CPU time (all threads; robust to other load on the machine);
  warm_render_s   (--warm) a second render with seed+1000: the kernel comes from drjit's in-memory
             cache, so this is the steady-state render time;
  mean_rgb   image mean of the last render (sanity check against torrey's image).
--budget-s: equal-time mode. Renders --calib-spp twice (cold, then warm) to measure the warm
samples/s, picks spp = budget x rate / pixels and renders that (writing --out).
"""
import argparse
import json
import os
import sys
import time

t_start = time.perf_counter()
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "mitsuba"))

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402


CPU = {}


def render(scene, spp, seed):
    """Renders; returns the image and the wall seconds, and leaves the process CPU seconds (all
    threads) of the same span in CPU["last"]."""
    t, c = time.perf_counter(), time.process_time()
    img = mi.render(scene, seed=seed, spp=spp)
    dr.eval(img)
    dr.sync_thread()
    CPU["last"] = time.process_time() - c
    return img, time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", required=True)
    ap.add_argument("--xml", required=True)
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--plugins", action="store_true")
    ap.add_argument("--warm", action="store_true")
    ap.add_argument("--out")
    ap.add_argument("--budget-s", type=float)
    ap.add_argument("--calib-spp", type=int, default=4)
    a = ap.parse_args()

    mi.set_variant(a.variant)
    if a.threads > 0:
        dr.set_thread_count(a.threads)
    if a.plugins:
        import torrey_bsdfs
        torrey_bsdfs.register()
    r = {"variant": a.variant, "mitsuba_version": mi.__version__, "threads": dr.thread_count()}
    r["import_s"] = round(time.perf_counter() - t_start, 4)
    t = time.perf_counter()
    scene = mi.load_file(a.xml)
    r["load_s"] = round(time.perf_counter() - t, 4)
    w, h = scene.sensors()[0].film().crop_size()
    pixels = int(w) * int(h)

    if a.budget_s:
        _, r["first_render_s"] = render(scene, a.calib_spp, a.seed + 2000)
        _, warm = render(scene, a.calib_spp, a.seed + 3000)
        r["calib_spp"], r["calib_warm_s"] = a.calib_spp, warm
        rate = pixels * a.calib_spp / warm
        spp = max(1, int(a.budget_s * rate / pixels))
        img, secs = render(scene, spp, a.seed)
        r.update(spp=spp, render_s=secs)
    else:
        img, r["first_render_s"] = render(scene, a.spp, a.seed)
        r["first_render_cpu_s"] = CPU["last"]
        r["spp"] = a.spp
        if a.warm:
            img, r["warm_render_s"] = render(scene, a.spp, a.seed + 1000)
            r["warm_render_cpu_s"] = CPU["last"]
    arr = __import__("numpy").array(img)[..., :3]
    r["mean_rgb"] = [float(x) for x in arr.reshape(-1, 3).mean(axis=0)]
    r["width"], r["height"] = int(w), int(h)
    if a.out:
        from exr_zip import write_exr_zip
        write_exr_zip(a.out, arr)
    print(json.dumps(r))


if __name__ == "__main__":
    main()
