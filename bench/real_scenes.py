#!/usr/bin/env python3
"""torrey against Mitsuba 3 (llvm_ad_rgb) on real scenes: speed at equal spp and error at equal time,
both renderers in one run, on ../shared/scenes/mitsuba-real (scenes other people wrote, with
Mitsuba 3.9.1 references) and on the four benchmark scenes of docs/performance.md.

One command, from the repository root:
    python3 bench/real_scenes.py                         # every scene, 3 runs each, 64 spp
    python3 bench/real_scenes.py --only veach-direct,cbox --runs 5 --spp 256
Other options: --threads N (default: all cores, both renderers), --no-build, --torrey-bin PATH,
--torrey-arg ARG (repeatable, e.g. --torrey-arg=--sampler=independent), --json PATH,
--mitsuba-scalar (Mitsuba's scalar_rgb variant too, one render per run: how much of the gap is
Mitsuba's 16-lane kernels rather than its algorithms).

What it measures (the numbers of docs/performance.md's table):
  * speed: torrey's whole process (wall: parse, build, render, EXR + PNG writing) against
    Mitsuba's load + render in a fresh process (bench/mitsuba_child.py), as a user waits for them.
    Mitsuba's first render compiles its kernels (drjit's on-disk cache is cold: HOME is an empty
    folder), so two Mitsuba times are kept: `cold` = load + first render, `warm` = load + a second
    render in the same process (the kernel cached). speed = Mitsuba time / torrey time (above 1:
    torrey is faster); the table's headline is the warm one, the harder target. Runs alternate
    torrey, Mitsuba, torrey, ...; medians of --runs.
  * error at equal time: relMSE = mean over pixels and channels of (img - ref)^2 / (ref^2 + 0.01)
    with the worst 0.1% of pixel terms left out (a few fireflies would otherwise decide it), minus
    the reference's own noise (its `_var` map, the variance of its mean, where there is one);
    efficiency = relMSE x seconds (the time above). ratio = Mitsuba's / torrey's: above 1, torrey
    reaches a given error sooner. torrey runs with its defaults (Sobol samples), Mitsuba with the
    scene's (independent). Each render's relMSE is the mean over --runs seeds.
  * references: the mitsuba-real scenes' own (refs/<scene>.exr, 256-1024 spp Mitsuba renders); the
    four benchmark scenes get a torrey render at --ref-spp, cached in out/bench/ref/.
  * recorded: CPU model, torrey's SIMD level (its summary line), Mitsuba's kernel width and target
    (bench/common.py mitsuba_llvm_simd), load averages before each run.
Writes out/bench/real_<date>.json and out/bench/real_latest.json.
"""
import argparse
import datetime
import json
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import REPO, SHARED, OUT, log  # noqa: E402

REAL = os.path.join(SHARED, "scenes", "mitsuba-real")
# name: (scene XML, refs/<name> or None)
REAL_SCENES = {
    "staircase": "staircase/scene.xml",
    "matpreview-copper": "matpreview-copper/docs/scenes/bsdf_roughconductor_copper.xml",
    "matpreview-glass": "matpreview-glass/docs/scenes/bsdf_dielectric_glass.xml",
    "stage-lights": "stage-lights/bunny.xml",
    "veach-direct": "veach-direct/docs/scenes/integrator_direct_both.xml",
    "volumetric-caustic": "volumetric-caustic/scene_v3.xml",
    "bunny-sss": "bunny-sss/docs/scenes/medium_homogeneous_sss.xml",
    "clover-banner": "clover-banner/scene.xml",
}
# The four benchmark scenes (torrey course dialect): converted for Mitsuba as bench/compare_mitsuba.py
# does. name: (scene, width, height, max depth)
BENCH_SCENES = {
    "cbox": (os.path.join(SHARED, "scenes", "torrey", "cbox", "cbox.xml"), 512, 512, 8),
    "textured_mesh": (os.path.join(REPO, "scenes", "textured_mesh.xml"), None, None, 8),
    "envmap_sky": (os.path.join(REPO, "scenes", "envmap_sky.xml"), None, None, 8),
    "living_room": (os.path.join(SHARED, "scenes", "torrey", "living-room-Wig42",
                                 "scene_bgonly_available.xml"), 640, 360, 2),
}


def rel_mse(img, ref, var=None, drop=0.001):
    """relMSE with the worst `drop` share of pixel terms left out, minus the reference's noise."""
    import numpy as np
    terms = ((img - ref) ** 2 / (ref ** 2 + 1e-2)).mean(axis=2).ravel()
    keep = max(1, int(round(terms.size * (1.0 - drop))))
    order = np.argsort(terms)[:keep]
    value = float(terms[order].mean())
    if var is not None:
        noise = (var / (ref ** 2 + 1e-2)).mean(axis=2).ravel()
        value -= float(noise[order].mean())
    return max(value, 0.0)


