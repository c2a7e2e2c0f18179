#!/usr/bin/env python3
"""Equal-time error: torrey and Mitsuba 3 (llvm_ad_rgb) each render for the same render-time budget;
their relative RMSE against a high-spp reference is compared.

One command, from the repository root:
    python3 bench/equal_time_error.py                      # cbox + textured_mesh, 2 s budget
    python3 bench/equal_time_error.py --budget 10 --ref-spp 4096 --only cbox,envmap_sky
Options: --budget SECONDS (render time per renderer, default 2), --ref-spp N (default 1024; 8192
for envmap_sky), --repeats N (renders per renderer with seeds 7, 8, ...; default 1), --threads N,
--no-build, --torrey-mipmap, --only NAME[,NAME].

How:
  * Reference: torrey at --ref-spp, rendered as two halves with seeds 100 and 101 and averaged
    (cached in out/bench/ref/). The halves' difference estimates the reference's own error
    (ref_noise_rel_rmse = relRMSE(a, b) / 2), which floors both renderers' numbers.
    torrey runs with --no-mipmap here unless --torrey-mipmap: with mip-mapping torrey converges to
    a slightly blurrier image than Mitsuba in minified texture regions, which would count as
    Mitsuba error against a torrey reference.
  * torrey: a calibration run (spp grown until it takes >= 0.3 s) gives samples/s; then
    spp = budget x rate / pixels, --repeats runs, seeds 7, 8, ...
  * Mitsuba llvm_ad_rgb (bench/mitsuba_child.py --budget-s): in one process, two calibration renders
    (the first compiles the kernel), samples/s from the warm one, then spp = budget x rate / pixels,
    --repeats runs (seeds 7, 8, ...), each calibrated in its own process. The budget therefore excludes Mitsuba's JIT compilation and scene load, and torrey's
    scene load and BVH build: it is render time only, for both.
  * relRMSE = sqrt(mean((img - ref)^2 / (ref^2 + 0.01))) over pixels and RGB channels.
    With --repeats N, relRMSE^2 is the mean of the N renders' relRMSE^2 (the expected squared
    error; heavy-tailed scenes such as envmap_sky, where rare caustic paths through the mirror
    sphere to the sun dominate, need several: single runs of it scattered by 2x).
    rel_rmse_ref_corrected (JSON) = sqrt(relRMSE^2 - ref_noise^2). Also printed: the ratio
    mitsuba/torrey of (corrected relRMSE)^2 x seconds actually used (relMSE x time is the inverse efficiency;
    a ratio above 1 means torrey is more efficient; it does not depend on the exact time used as
    long as the error is noise-dominated).
Writes out/bench/equal_time_<date>.json and equal_time_latest.json.
"""
import argparse
import datetime
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import REPO, SHARED, OUT, log  # noqa: E402

