#!/usr/bin/env python3
"""Side-by-side render benchmark: torrey against Mitsuba 3 (llvm_ad_rgb, the rival, and scalar_rgb).

One command, from the repository root:
    python3 bench/compare_mitsuba.py                       # full benchmark, 3 runs per renderer
    python3 bench/compare_mitsuba.py --runs 1 --spp-scale 0.125     # smoke test
    python3 bench/compare_mitsuba.py --only cbox,textured_mesh --runs 5
Other options: --threads N (default: all cores, both renderers), --no-build, --no-scalar,
--no-warm, --warm-cache, --torrey-no-mipmap, --torrey-bin PATH (e.g. the PGO build target/pgo/torrey),
--save-images, --json PATH.

What it does (details and the remaining setup differences: docs/performance.md):
  * `bash tests/mitsuba/setup.sh` (idempotent: venv with mitsuba 3.9.1, libLLVM 19), then re-runs
    itself under tests/mitsuba/.venv/bin/python; `cargo build --release`; installs GNU time if
    /usr/bin/time is missing.
  * Each scene is converted with tests/mitsuba/torrey_to_mitsuba.py to a Mitsuba 3 XML with the same
    resolution, spp, max depth, box filter and lights (out/bench/<scene>_mitsuba.xml).
  * Runs alternate: torrey, mitsuba-llvm, mitsuba-scalar, torrey, ... Every run is a fresh process
    under `/usr/bin/time -v` (peak RSS). torrey: its summary line gives load, build and render
    seconds. Mitsuba (bench/mitsuba_child.py): load (mi.load_file) and render (mi.render + dr.eval +
    dr.sync_thread) are timed separately; for llvm the first render in the process includes
    tracing + LLVM compilation (HOME is an empty temporary directory, so drjit's on-disk kernel
    cache is cold) and a second, warm render (seed + 1000) gives the steady-state time. The table's
    llvm column is the warm median; the first-render median is shown beside it. scalar_rgb renders
    once per process (no JIT).
  * Prints a table and writes out/bench/compare_<date>.json (+ compare_latest.json) with every run,
    the load averages before each run, the conversion notes and the image means of both renderers.
"""
import argparse
import datetime
import json
import os
import platform
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import REPO, SHARED, OUT, log  # noqa: E402

# name: (scene path, width or None = film, height, spp, max depth, note)
SCENES = {
    "cbox": (os.path.join(SHARED, "scenes", "torrey", "cbox", "cbox.xml"), 512, 512, 64, 8,
             "shared Cornell box, 38 triangles, diffuse, one area light (headline)"),
    "textured_mesh": (os.path.join(REPO, "scenes", "textured_mesh.xml"), None, None, 64, 8,
                      "checker-textured torus OBJ on a floor, 2 point lights, constant background"),
    "envmap_sky": (os.path.join(REPO, "scenes", "envmap_sky.xml"), None, None, 64, 8,
                   "3 analytic spheres (diffuse, mirror, blinn_microfacet) + ground, lit by a 512x256 sky envmap"),
    "living_room": (os.path.join(SHARED, "scenes", "torrey", "living-room-Wig42", "scene_bgonly_available.xml"),
                    640, 360, 32, 2,
                    "Wig42 living room (~296k triangles, 3 textures), `direct` integrator = max depth 2"),
}