def torrey_run(scene, spp, seed, threads, out_exr, extra, size=None, depth=None):
    cmd_extra = list(extra)
    cmd = [common.TORREY, scene, "-o", out_exr, "--spp", str(spp), "--threads", str(threads),
           "--seed", str(seed), "--quiet"] + cmd_extra
    if size:
        cmd += ["--size", "%dx%d" % size]
    if depth is not None:
        cmd += ["--max-depth", str(depth)]
    la = common.loadavg()
    p, rss, wall = common.timed_process(cmd)
    if p.returncode != 0:
        raise RuntimeError("torrey failed (%s):\n%s" % (" ".join(cmd), p.stderr[-2000:]))
    m = common.SUMMARY_RE.search(p.stderr)
    return {"wall_s": wall, "simd": m.group("simd") if m else None,
            "render_cpu_s": float(m.group("render_cpu")) if m and m.group("render_cpu") else None,
            "load_s": float(m.group("load")) if m else None,
            "build_s": float(m.group("build")) if m else None, "loadavg": la, "rss_mb": rss}


def mitsuba_run(xml, spp, seed, threads, out_exr, plugins):
    """`plugins`: the scene was converted from the torrey course and may use torrey's Python
    BSDF plugins (tests/mitsuba/torrey_bsdfs.py)."""
    r = common.run_mitsuba("llvm_ad_rgb", xml, spp, threads, seed, plugins=plugins, warm=True,
                           out_exr=out_exr)
    return {"cold_s": r["load_s"] + r["first_render_s"], "warm_s": r["load_s"] + r["warm_render_s"],
            "load_s": r["load_s"], "loadavg": r["loadavg_before"]}


