#!/usr/bin/env python3
"""Participating media: speed at equal spp against Mitsuba 3, and error at equal time on a sparse
heterogeneous medium (issue 32's goal: at least 3x lower error than Mitsuba and than torrey's own
global-majorant tracking).

    tests/mitsuba/.venv/bin/python bench/media_equal_time.py [--torrey target/release/torrey]
        [--budget 20] [--runs 2] [--ref-spp 8192] [--methods A,B] [--out DIR]
        [--speed [SCENE.xml ...]]

--speed: instead, the CPU seconds of torrey (independent samples, like Mitsuba's) and of Mitsuba
(llvm_ad_rgb, its kernel compiled by a first 1-spp render) at equal spp on the given scenes
(default: the media verdict scenes and the media scenes of ../shared/scenes/mitsuba-real).

Equal time is measured in process CPU seconds (all threads; robust to other load on a shared
machine): torrey's whole process, Mitsuba's render with its kernel compiled by a first 1-spp
render. Each method renders 16 spp to measure its CPU seconds per spp, then --runs renders of
the spp that fill the budget. Error: relMSE as bench/real_scenes.py measures it (worst 0.1% of
pixel terms left out, the reference's noise taken off) and RMSE (its MSE less the reference's
mean variance), against torrey at --ref-spp independent samples (rendered once in parts of
--ref-chunk, cached under --out, with the variance of their mean); then error x CPU seconds, so
that the calibration's inaccuracy does not count.

The scene (written to --out): a 64^3 cloud of our own in a null cube, about 5% of the voxels
occupied, densities up to 40 per unit length (strong contrast), under a rectangular light and a
dim sky, `volpath` max_depth 16. Compared:
  torrey            majorant grid (default), Sobol samples
  torrey global     TORREY_MAJORANT_GRID=1 (one majorant, Mitsuba's tracking), Sobol
  torrey indep      majorant grid, independent samples (the noise of the estimator alone)
  Mitsuba 3.9.1     llvm_ad_rgb (global majorant, delta tracking)
"""
import argparse
import hashlib
import json
import os
import resource
import struct
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "tests", "mitsuba"))
sys.path.insert(0, HERE)

SCENE = """<scene version="3.0.0">
    <default name="spp" value="16"/>
    <integrator type="volpath"><integer name="max_depth" value="16"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="38"/>
        <transform name="to_world"><lookat origin="0.4, 1.6, 4.2" target="0, 1, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="128"/><integer name="height" value="96"/>
            <rfilter type="box"/></film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="0.15, 0.2, 0.3"/></emitter>
    <shape type="rectangle">
        <transform name="to_world"><scale value="5"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.4"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale x="0.8" y="0.6" z="1"/><rotate x="1" angle="90"/>
            <translate x="0.8" y="3.2" z="0.4"/></transform>
        <emitter type="area"><rgb name="radiance" value="20, 17, 13"/></emitter>
    </shape>
    <medium type="heterogeneous" id="cloud">
        <volume type="gridvolume" name="sigma_t"><string name="filename" value="sparse_cloud.vol"/>
            <transform name="to_world"><scale value="2"/><translate x="-1" y="0.05" z="-1"/></transform>
        </volume>
        <float name="scale" value="40"/>
        <rgb name="albedo" value="0.95, 0.93, 0.9"/>
        <phase type="hg"><float name="g" value="0.5"/></phase>
    </medium>
    <shape type="cube">
        <transform name="to_world"><translate y="1.05"/></transform>
        <bsdf type="null"/>
        <ref name="interior" id="cloud"/>
    </shape>
</scene>
"""


def sparse_cloud(path, n=64, seed=5):
    """About 5% of the voxels occupied: ninety small dense puffs, smooth edges."""
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(3 * [(np.arange(n) + 0.5) / n]), indexing="ij")
    d = np.zeros((n, n, n))
    for _ in range(90):
        c = rng.uniform(0.2, 0.8, 3)
        r = rng.uniform(0.03, 0.08)
        d2 = ((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) / r ** 2
        d = np.maximum(d, rng.uniform(0.3, 1.0) * np.clip(1.0 - d2, 0, None) ** 2)
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]) + struct.pack("<iiiii", 1, n, n, n, 1))
        f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(d.astype("<f4").tobytes())
    return float((d > 0.01).mean())