def median(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def fmt(x, f="%.2f"):
    return "-" if x is None else f % x


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3, help="processes per renderer and scene (default 3)")
    ap.add_argument("--spp-scale", type=float, default=1.0, help="multiply every scene's spp (smoke tests)")
    ap.add_argument("--only", help="comma-separated scene names: " + ",".join(SCENES))
    ap.add_argument("--threads", type=int, default=os.cpu_count(), help="threads for both renderers")
    ap.add_argument("--no-build", action="store_true", help="skip cargo build --release")
    ap.add_argument("--no-scalar", action="store_true", help="skip mitsuba scalar_rgb")
    ap.add_argument("--scalar-plugins", action="store_true",
                    help="also run scalar_rgb on scenes that need torrey's Python BSDF plugins (very slow)")
    ap.add_argument("--no-warm", action="store_true", help="llvm: only the first (JIT-compiling) render")
    ap.add_argument("--warm-cache", action="store_true",
                    help="keep drjit's on-disk kernel cache (~/.drjit) instead of an empty one per process")
    ap.add_argument("--torrey-no-mipmap", action="store_true",
                    help="run torrey with --no-mipmap (bilinear full-resolution textures, as Mitsuba)")
    ap.add_argument("--torrey-sampler", default="independent", choices=["independent", "sobol"],
                    help="torrey's sample generator; independent (default) matches Mitsuba's for a "
                         "like-for-like throughput table, sobol is torrey's own default")
    ap.add_argument("--torrey-bin", help="torrey binary to time (default target/release/torrey; "
                    "bench/pgo_build.sh writes the profile-guided build to target/pgo/torrey); "
                    "implies --no-build")
    ap.add_argument("--save-images", action="store_true", help="keep both renderers' EXRs in out/bench/img/")
    ap.add_argument("--json", help="output JSON path (default out/bench/compare_<date>.json)")
    a = ap.parse_args()

    names = a.only.split(",") if a.only else list(SCENES)
    for n in names:
        if n not in SCENES:
            raise SystemExit("unknown scene %s (have %s)" % (n, ", ".join(SCENES)))

    mitsuba_line = common.setup_mitsuba()
    common.reexec_in_venv()  # from here on: tests/mitsuba/.venv's python (numpy, mitsuba)
    common.ensure_gnu_time()
    if a.torrey_bin:
        common.TORREY = os.path.abspath(a.torrey_bin)
    elif not a.no_build:
        common.build_torrey()
    os.makedirs(OUT, exist_ok=True)
    img_dir = os.path.join(OUT, "img")
    os.makedirs(img_dir, exist_ok=True)
    torrey_extra = (["--no-mipmap"] if a.torrey_no_mipmap else []) + ["--sampler", a.torrey_sampler]

    result = {
        "generator": "bench/compare_mitsuba.py",
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "git": common.git_rev(), "host": platform.node(), "cpu": common.cpu_name(), "cores": os.cpu_count(),
        "threads": a.threads, "runs": a.runs, "spp_scale": a.spp_scale, "mitsuba": mitsuba_line,
        "mitsuba_llvm_simd": common.mitsuba_llvm_simd(), "torrey_simd": None,
        "llvm_cache": "warm (~/.drjit kept)" if a.warm_cache else "cold (empty HOME per process)",
        "torrey_args": torrey_extra, "torrey_bin": os.path.relpath(common.TORREY, common.REPO), "loadavg_start": common.loadavg(), "scenes": {}, "skipped": {},
    }
    log("load average at start: %s" % result["loadavg_start"])

    for name in names:
        path, w, h, spp, depth, note = SCENES[name]
        if not os.path.exists(path):
            why = "scene file %s not found" % os.path.relpath(path, REPO)
            log("skip %s: %s" % (name, why))
            result["skipped"][name] = why
            continue
        if w is None:
            w, h = common.film_size(path)
        spp = max(1, round(spp * a.spp_scale))
        xml = os.path.join(OUT, name + "_mitsuba.xml")
        info = common.convert_scene(path, w, h, spp, depth, xml)
        plugins = bool(info["plugins"])
        variants = ["llvm_ad_rgb"]
        scalar_note = None
        if not a.no_scalar:
            if plugins and not a.scalar_plugins:
                scalar_note = "scalar_rgb skipped: needs Python BSDF plugins %s (use --scalar-plugins)" % info["plugins"]
            else:
                variants.append("scalar_rgb")
        entry = {"scene": os.path.relpath(path, REPO), "note": note, "width": w, "height": h, "spp": spp,
                 "max_depth": depth, "conversions": info["conversions"], "mitsuba_plugins": info["plugins"],
                 "scalar_note": scalar_note, "runs": {"torrey": []}}
        for v in variants:
            entry["runs"]["mitsuba-" + v] = []
        log("== %s: %dx%d, %d spp, max depth %d%s" % (name, w, h, spp, depth,
                                                       "; " + scalar_note if scalar_note else ""))
        for i in range(a.runs):
            keep = a.save_images and i == 0
            t_exr = os.path.join(img_dir, "%s_torrey.exr" % name)
            r = common.run_torrey(path, w, h, spp, depth, a.threads, i, t_exr, torrey_extra)
            if i == 0:
                r["mean_rgb"] = [float(x) for x in common.read_exr(t_exr).reshape(-1, 3).mean(axis=0)]
            if not keep:
                for f in (t_exr, t_exr[:-4] + ".png"):
                    if os.path.exists(f):
                        os.unlink(f)
            entry["runs"]["torrey"].append(r)
            result["torrey_simd"] = result["torrey_simd"] or "%s, %s-wide BVH" % (r.get("simd"), r.get("bvh_width"))
            log("  run %d torrey        render %6.2f s  load+build %.2f s  rss %5.0f MB  (load avg %s)" % (
                i, r["render_s"], r["load_s"] + r["build_s"], r["peak_rss_mb"], r["loadavg_before"][0]))
            for v in variants:
                m_exr = os.path.join(img_dir, "%s_mitsuba_%s.exr" % (name, v)) if keep else None
                warm = v.startswith("llvm") and not a.no_warm
                r = common.run_mitsuba(v, xml, spp, a.threads, i, plugins, warm=warm, out_exr=m_exr,
                                       cold_cache=not a.warm_cache)
                r["render_s"] = r["warm_render_s"] if warm else r["first_render_s"]
                r["render_cpu_s"] = r.get("warm_render_cpu_s") if warm else r.get("first_render_cpu_s")
                entry["runs"]["mitsuba-" + v].append(r)
                log("  run %d %-13s render %6.2f s  first %6.2f s  load %.2f s  rss %5.0f MB  (load avg %s)" % (
                    i, v, r["render_s"], r["first_render_s"], r["load_s"], r["peak_rss_mb"],
                    r["loadavg_before"][0]))
        entry["summary"] = summarize(entry)
        result["scenes"][name] = entry

    result["loadavg_end"] = common.loadavg()
    print_table(result)
    path = a.json or os.path.join(OUT, "compare_%s.json" % datetime.datetime.now().strftime("%Y%m%d_%H%M%S"))
    for p in (path, os.path.join(OUT, "compare_latest.json")):
        with open(p, "w") as f:
            json.dump(result, f, indent=1)
            f.write("\n")
    log("wrote %s (and compare_latest.json)" % os.path.relpath(path, REPO))


