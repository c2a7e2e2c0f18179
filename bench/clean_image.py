#!/usr/bin/env python3
"""Time to a clean image (issue 33's measurements) on ../shared/scenes/mitsuba-real, against the
scenes' Mitsuba 3.9.1 references:

  * denoised: 16 spp with --denoise against raw 256 spp, relMSE (bench/real_scenes.py's: the
    worst 0.1% of pixel terms left out, the reference's own noise taken off);
  * adaptive: a uniform render of --uniform-spp spp takes T seconds; then --time-limit T with
    --noise-threshold (cap --adaptive-cap spp): efficiency = relMSE x seconds, uniform / adaptive
    (above 1: adaptive reaches an error sooner); also against `timed`, the same time limit without
    a threshold (a uniform render in passes: what the allocation gains, apart from the passes);
  * threshold: --noise-threshold alone (cap --threshold-cap): the share of pixels whose relative
    standard error (the EXR's variance) is under it, and the mean spp;
  * the denoiser's time on a 1920x1080 image (--denoise-size).

    python3 bench/clean_image.py [--only a,b] [--skip raw256,denoised16,noisy16,adaptive,timed,threshold,fullhd]
                                 [--threshold 0.05] [--no-build] [--torrey-bin PATH]

Besides the mitsuba-real scenes, `interior-openings` (scenes/interior_openings.xml, a room lit
through small openings: uneven noise) against out/refs/interior_openings{,_var}.exr, made by
bench/mitsuba_reference.py (skipped when missing). Times are the renders' wall clock; the
adaptive comparison also gives relMSE x CPU seconds (steadier on a shared machine).

Needs torrey built with the `denoise` feature (bash crates/denoise/install-oidn.sh; the script
builds `cargo build --release --features denoise` unless --no-build) and Mitsuba's venv for
reading EXRs (bench/common.py). Writes out/bench/clean_image_<date>.json.
"""
import argparse
import datetime
import json
import os
import re
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import REPO, SHARED, OUT, log  # noqa: E402
from real_scenes import REAL_SCENES, rel_mse  # noqa: E402

REAL = os.path.join(SHARED, "scenes", "mitsuba-real")
SCENES = ["staircase", "matpreview-copper", "matpreview-glass", "stage-lights", "veach-direct",
          "volumetric-caustic", "bunny-sss", "clover-banner", "interior-openings"]
# Scenes of this repository: scene, reference (made by bench/mitsuba_reference.py).
OWN = {"interior-openings": (os.path.join(REPO, "scenes", "interior_openings.xml"),
                             os.path.join(REPO, "out", "refs", "interior_openings"))}


def channels(path):
    """Every channel of an EXR by name, float64 (H, W)."""
    import numpy as np
    import mitsuba as mi
    if not mi.variant():
        mi.set_variant("scalar_rgb")
    bmp = mi.Bitmap(path)
    names = [f.name for f in bmp.struct_()]
    a = np.array(bmp, copy=False).astype(np.float64)
    if a.ndim == 2:
        a = a[..., None]
    return {n: a[..., i] for i, n in enumerate(names)}


def rgb(ch, prefix=""):
    import numpy as np
    return np.stack([ch[prefix + c] for c in "RGB"], axis=-1)


def relative_errors(ch):
    """The per-pixel relative standard error --noise-threshold bounds (torrey's relative_error)."""
    import numpy as np
    mean = rgb(ch, "noisy." if "noisy.R" in ch else "").mean(axis=-1)
    sd = np.mean([np.sqrt(np.maximum(ch["variance." + c], 0)) for c in "RGB"], axis=0)
    return sd / np.sqrt(mean ** 2 + 0.01)