def read_exr(path, channels="RGB"):
    """The named channels of an EXR as float64 (H, W, len(channels))."""
    import mitsuba as mi
    b = mi.Bitmap(path)
    names = [b.struct_()[i].name for i in range(b.channel_count())]
    a = np.array(b).astype(np.float64)
    if isinstance(channels, str):
        channels = list(channels)
    idx = [names.index(c) for c in channels] if channels[0] in names else [0, 1, 2]
    return a[..., idx]


def torrey(exe, xml, spp, out, env=None, sampler=None, seed=0, extra=()):
    """Renders with torrey; returns CPU seconds of the child (all threads)."""
    cmd = [exe, xml, "--seed", str(seed), "-o", out, "--quiet", "--no-mipmap", *extra]
    if spp is not None:
        cmd += ["--spp", str(spp)]
    if sampler:
        cmd += ["--sampler", sampler]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, env={**os.environ, **(env or {})},
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def mitsuba(xml, spp, out, seed=0):
    """Renders with Mitsuba in this process (llvm_ad_rgb); returns CPU seconds of the render
    (kernel compiled by a first, small render)."""
    import drjit as dr
    import mitsuba as mi
    from exr_zip import write_exr_zip
    scene = mi.load_file(xml)
    img = mi.render(scene, spp=1, seed=seed + 777)
    dr.eval(img)
    dr.sync_thread()
    c = time.process_time()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    cpu = time.process_time() - c
    write_exr_zip(out, np.array(img)[..., :3])
    return cpu


def errors(img, ref, var):
    """(relMSE, RMSE) against the reference, its own noise (`var`, the variance of its mean)
    taken off: relMSE as bench/real_scenes.py measures it (the worst 0.1% of pixel terms left
    out), RMSE = sqrt(MSE - mean variance)."""
    from real_scenes import rel_mse
    mse = float(((img - ref) ** 2).mean()) - float(var.mean())
    return rel_mse(img, ref, var), float(np.sqrt(max(mse, 0.0)))


def reference(exe, xml, spp, chunk, folder):
    """torrey's reference of the scene: `spp` independent samples (their variance is the noise
    of the mean; Sobol's would be overestimated), rendered as parts of `chunk` samples (kept: a
    larger --ref-spp renders only the missing ones). Returns (mean, variance of the mean): the
    parts' mean and sum of variances / parts² (parts of equal counts)."""
    os.makedirs(folder, exist_ok=True)
    means, variances = [], []
    for a in range(0, spp, chunk):
        b = min(spp, a + chunk)
        part = os.path.join(folder, "part_%d_%d.exr" % (a, b))
        if not os.path.exists(part):
            t0 = time.time()
            cpu = torrey(exe, xml, b, part + ".tmp.exr", sampler="independent", seed=99,
                         extra=["--sample-range", "%d..%d" % (a, b)])
            os.replace(part + ".tmp.exr", part)
            print("reference samples %d..%d: %.0f CPU s, %.0f s" % (a, b, cpu, time.time() - t0),
                  flush=True)
        means.append(read_exr(part))
        variances.append(read_exr(part, ["variance.R", "variance.G", "variance.B"]))
    k = len(means)
    return np.mean(means, 0), np.sum(variances, 0) / k ** 2