def summarize(entry):
    samples = entry["width"] * entry["height"] * entry["spp"]
    s = {"samples": samples}
    for key, runs in entry["runs"].items():
        med = median([r["render_s"] for r in runs])
        d = {"render_s_median": med, "render_s_all": [r["render_s"] for r in runs],
             "render_cpu_s_median": median([r.get("render_cpu_s") for r in runs]),
             "msamples_s": samples / med / 1e6 if med else None,
             "peak_rss_mb_max": max(r["peak_rss_mb"] for r in runs),
             "process_wall_s_median": median([r["process_wall_s"] for r in runs]),
             "loadavg_1min": [r["loadavg_before"][0] for r in runs]}
        if key == "torrey":
            d["load_s_median"] = median([r["load_s"] for r in runs])
            d["build_s_median"] = median([r["build_s"] for r in runs])
            d["time_to_render_start_s_median"] = median([r["load_s"] + r["build_s"] for r in runs])
            rays = [r.get("mrays_s_reported") for r in runs if r.get("mrays_s_reported") is not None]
            d["mrays_s_median"] = median(rays) if rays else None
            first = [r["load_s"] + r["build_s"] + r["first_tile_s"] for r in runs
                     if r.get("first_tile_s") is not None]
            # load + BVH build + the first 16x16 tile: when the first final pixels exist
            d["time_to_first_pixel_s_median"] = median(first) if first else None
        else:
            d["load_s_median"] = median([r["load_s"] for r in runs])
            d["import_s_median"] = median([r["import_s"] for r in runs])
            d["first_render_s_median"] = median([r["first_render_s"] for r in runs])
        d["mean_rgb"] = runs[0].get("mean_rgb")
        s[key] = d
    t = s["torrey"]["render_s_median"]
    llvm = s.get("mitsuba-llvm_ad_rgb", {})
    if t and llvm.get("render_s_median"):
        s["ratio_llvm_warm_over_torrey"] = llvm["render_s_median"] / t
        s["ratio_llvm_first_over_torrey"] = llvm["first_render_s_median"] / t
    tc = s["torrey"]["render_cpu_s_median"]
    if tc and llvm.get("render_cpu_s_median"):
        s["ratio_llvm_warm_over_torrey_cpu"] = llvm["render_cpu_s_median"] / tc
    sc = s.get("mitsuba-scalar_rgb", {})
    if t and sc.get("render_s_median"):
        s["ratio_scalar_over_torrey"] = sc["render_s_median"] / t
    tm, mm = s["torrey"]["mean_rgb"], llvm.get("mean_rgb")
    if tm and mm:
        s["image_mean_ratio_mitsuba_over_torrey"] = [m / x if x else None for m, x in zip(mm, tm)]
    return s