# name: (scene, width or None = film size, height, max depth)
SCENES = {
    "cbox": (os.path.join(SHARED, "scenes", "torrey", "cbox", "cbox.xml"), 256, 256, 8),
    "textured_mesh": (os.path.join(REPO, "scenes", "textured_mesh.xml"), None, None, 8),
    "envmap_sky": (os.path.join(REPO, "scenes", "envmap_sky.xml"), None, None, 8),
    # Half the benchmark's 640x360, to keep the 1024-spp reference affordable; `direct` = depth 2.
    "living_room": (os.path.join(SHARED, "scenes", "torrey", "living-room-Wig42", "scene_bgonly_available.xml"),
                    320, 180, 2),
}
SEED = 7
# Scenes whose error is dominated by rare, bright paths need a quieter reference than --ref-spp.
REF_SPP_MIN = {"envmap_sky": 8192}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--budget", type=float, default=2.0, help="render seconds per renderer (default 2)")
    ap.add_argument("--ref-spp", type=int, default=1024, help="torrey reference spp (default 1024)")
    ap.add_argument("--only", default="cbox,textured_mesh", help="scenes: " + ",".join(SCENES))
    ap.add_argument("--repeats", type=int, default=1, help="renders per renderer (seeds 7, 8, ...; default 1)")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--torrey-mipmap", action="store_true", help="keep torrey's mip-mapping on")
    a = ap.parse_args()

    mitsuba_line = common.setup_mitsuba()
    common.reexec_in_venv()
    common.ensure_gnu_time()
    if not a.no_build:
        common.build_torrey()
    work = os.path.join(OUT, "equal_time")
    ref_dir = os.path.join(OUT, "ref")
    os.makedirs(work, exist_ok=True)
    os.makedirs(ref_dir, exist_ok=True)
    extra = [] if a.torrey_mipmap else ["--no-mipmap"]
    result = {"generator": "bench/equal_time_error.py", "date": datetime.datetime.now().isoformat(timespec="seconds"),
              "git": common.git_rev(), "mitsuba": mitsuba_line, "threads": a.threads, "budget_s": a.budget,
              "ref_spp": a.ref_spp, "repeats": a.repeats, "torrey_args": extra, "loadavg_start": common.loadavg(), "scenes": {},
              "skipped": {}, "cpu": common.cpu_name(), "mitsuba_llvm_simd": common.mitsuba_llvm_simd(),
              "torrey_simd": None}
    log("load average at start: %s" % result["loadavg_start"])

    for name in a.only.split(","):
        path, w, h, depth = SCENES[name]
        if not os.path.exists(path):
            result["skipped"][name] = "scene file not found"
            log("skip %s: %s not found" % (name, path))
            continue
        if w is None:
            w, h = common.film_size(path)
        pixels = w * h
        log("== %s %dx%d depth %d, budget %.1f s" % (name, w, h, depth, a.budget))

        # reference (two halves)
        ref_spp = max(a.ref_spp, REF_SPP_MIN.get(name, 0))
        tag = "%s_%dx%d_d%d_%dspp%s" % (name, w, h, depth, ref_spp, "_mip" if a.torrey_mipmap else "")
        halves = []
        for k in (0, 1):
            exr = os.path.join(ref_dir, "%s_half%d.exr" % (tag, k))
            if not os.path.exists(exr):
                log("  reference half %d: torrey %d spp" % (k, ref_spp // 2))
                common.run_torrey(path, w, h, max(1, ref_spp // 2), depth, a.threads, 100 + k, exr, extra)
            halves.append(common.read_exr(exr))
        ref = 0.5 * (halves[0] + halves[1])
        ref_noise = common.rel_rmse(halves[0], halves[1]) / 2

        # torrey: calibrate, then render for the budget
        spp = 4
        while True:
            cal = common.run_torrey(path, w, h, spp, depth, a.threads, 1, os.path.join(work, "cal.exr"), extra)
            if cal["render_s"] >= 0.3 or spp >= 4096:
                break
            spp *= 4
        t_rate = pixels * spp / max(cal["render_s"], 1e-3)
        t_spp = max(1, int(a.budget * t_rate / pixels))
        t_runs = []
        for r in range(a.repeats):
            t_exr = os.path.join(work, "%s_torrey_%d.exr" % (name, r))
            tr = common.run_torrey(path, w, h, t_spp, depth, a.threads, SEED + r, t_exr, extra)
            tr["rel_rmse"] = common.rel_rmse(common.read_exr(t_exr), ref)
            t_runs.append(tr)
        result["torrey_simd"] = "%s, %s-wide BVH" % (tr.get("simd"), tr.get("bvh_width"))
        t_err = mean_rms([t["rel_rmse"] for t in t_runs])

        # mitsuba llvm: calibrate and render inside one process
        xml = os.path.join(work, name + "_mitsuba.xml")
        info = common.convert_scene(path, w, h, 4, depth, xml)
        m_runs = []
        for r in range(a.repeats):
            m_exr = os.path.join(work, "%s_mitsuba_llvm_%d.exr" % (name, r))
            mr = common.run_mitsuba_budget("llvm_ad_rgb", xml, a.budget, a.threads, SEED + r,
                                           bool(info["plugins"]), m_exr)
            mr["rel_rmse"] = common.rel_rmse(common.read_exr(m_exr), ref)
            m_runs.append(mr)
        m_err = mean_rms([m["rel_rmse"] for m in m_runs])

        e = {"scene": os.path.relpath(path, REPO), "width": w, "height": h, "max_depth": depth,
             "ref_spp": ref_spp, "ref_noise_rel_rmse": ref_noise, "mitsuba_plugins": info["plugins"],
             "torrey": {"spp": t_spp, "render_s": mean([t["render_s"] for t in t_runs]), "rel_rmse": t_err,
                        "rel_rmse_runs": [t["rel_rmse"] for t in t_runs],
                        "calib_msamples_s": t_rate / 1e6, "loadavg_before": tr["loadavg_before"]},
             "mitsuba_llvm": {"spp": mr["spp"], "render_s": mean([m["render_s"] for m in m_runs]), "rel_rmse": m_err,
                              "rel_rmse_runs": [m["rel_rmse"] for m in m_runs],
                              "calib_msamples_s": pixels * mr["calib_spp"] / mr["calib_warm_s"] / 1e6,
                              "jit_first_render_s": mr["first_render_s"], "loadavg_before": mr["loadavg_before"]}}
        for k in ("torrey", "mitsuba_llvm"):
            # the reference's own noise removed in quadrature (it is independent of both renders)
            e[k]["rel_rmse_ref_corrected"] = max(0.0, e[k]["rel_rmse"] ** 2 - ref_noise ** 2) ** 0.5
            e[k]["rel_mse_x_s"] = e[k]["rel_rmse_ref_corrected"] ** 2 * e[k]["render_s"]
        e["rel_mse_x_s_ratio_mitsuba_over_torrey"] = e["mitsuba_llvm"]["rel_mse_x_s"] / e["torrey"]["rel_mse_x_s"]
        result["scenes"][name] = e
        log("  torrey  %5d spp %6.2f s relRMSE %.4f | mitsuba-llvm %5d spp %6.2f s relRMSE %.4f | ref noise %.4f" % (
            t_spp, e["torrey"]["render_s"], t_err, mr["spp"], e["mitsuba_llvm"]["render_s"], m_err, ref_noise))

    result["loadavg_end"] = common.loadavg()
    print("equal-time error, budget %.1f s render time each, %d run(s) each, %d threads, reference torrey >= %d spp%s; "
          "load avg start %s end %s" % (a.budget, a.repeats, a.threads, a.ref_spp, " (no mip-mapping)" if extra else "",
                                        result["loadavg_start"], result["loadavg_end"]))
    print("CPU %s; SIMD: torrey %s; Mitsuba llvm kernels %s" % (
        result["cpu"], result["torrey_simd"], result["mitsuba_llvm_simd"]))
    print("%-14s %9s %8s %9s | %9s %8s %9s | %9s %12s" % (
        "scene", "torrey spp", "s", "relRMSE", "llvm spp", "s", "relRMSE", "ref noise", "relMSE*s m/t"))
    for name, e in result["scenes"].items():
        t, m = e["torrey"], e["mitsuba_llvm"]
        print("%-14s %9d %8.2f %9.4f | %9d %8.2f %9.4f | %9.4f %12.2f" % (
            name, t["spp"], t["render_s"], t["rel_rmse"], m["spp"], m["render_s"], m["rel_rmse"],
            e["ref_noise_rel_rmse"], e["rel_mse_x_s_ratio_mitsuba_over_torrey"]))
    stamp = datetime.datetime.now().strftime("%Y%m%d_%H%M%S")
    for p in (os.path.join(OUT, "equal_time_%s.json" % stamp), os.path.join(OUT, "equal_time_latest.json")):
        with open(p, "w") as f:
            json.dump(result, f, indent=1)
            f.write("\n")
    log("wrote out/bench/equal_time_%s.json (and equal_time_latest.json)" % stamp)


def mean(xs):
    return sum(xs) / len(xs)


def mean_rms(errors):
    """The root of the mean squared error over runs: relRMSE of the expected squared error."""
    return mean([x * x for x in errors]) ** 0.5


if __name__ == "__main__":
    main()