def mitsuba_scalar_run(xml, spp, seed, threads, plugins):
    """Mitsuba's scalar_rgb variant (one path at a time, as torrey's scalar loop): load + render,
    in a fresh process (no kernel to compile, so one render)."""
    r = common.run_mitsuba("scalar_rgb", xml, spp, threads, seed, plugins=plugins, warm=False)
    return {"s": r["load_s"] + r["first_render_s"], "load_s": r["load_s"],
            "loadavg": r["loadavg_before"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--ref-spp", type=int, default=1024, help="torrey reference of the four")
    ap.add_argument("--only")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--torrey-bin")
    ap.add_argument("--torrey-arg", action="append", default=[])
    ap.add_argument("--json")
    ap.add_argument("--mitsuba-scalar", action="store_true")
    a = ap.parse_args()
    common.setup_mitsuba()
    common.reexec_in_venv()
    import numpy as np  # noqa: F401  (venv)
    if a.torrey_bin:
        common.TORREY = os.path.abspath(a.torrey_bin)
    elif not a.no_build:
        common.build_torrey()
    common.ensure_gnu_time()
    only = set(a.only.split(",")) if a.only else None
    work = os.path.join(OUT, "real")
    os.makedirs(work, exist_ok=True)
    result = {"date": datetime.datetime.now().isoformat(timespec="seconds"), "rev": common.git_rev(),
              "cpu": common.cpu_name(), "threads": a.threads, "spp": a.spp, "runs": a.runs,
              "mitsuba_simd": common.mitsuba_llvm_simd(), "torrey_args": a.torrey_arg, "scenes": {}}
    log("CPU %s; Mitsuba kernels %s" % (result["cpu"], result["mitsuba_simd"]))

    jobs = []
    for name, rel in REAL_SCENES.items():
        if only and name not in only:
            continue
        xml = os.path.join(REAL, rel)
        ref = os.path.join(REAL, "refs", name + ".exr")
        jobs.append((name, xml, xml, None, None, ref, ref.replace(".exr", "_var.exr")))
    for name, (scene, w, h, depth) in BENCH_SCENES.items():
        if only and name not in only:
            continue
        if w is None:
            w, h = common.film_size(scene)
        mxml = os.path.join(work, name + "_mitsuba.xml")
        common.convert_scene(scene, w, h, a.spp, depth, mxml)
        ref = os.path.join(OUT, "ref", "%s_%dx%d_d%d_%d.exr" % (name, w, h, depth, a.ref_spp))
        if not os.path.exists(ref):
            os.makedirs(os.path.dirname(ref), exist_ok=True)
            log("%s: torrey reference at %d spp" % (name, a.ref_spp))
            torrey_run(scene, a.ref_spp, 100, a.threads, ref, ["--sampler", "independent"],
                       (w, h), depth)
        jobs.append((name, scene, mxml, (w, h), depth, ref, None))

    for name, scene, mxml, size, depth, ref, var in jobs:
        log("== %s" % name)
        entry = {"torrey": [], "mitsuba": [], "torrey_relmse": [], "mitsuba_relmse": [],
                 "mitsuba_scalar": []}
        ref_img = common.read_exr(ref)
        var_img = common.read_exr(var) if var and os.path.exists(var) else None
        for run in range(a.runs):
            seed = 7 + run
            t_out = os.path.join(work, "%s_torrey_%d.exr" % (name, run))
            m_out = os.path.join(work, "%s_mitsuba_%d.exr" % (name, run))
            try:
                t = torrey_run(scene, a.spp, seed, a.threads, t_out, a.torrey_arg, size, depth)
            except RuntimeError as e:
                entry["torrey_error"] = str(e).splitlines()[-1]
                log("   torrey failed: %s" % entry["torrey_error"])
                break
            m = mitsuba_run(mxml, a.spp, seed, a.threads, m_out, plugins=mxml != scene)
            if a.mitsuba_scalar:
                try:
                    entry["mitsuba_scalar"].append(
                        mitsuba_scalar_run(mxml, a.spp, seed, a.threads, plugins=mxml != scene))
                except RuntimeError as e:
                    # torrey's course BSDFs as Python plugins divide Python floats in scalar
                    # variants, where a zero pdf raises (drjit's lanes give inf and select it away).
                    entry["mitsuba_scalar_error"] = str(e).splitlines()[-1]
                    log("   mitsuba scalar failed: %s" % entry["mitsuba_scalar_error"])
            entry["torrey"].append(t)
            entry["mitsuba"].append(m)
            entry["torrey_relmse"].append(rel_mse(common.read_exr(t_out), ref_img, var_img))
            entry["mitsuba_relmse"].append(rel_mse(common.read_exr(m_out), ref_img, var_img))
            log("   run %d: torrey %.2f s (%s), mitsuba cold %.2f s warm %.2f s; relMSE %.4g / %.4g"
                % (run, t["wall_s"], t["simd"], m["cold_s"], m["warm_s"], entry["torrey_relmse"][-1],
                   entry["mitsuba_relmse"][-1]))
        if entry["torrey"]:
            med = lambda xs: statistics.median(xs)  # noqa: E731
            tt = med([r["wall_s"] for r in entry["torrey"]])
            cold = med([r["cold_s"] for r in entry["mitsuba"]])
            warm = med([r["warm_s"] for r in entry["mitsuba"]])
            te, me = statistics.mean(entry["torrey_relmse"]), statistics.mean(entry["mitsuba_relmse"])
            entry.update(torrey_s=tt, mitsuba_cold_s=cold, mitsuba_warm_s=warm,
                         speed_warm=warm / tt, speed_cold=cold / tt,
                         eff_ratio_warm=(me * warm) / max(te * tt, 1e-30),
                         simd=entry["torrey"][0]["simd"])
            if entry["mitsuba_scalar"]:
                scalar = med([r["s"] for r in entry["mitsuba_scalar"]])
                entry.update(mitsuba_scalar_s=scalar, speed_scalar=scalar / tt)
        result["scenes"][name] = entry
        # Written after every scene, so that a failure later keeps what was measured.
        path = a.json or os.path.join(OUT, "real_%s.json" % datetime.date.today().isoformat())
        for p in (path, os.path.join(OUT, "real_latest.json")):
            with open(p, "w") as f:
                json.dump(result, f, indent=1)
    print_table(result)
    log("wrote %s" % path)


def print_table(result):
    print("CPU: %s; %d threads; %d spp; Mitsuba llvm_ad_rgb kernels: %s; torrey args %s; rev %s"
          % (result["cpu"], result["threads"], result["spp"], result["mitsuba_simd"],
             result["torrey_args"] or "(defaults)", result["rev"]))
    scalar = any("mitsuba_scalar_s" in e for e in result["scenes"].values())
    print("| scene | torrey SIMD | torrey s | Mitsuba s (warm / cold) | speed warm (cold) | "
          "relMSE torrey / Mitsuba | equal-time ratio |"
          + (" Mitsuba scalar s | speed vs scalar |" if scalar else ""))
    print("| --- | --- | --- | --- | --- | --- | --- |" + (" --- | --- |" if scalar else ""))
    for name, e in result["scenes"].items():
        if "torrey_s" not in e:
            print("| %s | - | %s | | | | |" % (name, e.get("torrey_error", "no run")))
            continue
        row = "| %s | %s | %.2f | %.2f / %.2f | **%.2f** (%.2f) | %.3g / %.3g | **%.2f** |" % (
            name, e["simd"], e["torrey_s"], e["mitsuba_warm_s"], e["mitsuba_cold_s"],
            e["speed_warm"], e["speed_cold"], statistics.mean(e["torrey_relmse"]),
            statistics.mean(e["mitsuba_relmse"]), e["eff_ratio_warm"])
        if "mitsuba_scalar_s" in e:
            row += " %.2f | %.2f |" % (e["mitsuba_scalar_s"], e["speed_scalar"])
        elif scalar:
            row += " - | - |"
        print(row)


if __name__ == "__main__":
    main()