def print_table(result):
    hdr = ("scene", "size", "spp", "d", "torrey s", "llvm s", "llvm 1st", "scalar s", "llvm/t",
           "t cpu s", "llvm cpu s", "llvm/t cpu",
           "t Ms/s", "llvm Ms/s", "t MB", "llvm MB", "scal MB")
    rows = []
    for name, e in result["scenes"].items():
        s = e["summary"]
        t, l, sc = s["torrey"], s.get("mitsuba-llvm_ad_rgb", {}), s.get("mitsuba-scalar_rgb", {})
        rows.append((name, "%dx%d" % (e["width"], e["height"]), str(e["spp"]), str(e["max_depth"]),
                     fmt(t["render_s_median"]), fmt(l.get("render_s_median")),
                     fmt(l.get("first_render_s_median")), fmt(sc.get("render_s_median")),
                     fmt(s.get("ratio_llvm_warm_over_torrey")), fmt(t.get("render_cpu_s_median")),
                     fmt(l.get("render_cpu_s_median")), fmt(s.get("ratio_llvm_warm_over_torrey_cpu")),
                     fmt(t["msamples_s"]),
                     fmt(l.get("msamples_s")), fmt(t["peak_rss_mb_max"], "%.0f"),
                     fmt(l.get("peak_rss_mb_max"), "%.0f"), fmt(sc.get("peak_rss_mb_max"), "%.0f")))
    widths = [max(len(str(r[i])) for r in rows + [hdr]) for i in range(len(hdr))]
    line = lambda r: "  ".join(str(c).rjust(wd) if i else str(c).ljust(wd)  # noqa: E731
                               for i, (c, wd) in enumerate(zip(r, widths)))
    print("torrey %s vs %s; %d threads; %d runs each (medians); llvm = warm render, llvm 1st = first "
          "render incl. JIT (%s kernel cache); load avg start %s end %s" % (
              result["git"], result["mitsuba"], result["threads"], result["runs"], result["llvm_cache"],
              result["loadavg_start"], result["loadavg_end"]))
    print("CPU %s; SIMD: torrey %s; Mitsuba llvm kernels %s" % (
        result["cpu"], result["torrey_simd"], result["mitsuba_llvm_simd"]))
    print(line(hdr))
    for r in rows:
        print(line(r))
    for name, why in result["skipped"].items():
        print("skipped %s: %s" % (name, why))
    for name, e in result["scenes"].items():
        s = e["summary"]
        extra = []
        if e["scalar_note"]:
            extra.append(e["scalar_note"])
        if "image_mean_ratio_mitsuba_over_torrey" in s:
            extra.append("image mean mitsuba/torrey = %s" % " ".join(
                fmt(x, "%.3f") for x in s["image_mean_ratio_mitsuba_over_torrey"]))
        t = s["torrey"]
        extra.append("torrey load %.2f s + build %.2f s; mitsuba-llvm load %s s" % (
            t["load_s_median"], t["build_s_median"], fmt(s.get("mitsuba-llvm_ad_rgb", {}).get("load_s_median"))))
        if t.get("mrays_s_median") is not None:
            extra.append("torrey %.2f M rays/s, first pixel after %s s (load + build + first tile)" % (
                t["mrays_s_median"], fmt(t.get("time_to_first_pixel_s_median"), "%.3f")))
        print("  %s: %s" % (name, "; ".join(extra)))


if __name__ == "__main__":
    main()