def torrey(scene, out, *args):
    cmd = [common.TORREY, scene, "-o", out, "--quiet"] + [str(a) for a in args]
    start = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - start
    if p.returncode != 0:
        raise RuntimeError("torrey failed (%s):\n%s" % (" ".join(cmd), p.stderr[-2000:]))
    render = float(re.search(r"render ([0-9.]+) s", p.stderr).group(1))
    cpu = re.search(r"render CPU ([0-9.]+) s", p.stderr)
    dn = re.search(r"denoised in ([0-9.]+) s", p.stderr)
    return {"wall_s": wall, "render_s": render, "cpu_s": float(cpu.group(1)) if cpu else render,
            "denoise_s": float(dn.group(1)) if dn else None,
            "stderr": p.stderr.strip().splitlines()[-3:]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only")
    ap.add_argument("--skip", default="", help="stages to leave out: raw256,denoised16,noisy16,adaptive,timed,threshold,fullhd")
    ap.add_argument("--seeds", type=int, default=2, help="renders per setting (their mean relMSE)")
    ap.add_argument("--uniform-spp", type=int, default=64)
    ap.add_argument("--adaptive-cap", type=int, default=1024)
    ap.add_argument("--threshold", type=float, default=0.05)
    ap.add_argument("--threshold-cap", type=int, default=4096)
    ap.add_argument("--denoise-size", default="1920x1080")
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--torrey-bin")
    a = ap.parse_args()
    common.setup_mitsuba()
    common.reexec_in_venv()
    import numpy as np
    if a.torrey_bin:
        common.TORREY = os.path.abspath(a.torrey_bin)
    elif not a.no_build:
        log("cargo build --release --features denoise")
        subprocess.run(["cargo", "build", "--release", "--quiet", "--features", "denoise"],
                       cwd=REPO, check=True)
    work = os.path.join(OUT, "clean")
    os.makedirs(work, exist_ok=True)
    only = set(a.only.split(",")) if a.only else None
    skip = set(a.skip.split(",")) if a.skip else set()
    result = {"date": datetime.datetime.now().isoformat(timespec="seconds"), "rev": common.git_rev(),
              "cpu": common.cpu_name(), "args": vars(a), "scenes": {}}
    for name in SCENES:
        if only and name not in only:
            continue
        if name in OWN:
            xml, refbase = OWN[name]
            if not os.path.exists(refbase + ".exr"):
                log("== %s: no reference %s.exr (bench/mitsuba_reference.py), skipped" % (name, refbase))
                continue
        else:
            xml, refbase = os.path.join(REAL, REAL_SCENES[name]), os.path.join(REAL, "refs", name)
        ref = rgb(channels(refbase + ".exr"))
        var = rgb(channels(refbase + "_var.exr"))
        out = lambda tag: os.path.join(work, "%s_%s.exr" % (name, tag))  # noqa: E731
        log("== %s (load average %.1f)" % (name, os.getloadavg()[0]))
        e = {}
        try:
            for tag, args, image in [
                ("raw256", ["--spp", 256], ""),
                ("denoised16", ["--spp", 16, "--denoise"], ""),
                ("noisy16", ["--spp", 16], ""),
                ("uniform", ["--spp", a.uniform_spp], ""),
            ]:
                if tag in skip or (tag == "uniform" and "adaptive" in skip):
                    continue
                runs, errs = [], []
                for s in range(a.seeds):
                    runs.append(torrey(xml, out(tag), *args, "--seed", 7 + s))
                    errs.append(rel_mse(rgb(channels(out(tag)), image), ref, var))
                e[tag] = {"relmse": float(np.mean(errs)),
                          "render_s": float(np.median([r["render_s"] for r in runs])),
                          "wall_s": float(np.median([r["wall_s"] for r in runs])),
                          "cpu_s": float(np.median([r["cpu_s"] for r in runs])),
                          "render_s_all": [r["render_s"] for r in runs],
                          "denoise_s": runs[0]["denoise_s"]}
                log("   %-10s relMSE %.4g, render %.2f s%s" % (
                    tag, e[tag]["relmse"], e[tag]["render_s"],
                    ", denoise %.2f s" % runs[0]["denoise_s"] if runs[0]["denoise_s"] else ""))
            if "adaptive" in skip:
                result["scenes"][name] = e
                continue
            budget = e["uniform"]["render_s"]

            def timed(tag, *extra):
                """Renders within the uniform render's time, one per seed; `extra`: the options."""
                runs, errs, spp = [], [], []
                for s in range(a.seeds):
                    runs.append(torrey(xml, out(tag), "--spp", a.adaptive_cap, "--time-limit",
                                       "%.3f" % budget, "--seed", 7 + s, *extra))
                    ch = channels(out(tag))
                    errs.append(rel_mse(rgb(ch), ref, var))
                    spp.append(float(ch["count"].mean()))
                return {"relmse": float(np.mean(errs)), "mean_spp": float(np.mean(spp)),
                        "render_s": float(np.median([r["render_s"] for r in runs])),
                        "cpu_s": float(np.median([r["cpu_s"] for r in runs])),
                        "render_s_all": [r["render_s"] for r in runs], "relmse_all": errs}

            # The same passes without a threshold: a uniform render under the time limit, so that
            # adaptive's allocation is judged apart from what passes under a time limit cost.
            if "timed" not in skip:
                e["timed_uniform"] = timed("timed_uniform")
                log("   timed uniform relMSE %.4g in %.2f s (%.1f spp on average)"
                    % (e["timed_uniform"]["relmse"], e["timed_uniform"]["render_s"],
                       e["timed_uniform"]["mean_spp"]))
            e["adaptive"] = timed("adaptive", "--noise-threshold", a.threshold)
            eff = (e["uniform"]["relmse"] * budget) / (e["adaptive"]["relmse"] * e["adaptive"]["render_s"])
            eff_cpu = (e["uniform"]["relmse"] * e["uniform"]["cpu_s"]) / (e["adaptive"]["relmse"] * e["adaptive"]["cpu_s"])
            e["adaptive"]["efficiency_ratio"] = eff
            e["adaptive"]["efficiency_ratio_cpu"] = eff_cpu
            log("   adaptive   relMSE %.4g in %.2f s (%.1f spp on average): relMSE x s %.2fx better"
                " (x CPU s: %.2fx; uniform %.2f CPU s, adaptive %.2f)"
                % (e["adaptive"]["relmse"], e["adaptive"]["render_s"], e["adaptive"]["mean_spp"], eff,
                   eff_cpu, e["uniform"]["cpu_s"], e["adaptive"]["cpu_s"]))
            if "timed_uniform" in e:
                tu = e["timed_uniform"]
                e["adaptive"]["vs_timed_uniform"] = (tu["relmse"] * tu["render_s"]) / (
                    e["adaptive"]["relmse"] * e["adaptive"]["render_s"])
                log("   adaptive against the timed uniform render: relMSE x s %.2fx better"
                    % e["adaptive"]["vs_timed_uniform"])
            if "threshold" in skip:
                result["scenes"][name] = e
                continue
            t = torrey(xml, out("threshold"), "--spp", a.threshold_cap, "--noise-threshold", a.threshold)
            ch = channels(out("threshold"))
            err = relative_errors(ch)
            e["threshold"] = {"under": float((err < a.threshold).mean()),
                              "under_uncapped": float((err[ch["count"] < a.threshold_cap] < a.threshold).mean())
                              if (ch["count"] < a.threshold_cap).any() else None,
                              "capped": float((ch["count"] >= a.threshold_cap).mean()),
                              "mean_spp": float(ch["count"].mean()), "render_s": t["render_s"],
                              "relmse": rel_mse(rgb(ch), ref, var)}
            log("   threshold  %.1f%% of pixels under %g (%.1f%% at the %d cap; %s%% of the others), "
                "%.0f spp on average, %.1f s"
                % (100 * e["threshold"]["under"], a.threshold, 100 * e["threshold"]["capped"],
                   a.threshold_cap, "%.1f" % (100 * e["threshold"]["under_uncapped"])
                   if e["threshold"]["under_uncapped"] is not None else "-",
                   e["threshold"]["mean_spp"], t["render_s"]))
        except RuntimeError as err:
            e["error"] = str(err).splitlines()[-1]
            log("   failed: %s" % e["error"])
        result["scenes"][name] = e
    # The denoiser alone on a full-HD image (1 spp of the copper scene: its time does not depend
    # on the content).
    if "fullhd" not in skip:
        xml = os.path.join(REAL, REAL_SCENES["matpreview-copper"])
        t = torrey(xml, os.path.join(work, "fullhd.exr"), "--spp", 1, "--size", a.denoise_size, "--denoise")
        result["denoise_fullhd_s"] = t["denoise_s"]
        log("denoising %s: %.2f s" % (a.denoise_size, t["denoise_s"]))
    path = os.path.join(OUT, "clean_image_%s.json" % datetime.datetime.now().strftime("%Y-%m-%dT%H%M"))
    with open(path, "w") as f:
        json.dump(result, f, indent=1)
    log("wrote %s" % path)


if __name__ == "__main__":
    main()