METHODS = {
    "torrey": ({}, None),
    "torrey global majorant": ({"TORREY_MAJORANT_GRID": "1"}, None),
    "torrey independent": ({}, "independent"),
    "torrey global, independent": ({"TORREY_MAJORANT_GRID": "1"}, "independent"),
    # The majorant grid's resolution (default: a cell per 4 samples, 16^3 here).
    "torrey majorant 32": ({"TORREY_MAJORANT_GRID": "32"}, None),
    "torrey majorant 64": ({"TORREY_MAJORANT_GRID": "64"}, None),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--torrey", default=os.path.join(REPO, "target", "release", "torrey"))
    ap.add_argument("--budget", type=float, default=20.0, help="CPU seconds per method")
    ap.add_argument("--runs", type=int, default=2, help="renders (seeds) per method")
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--ref-chunk", type=int, default=2048)
    ap.add_argument("--methods", help="comma-separated subset of: %s, Mitsuba" % ", ".join(METHODS))
    ap.add_argument("--out", default=os.path.join(REPO, "out", "bench", "media"))
    ap.add_argument("--speed", nargs="*", help="equal-spp timing instead (scene files; spp 16)")
    a = ap.parse_args()
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    os.makedirs(a.out, exist_ok=True)
    if a.speed is not None:
        speed(a.torrey, [(x, 16) for x in a.speed] or SPEED_SCENES, a.out)
        return
    occupied = sparse_cloud(os.path.join(a.out, "sparse_cloud.vol"))
    xml = os.path.join(a.out, "sparse_cloud.xml")
    with open(xml, "w") as f:
        f.write(SCENE)
    print("sparse cloud: %.1f%% of the voxels above 1%% of the peak" % (100 * occupied))
    # The reference's folder is named by the scene's text: another scene gets another one.
    key = hashlib.sha1((SCENE + str(occupied)).encode()).hexdigest()[:10]
    ref, var = reference(a.torrey, xml, a.ref_spp, a.ref_chunk, os.path.join(a.out, "ref_" + key))
    print("reference: torrey %d spp (independent), mean %s, its noise relMSE %.3g" % (
        a.ref_spp, ref.mean((0, 1)).round(4).tolist(), float((var / (ref ** 2 + 1e-2)).mean())))
    runs = {name: (lambda spp, out, seed, e=env, s=smp: torrey(a.torrey, xml, spp, out, env=e,
                                                               sampler=s, seed=seed))
            for name, (env, smp) in METHODS.items()}
    runs["Mitsuba"] = lambda spp, out, seed: mitsuba(xml, spp, out, seed=seed)
    chosen = a.methods.split(",") if a.methods else list(runs)
    results = {}
    for name in chosen:
        run = runs[name]
        calib = 16
        out = os.path.join(a.out, name.replace(" ", "_").replace(",", "") + ".exr")
        cpu = run(calib, out, 1000)
        spp = max(1, int(a.budget / (cpu / calib)))
        r = {"spp": spp, "cpu_s": [], "relmse": [], "rmse": []}
        images = []
        for k in range(a.runs):
            r["cpu_s"].append(round(run(spp, out, k), 2))
            img = read_exr(out)
            images.append(img)
            rel, rm = errors(img, ref, var)
            r["relmse"].append(rel)
            r["rmse"].append(rm)
        r["relmse_mean"] = float(np.mean(r["relmse"]))
        r["rmse_mean"] = float(np.sqrt(np.mean(np.square(r["rmse"]))))
        # Unbiased against the reference: the mean of the runs has 1/runs of one run's error.
        r["relmse_of_mean_x_runs"] = errors(np.mean(images, 0), ref, var)[0] * a.runs
        results[name] = r
        print("%-28s %5d spp  CPU s %s  relMSE %.4g  RMSE %.5f  (mean of %d runs: relMSE x %d = "
              "%.4g)" % (name, spp, r["cpu_s"], r["relmse_mean"], r["rmse_mean"], a.runs, a.runs,
                         r["relmse_of_mean_x_runs"]), flush=True)
    for r in results.values():
        # Error x time (relMSE falls as 1 / time for unbiased estimators): the spp that fill the
        # budget come from a short calibration render, and this takes its inaccuracy out.
        r["relmse_x_cpu_s"] = r["relmse_mean"] * float(np.mean(r["cpu_s"]))
        r["mse_x_cpu_s"] = r["rmse_mean"] ** 2 * float(np.mean(r["cpu_s"]))
    if "torrey" in results:
        base = results["torrey"]
        for name, r in results.items():
            rel = r["relmse_x_cpu_s"] / base["relmse_x_cpu_s"]
            mse = r["mse_x_cpu_s"] / base["mse_x_cpu_s"]
            print("%-28s at equal CPU time: relMSE / torrey's %.2f (its square root %.2f), "
                  "RMSE / torrey's %.2f" % (name, rel, np.sqrt(rel), np.sqrt(mse)))
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump({"reference_spp": a.ref_spp, "reference_mean": ref.mean((0, 1)).round(4).tolist(),
                   "budget_cpu_s": a.budget, "results": results}, f, indent=2)


if __name__ == "__main__":
    main()
