"""Shared helpers for bench/compare_mitsuba.py and bench/equal_time_error.py.

Standard library only at import time; the Mitsuba child code imports mitsuba lazily.
"""
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
MITSUBA_DIR = os.path.join(REPO, "tests", "mitsuba")
VENV_PY = os.path.join(MITSUBA_DIR, ".venv", "bin", "python")
SHARED = os.environ.get("TORREY_SHARED", os.path.join(os.path.dirname(REPO), "shared"))
TORREY = os.path.join(REPO, "target", "release", "torrey")
OUT = os.path.join(REPO, "out", "bench")
TIME = "/usr/bin/time"

SUMMARY_RE = re.compile(
    r"(?P<w>\d+)x(?P<h>\d+) px, (?P<spp>\d+) spp, max depth (?P<depth>-?\d+), (?P<tris>\d+) triangles[^;]*; "
    r"load (?P<load>[\d.]+) s, build (?P<build>[\d.]+) s, render (?P<render>[\d.]+) s, "
    r"(?P<msps>[\d.]+) M samples/s"
    r"(?:, (?P<mrays>[\d.]+) M rays/s \((?P<closest>\d+) closest \+ (?P<shadow>\d+) shadow\), "
    r"first tile after (?P<first_tile>[\d.]+) s)?"
    r"(?:, (?P<bvh_width>\d+)-wide BVH)?(?:, SIMD (?P<simd>[\w+-]+))?"
    r"(?:, render CPU (?P<render_cpu>[\d.]+) s)?")


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def loadavg():
    return [round(x, 2) for x in os.getloadavg()]


def setup_mitsuba():
    """Runs tests/mitsuba/setup.sh (idempotent) and exports DRJIT_LIBLLVM_PATH from its output."""
    out = subprocess.run(["bash", os.path.join(MITSUBA_DIR, "setup.sh")], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit("tests/mitsuba/setup.sh failed:\n" + out.stdout + out.stderr)
    m = re.search(r"export DRJIT_LIBLLVM_PATH=(\S+)", out.stdout)
    if m:
        os.environ["DRJIT_LIBLLVM_PATH"] = m.group(1)
    return out.stdout.strip().splitlines()[0] if out.stdout.strip() else ""


def reexec_in_venv():
    """Re-runs the calling script under the Mitsuba venv's python (numpy, mitsuba available)."""
    if os.path.realpath(sys.prefix) != os.path.realpath(os.path.join(MITSUBA_DIR, ".venv")):
        os.execv(VENV_PY, [VENV_PY] + sys.argv)


def ensure_gnu_time():
    if os.path.exists(TIME):
        return
    log("installing GNU time (for peak RSS)")
    sudo = [] if os.geteuid() == 0 else ["sudo"]
    if subprocess.run(sudo + ["apt-get", "install", "-y", "-qq", "time"]).returncode != 0:
        subprocess.run(sudo + ["apt-get", "update", "-qq"], check=True)
        subprocess.run(sudo + ["apt-get", "install", "-y", "-qq", "time"], check=True)


def build_torrey():
    log("cargo build --release")
    subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=REPO, check=True)


def git_rev():
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                             text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=REPO,
                               capture_output=True, text=True).stdout.strip()
        return rev + ("-dirty" if dirty else "")
    except OSError:
        return "unknown"


