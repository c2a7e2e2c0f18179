#!/usr/bin/env python3
"""Texture-only error of torrey's texture filtering against Mitsuba 3 (issue 22's measurement).

Each scene is rendered at max depth 2 twice with the same seed: as is, and with every bitmap
`reflectance` replaced by a white albedo. With direct lighting only, both renders share every
sample's shading estimate, so textured / white is the texture value each pixel's samples looked
up. Its RMSE (over pixels and channels, pixels whose white reference is not black) against the
same ratio from a 4096-spp `--no-mipmap` torrey render (the exact per-pixel average of the
unfiltered, bilinear texture) is the texture error.

  bench/texture_error.py [--scenes checker_sky,textured_mesh] [--spp 1,256] [--ref-spp 4096]
                         [--seed 7] [--before PATH] [--after PATH] [--no-mitsuba] [--threads N]
                         [--reuse-ref]

--before / --after: torrey binaries to compare (default: target/ci/torrey as "after" only; pass
--before with a binary built from the commit before the change, e.g. 5c329e0). `--no-mipmap`
runs use the --after binary. Mitsuba 3 renders the scenes converted by
tests/mitsuba/torrey_to_mitsuba.py (bilinear textures, independent sampler). Runs under
a python with mitsuba (else re-executes itself under tests/mitsuba/.venv's python). Prints a markdown table; images go to
out/texture_error/.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import common  # noqa: E402

REPO = common.REPO
OUT = os.path.join(REPO, "out", "texture_error")


def absolutise(text, base):
    """Relative `filename` values made absolute, so variants can live in a temp directory."""
    def fix(m):
        p = m.group(2)
        return m.group(1) + (p if os.path.isabs(p) else os.path.normpath(os.path.join(base, p))) + '"'
    return re.sub(r'(name="filename"\s+value=")([^"]+)"', fix, text)


def white_variant(text):
    """Every bitmap reflectance (inline or referenced) replaced by a white albedo."""
    text = re.sub(r'<texture type="bitmap" name="reflectance">.*?</texture>',
                  '<rgb name="reflectance" value="1, 1, 1"/>', text, flags=re.S)
    return re.sub(r'<ref name="reflectance" id="[^"]*"/>',
                  '<rgb name="reflectance" value="1, 1, 1"/>', text)


def variants(scene, tmp):
    src = os.path.join(REPO, "scenes", scene + ".xml")
    text = absolutise(open(src).read(), os.path.dirname(src))
    paths = {}
    for kind, t in (("tex", text), ("white", white_variant(text))):
        p = os.path.join(tmp, "%s_%s.xml" % (scene, kind))
        with open(p, "w") as f:
            f.write(t)
        paths[kind] = p
    assert open(paths["tex"]).read() != open(paths["white"]).read(), scene + ": nothing textured"
    return paths


def read_exr(path):
    import mitsuba as mi
    import numpy as np
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def torrey(binary, xml, spp, seed, out, extra, threads):
    cmd = [binary, xml, "--spp", str(spp), "--seed", str(seed), "--max-depth", "2", "--quiet",
           "-o", out] + extra
    if threads:
        cmd += ["--threads", str(threads)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return read_exr(out)


def render_mitsuba(xml_path, spp, seed, out):
    import mitsuba as mi
    sys.path.insert(0, os.path.join(REPO, "tests", "mitsuba"))
    from torrey_to_mitsuba import convert
    text, info = convert(xml_path, spp=spp, max_depth=2)
    # A black <background> becomes a zero-radiance constant emitter, which Mitsuba's light
    # sampling would pick half the time: samples with no information about the texture.
    text = re.sub(r'<emitter type="constant">\s*<rgb name="radiance" value="0(\.0*)?, 0(\.0*)?, 0(\.0*)?"\s*/>\s*</emitter>',
                  "", text)
    if info["plugins"]:
        import torrey_bsdfs
        torrey_bsdfs.register()
    scene = mi.load_string(text)
    img = mi.render(scene, seed=seed, spp=spp)
    mi.Bitmap(img).write(out)
    return read_exr(out)


def ratio(tex, white, mask):
    import numpy as np
    r = np.where(white > 0, tex / np.where(white > 0, white, 1), 0)
    return r[mask]


def main():
    try:
        import mitsuba  # noqa: F401  (run with a python that has it, e.g. the main venv's)
    except ImportError:
        common.reexec_in_venv()
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenes", default="checker_sky,textured_mesh")
    ap.add_argument("--spp", default="1,256")
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--before")
    ap.add_argument("--after", default=os.path.join(REPO, "target", "ci", "torrey"))
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--reuse-ref", action="store_true", help="reuse reference EXRs of an earlier run")
    ap.add_argument("--threads", type=int, default=0)
    a = ap.parse_args()
    import numpy as np
    if not a.no_mitsuba:
        if "DRJIT_LIBLLVM_PATH" not in os.environ:
            common.setup_mitsuba()
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
    os.makedirs(OUT, exist_ok=True)
    spps = [int(s) for s in a.spp.split(",")]
    methods = []
    if a.before:
        methods.append(("before", a.before, []))
    methods += [("no-mipmap", a.after, ["--no-mipmap"]), ("after", a.after, []),
                # Mitsuba's kind of samples: what the filter does without Sobol's stratification.
                ("no-mipmap indep.", a.after, ["--no-mipmap", "--sampler", "independent"]),
                ("after indep.", a.after, ["--sampler", "independent"])]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in a.scenes.split(","):
            v = variants(scene, tmp)
            o = lambda name: os.path.join(OUT, "%s_%s.exr" % (scene, name))  # noqa: E731
            # The reference: unfiltered textures, many samples, a seed of its own.
            ref_seed = a.seed + 1000
            refs = [o("ref%d_tex" % a.ref_spp), o("ref%d_white" % a.ref_spp)]
            if a.reuse_ref and all(os.path.exists(p) for p in refs):
                ref_t, ref_w = read_exr(refs[0]), read_exr(refs[1])
            else:
                ref_t = torrey(a.after, v["tex"], a.ref_spp, ref_seed, refs[0], ["--no-mipmap"], a.threads)
                ref_w = torrey(a.after, v["white"], a.ref_spp, ref_seed, refs[1], ["--no-mipmap"], a.threads)
            mask = np.broadcast_to((ref_w > 1e-6).all(axis=-1, keepdims=True), ref_w.shape)
            ref = ratio(ref_t, ref_w, mask)
            common.log("%s: %d of %d pixels carry a ratio" % (scene, mask[..., 0].sum(), mask[..., 0].size))
            for spp in spps:
                row = {"scene": scene, "spp": spp}
                for name, binary, extra in methods:
                    t = torrey(binary, v["tex"], spp, a.seed, o("%s_%d_tex" % (name.replace(" ", "_"), spp)), extra, a.threads)
                    w = torrey(binary, v["white"], spp, a.seed, o("%s_%d_white" % (name.replace(" ", "_"), spp)), extra, a.threads)
                    row[name] = float(np.sqrt(np.mean((ratio(t, w, mask) - ref) ** 2)))
                if not a.no_mitsuba:
                    t = render_mitsuba(v["tex"], spp, a.seed, o("mitsuba_%d_tex" % spp))
                    w = render_mitsuba(v["white"], spp, a.seed, o("mitsuba_%d_white" % spp))
                    row["mitsuba"] = float(np.sqrt(np.mean((ratio(t, w, mask) - ref) ** 2)))
                common.log(str(row))
                rows.append(row)
    cols = [m[0] for m in methods] + ([] if a.no_mitsuba else ["mitsuba"])
    print("| scene | spp | " + " | ".join(cols) + " | after / mitsuba |")
    print("| --- | --- | " + " | ".join("---" for _ in cols) + " | --- |")
    for r in rows:
        q = "%.2f" % (r["after"] / r["mitsuba"]) if "mitsuba" in r else "-"
        print("| %s | %d | %s | %s |" % (r["scene"], r["spp"], " | ".join("%.4f" % r[c] for c in cols), q))


if __name__ == "__main__":
    main()
