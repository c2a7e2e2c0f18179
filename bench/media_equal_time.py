#!/usr/bin/env python3
"""Participating media: speed at equal spp against Mitsuba 3, and error at equal time on a sparse
heterogeneous medium (issue 32's goal: at least 3x lower error than Mitsuba and than torrey's own
global-majorant tracking).

    tests/mitsuba/.venv/bin/python bench/media_equal_time.py [--torrey target/release/torrey]
        [--budget 20] [--ref-spp 4096] [--out DIR] [--speed [SCENE.xml ...]]

--speed: instead, the CPU seconds of torrey (independent samples, like Mitsuba's) and of Mitsuba
(llvm_ad_rgb, its kernel compiled by a first 1-spp render) at equal spp on the given scenes
(default: the media verdict scenes and the media scenes of ../shared/scenes/mitsuba-real).

Equal time is measured in process CPU seconds (all threads; robust to other load on a shared
machine): each method renders a few spp to measure its CPU seconds per spp, then renders the spp
that fill the budget. Error is the RMSE over pixels and channels against a reference rendered by
torrey at --ref-spp with its default sampler (checked against Mitsuba's mean).

The scene (written to --out): a 64^3 cloud of our own in a null cube, about 5% of the voxels
occupied, densities up to 40 per unit length (strong contrast), under a rectangular light and a
dim sky, `volpath` max_depth 16. Compared:
  torrey            majorant grid (default), Sobol samples
  torrey global     TORREY_MAJORANT_GRID=1 (one majorant, Mitsuba's tracking), Sobol
  torrey indep      majorant grid, independent samples (the noise of the estimator alone)
  Mitsuba 3.9.1     llvm_ad_rgb (global majorant, delta tracking)
"""
import argparse
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


def read_exr(path):
    import mitsuba as mi
    b = mi.Bitmap(path)
    names = [b.struct_()[i].name for i in range(b.channel_count())]
    a = np.array(b).astype(np.float64)
    idx = [names.index(c) for c in "RGB"] if "R" in names else [0, 1, 2]
    return a[..., idx]


def torrey(exe, xml, spp, out, env=None, sampler=None, seed=0):
    """Renders with torrey; returns CPU seconds of the child (all threads)."""
    cmd = [exe, xml, "--spp", str(spp), "--seed", str(seed), "-o", out, "--quiet", "--no-mipmap"]
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


def rmse(a, b):
    return float(np.sqrt(((a - b) ** 2).mean()))


SPEED_SCENES = [(os.path.join(REPO, "tests", "scenes", "mitsuba", n + ".xml"), 256) for n in [
    "media_homogeneous_env", "media_grid", "media_chromatic_hg", "media_emitter_inside",
    "media_dielectrics", "media_roughdielectric_spot", "media_camera_fog"]] + [
    (os.path.join(REPO, "..", "shared", "scenes", "mitsuba-real", p), spp) for p, spp in [
        ("volumetric-caustic/scene_v3.xml", 16),
        ("bunny-sss/docs/scenes/medium_homogeneous_sss.xml", 16),
        ("clover-banner/scene.xml", 16)]]


def speed(exe, scenes, out):
    """Equal spp: CPU seconds of torrey and of Mitsuba per scene."""
    for xml, spp in scenes:
        if not os.path.exists(xml):
            continue
        t = torrey(exe, xml, spp, os.path.join(out, "speed_torrey.exr"), sampler="independent")
        m = mitsuba(xml, spp, os.path.join(out, "speed_mitsuba.exr"))
        print("%-52s %4d spp  torrey %7.1f CPU s  Mitsuba %7.1f CPU s  Mitsuba / torrey %.2f" % (
            os.path.relpath(xml, REPO), spp, t, m, m / t), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--torrey", default=os.path.join(REPO, "target", "release", "torrey"))
    ap.add_argument("--budget", type=float, default=20.0, help="CPU seconds per method")
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--out", default="/tmp/torrey-media-bench")
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
    ref_path = os.path.join(a.out, "ref.exr")
    if not os.path.exists(ref_path):
        cpu = torrey(a.torrey, xml, a.ref_spp, ref_path, seed=99)
        print("reference: torrey %d spp (Sobol), %.0f CPU s" % (a.ref_spp, cpu))
    ref = read_exr(ref_path)
    results = {}
    methods = [
        ("torrey", lambda spp, out: torrey(a.torrey, xml, spp, out)),
        ("torrey global majorant",
         lambda spp, out: torrey(a.torrey, xml, spp, out, env={"TORREY_MAJORANT_GRID": "1"})),
        ("torrey independent", lambda spp, out: torrey(a.torrey, xml, spp, out, sampler="independent")),
        ("torrey global, independent",
         lambda spp, out: torrey(a.torrey, xml, spp, out, env={"TORREY_MAJORANT_GRID": "1"},
                                 sampler="independent")),
        ("Mitsuba 3.9.1", lambda spp, out: mitsuba(xml, spp, out)),
    ]
    for name, run in methods:
        calib = 8
        out = os.path.join(a.out, name.replace(" ", "_").replace(",", "") + ".exr")
        cpu = run(calib, out)
        spp = max(1, int(a.budget / (cpu / calib)))
        cpu = run(spp, out)
        err = rmse(read_exr(out), ref)
        results[name] = {"spp": spp, "cpu_s": round(cpu, 2), "cpu_s_per_spp": round(cpu / spp, 4),
                         "rmse": err, "mean": read_exr(out).mean((0, 1)).round(4).tolist()}
        print("%-28s %5d spp  %6.1f CPU s  (%.3f CPU s/spp)  RMSE %.5f  mean %s" % (
            name, spp, cpu, cpu / spp, err, results[name]["mean"]), flush=True)
    base = results["torrey"]["rmse"]
    for name, r in results.items():
        print("%-28s error / torrey's: %.2f" % (name, r["rmse"] / base))
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump({"reference_mean": ref.mean((0, 1)).round(4).tolist(), "results": results}, f,
                  indent=2)


if __name__ == "__main__":
    main()