def timed_process(cmd, env=None):
    """Runs cmd under `/usr/bin/time -v`; returns (CompletedProcess, peak_rss_mb, wall_seconds)."""
    fd, tfile = tempfile.mkstemp(prefix="bench_time_", suffix=".txt")
    os.close(fd)
    t0 = time.perf_counter()
    p = subprocess.run([TIME, "-v", "-o", tfile] + cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    rss = None
    with open(tfile) as f:
        for line in f:
            if "Maximum resident set size" in line:
                rss = int(line.split(":")[1]) / 1024.0
    os.unlink(tfile)
    return p, rss, wall


def run_torrey(scene, width, height, spp, depth, threads, seed, out_exr, extra=()):
    """One torrey process; returns a dict with the parsed summary line, peak RSS and wall time."""
    cmd = [TORREY, scene, "-o", out_exr, "--spp", str(spp), "--size", "%dx%d" % (width, height),
           "--max-depth", str(depth), "--threads", str(threads), "--seed", str(seed), "--quiet"] + list(extra)
    la = loadavg()
    p, rss, wall = timed_process(cmd)
    if p.returncode != 0:
        raise RuntimeError("torrey failed (%s):\n%s" % (" ".join(cmd), p.stderr[-3000:]))
    m = SUMMARY_RE.search(p.stderr)
    if not m:
        raise RuntimeError("no summary line in torrey's output:\n" + p.stderr[-3000:])
    d = m.groupdict()
    return {"renderer": "torrey", "render_s": float(d["render"]), "load_s": float(d["load"]),
            "build_s": float(d["build"]), "msamples_s_reported": float(d["msps"]),
            "triangles": int(d["tris"]), "spp": int(d["spp"]), "peak_rss_mb": rss,
            "process_wall_s": round(wall, 3), "loadavg_before": la, "seed": seed,
            "nonfinite_warning": "NaN or infinite" in p.stderr,
            "mrays_s_reported": float(d["mrays"]) if d.get("mrays") else None,
            "rays_closest": int(d["closest"]) if d.get("closest") else None,
            "rays_shadow": int(d["shadow"]) if d.get("shadow") else None,
            "first_tile_s": float(d["first_tile"]) if d.get("first_tile") else None,
            "bvh_width": int(d["bvh_width"]) if d.get("bvh_width") else None,
            "simd": d.get("simd"),
            "render_cpu_s": float(d["render_cpu"]) if d.get("render_cpu") else None}


def mitsuba_llvm_simd():
    """The vector width and target CPU of the kernels Mitsuba's LLVM backend compiles on this
    machine, read from the IR of a tiny kernel (drjit's PrintIR flag): e.g. "16 x f32, znver5"."""
    probe = ("import drjit as dr, mitsuba as mi\n"
             "mi.set_variant('llvm_ad_rgb')\n"
             "dr.set_log_level(dr.LogLevel.Info)\n"
             "dr.set_flag(dr.JitFlag.PrintIR, True)\n"
             "x = dr.arange(mi.Float, 10) + 1\n"
             "dr.eval(x)\n")
    try:
        p = subprocess.run([VENV_PY, "-c", probe], capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.TimeoutExpired) as e:
        return "unknown (%s)" % e
    text = p.stdout + p.stderr
    widths = sorted(set(int(w) for w in re.findall(r"<(\d+) x float>", text)))
    cpu = re.search(r'"target-cpu"="([^"]+)"', text)
    if not widths:
        return "unknown"
    return "%d x f32, %s" % (widths[-1], cpu.group(1) if cpu else "?")


def run_mitsuba_budget(variant, xml, budget_s, threads, seed, plugins, out_exr, calib_spp=4):
    """Equal-time mode of bench/mitsuba_child.py: calibrate (cold + warm render), then render for
    budget_s seconds of warm render time and write out_exr."""
    return run_mitsuba(variant, xml, calib_spp, threads, seed, plugins, warm=False, out_exr=out_exr,
                       extra=["--budget-s", str(budget_s), "--calib-spp", str(calib_spp)])


def run_mitsuba(variant, xml, spp, threads, seed, plugins, warm=True, out_exr=None, cold_cache=True,
                extra=()):
    """One fresh Mitsuba process (bench/mitsuba_child.py) under /usr/bin/time -v.

    cold_cache: HOME points to an empty temporary directory, so drjit's on-disk kernel cache
    (~/.drjit) is empty and the first render includes tracing and LLVM compilation."""
    cmd = [VENV_PY, os.path.join(HERE, "mitsuba_child.py"), "--variant", variant, "--xml", xml,
           "--spp", str(spp), "--threads", str(threads), "--seed", str(seed)]
    if plugins:
        cmd += ["--plugins"]
    if warm:
        cmd += ["--warm"]
    if out_exr:
        cmd += ["--out", out_exr]
    cmd += list(extra)
    env = dict(os.environ)
    home = None
    if cold_cache:
        home = tempfile.mkdtemp(prefix="bench_drjit_home_")
        env["HOME"] = home
    la = loadavg()
    try:
        p, rss, wall = timed_process(cmd, env=env)
    finally:
        if home:
            shutil.rmtree(home, ignore_errors=True)
    if p.returncode != 0:
        raise RuntimeError("mitsuba %s failed:\n%s" % (variant, p.stderr[-3000:]))
    # The last line, from its brace: a Mitsuba warning ends with a colour reset that can precede it.
    last = p.stdout.strip().splitlines()[-1]
    r = json.loads(last[last.index("{"):])
    r.update(renderer="mitsuba-" + variant, peak_rss_mb=rss, process_wall_s=round(wall, 3),
             loadavg_before=la, seed=seed)
    return r


def convert_scene(scene, width, height, spp, depth, xml_out):
    """torrey XML -> Mitsuba 3 XML via tests/mitsuba/torrey_to_mitsuba.py; returns its info dict."""
    sys.path.insert(0, MITSUBA_DIR)
    from torrey_to_mitsuba import convert
    text, info = convert(scene, width, height, spp, depth)
    # torrey skips <medium> (warns); Mitsuba's `path` integrator ignores media too, but its parser
    # rejects the course scenes' old-style medium parameters, so drop them here.
    text, n = re.subn(r"\s*<medium\b.*?</medium>", "", text, flags=re.S)
    if n:
        info["conversions"].append("%d <medium> elements dropped (torrey skips media)" % n)
    os.makedirs(os.path.dirname(xml_out), exist_ok=True)
    with open(xml_out, "w") as f:
        f.write(text)
    return info


def film_size(scene):
    import xml.etree.ElementTree as ET
    film = ET.parse(scene).getroot().find("sensor/film")
    get = lambda n: int(next(c.get("value") for c in film if c.get("name") == n))  # noqa: E731
    return get("width"), get("height")


def read_exr(path):
    """Linear RGB float32 array (H, W, 3); needs the venv (mitsuba's Bitmap reader)."""
    import numpy as np
    import mitsuba as mi
    if not mi.variant():
        mi.set_variant("scalar_rgb")
    bmp = mi.Bitmap(path)
    return np.array(bmp, dtype=np.float32)[..., :3]


def rel_rmse(img, ref, eps=1e-2):
    """sqrt(mean((img - ref)^2 / (ref^2 + eps))) over pixels and channels."""
    import numpy as np
    return float(np.sqrt(np.mean((img - ref) ** 2 / (ref ** 2 + eps))))


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()
