#!/usr/bin/env python3
"""Mitsuba 3.9.1's sdfgrid hits for fixed rays: tests/references/sdfgrid_probe.json, which
tests/sdfgrid.rs compares torrey's hits with (distance, geometric and shading normal).

    tests/mitsuba/.venv/bin/python tests/mitsuba/make_sdfgrid_probe.py

Three shapes, on the grids of tests/scenes/mitsuba/volumes (sdf_volumes.py): the blob with
analytic normals under a non-uniform scale and a translation; the same with smooth normals; the
torus with smooth normals in a shapegroup placed by a rotating instance. 200 rays each, from
random points around the shape towards random points of the middle of its box (some miss). Variant llvm_ad_rgb.
"""
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402
import mitsuba as mi  # noqa: E402
import sdf_volumes  # noqa: E402

RAYS = 200
VOLUMES = os.path.join(REPO, "tests", "scenes", "mitsuba", "volumes")


def f32(x):
    """A float32 written with the 9 significant digits that give it back exactly."""
    return float("%.9g" % np.float32(x))


def main():
    mi.set_variant("llvm_ad_rgb")
    sdf_volumes.write_all(VOLUMES)
    T = mi.ScalarTransform4f
    blob = os.path.join(VOLUMES, "blob.vol")
    torus = os.path.join(VOLUMES, "torus.vol")
    scale_translate = T().translate([0.3, -0.2, 0.5]).scale([1.4, 1.2, 1.3])
    instance = (T().translate([1.15, 0.55, 0.45]).rotate([0, 1, 0], -30).rotate([1, 0, 0], 55)
                .scale(1.2).translate([-0.5, -0.5, -0.5]))
    configs = {
        "blob_analytic": ({"type": "sdfgrid", "filename": blob, "normals": "analytic",
                           "to_world": scale_translate}, scale_translate),
        "blob_smooth": ({"type": "sdfgrid", "filename": blob, "normals": "smooth",
                         "to_world": scale_translate}, scale_translate),
        "torus_instance": (None, instance),
    }
    out = {"generator": "tests/mitsuba/make_sdfgrid_probe.py", "mitsuba_version": mi.__version__,
           "configs": {}}
    rng = np.random.default_rng(34)
    for name, (shape, to_world) in configs.items():
        if shape is None:
            scene = mi.load_dict({
                "type": "scene",
                "group": {"type": "shapegroup",
                          "s": {"type": "sdfgrid", "filename": torus, "normals": "smooth"}},
                "inst": {"type": "instance", "group": {"type": "ref", "id": "group"},
                         "to_world": to_world}})
        else:
            scene = mi.load_dict({"type": "scene", "s": shape})
        m = np.array(to_world.matrix, dtype=np.float64)
        corners = np.array([[(c >> a) & 1 for a in range(3)] + [1] for c in range(8)], float)
        world = (m @ corners.T).T[:, :3]
        lo, hi = world.min(0), world.max(0)
        centre, size = 0.5 * (lo + hi), np.linalg.norm(hi - lo)
        u = rng.normal(size=(RAYS, 3))
        o = centre + size * u / np.linalg.norm(u, axis=1)[:, None]
        target = centre + (hi - lo) * rng.uniform(-0.3, 0.3, size=(RAYS, 3))
        d = target - o
        d /= np.linalg.norm(d, axis=1)[:, None]
        o, d = o.astype(np.float32), d.astype(np.float32)
        ray = mi.Ray3f(mi.Point3f(o[:, 0], o[:, 1], o[:, 2]), mi.Vector3f(d[:, 0], d[:, 1], d[:, 2]))
        si = scene.ray_intersect(ray)
        t = np.array(si.t)
        n = np.array(si.n).reshape(3, -1).T if np.array(si.n).shape[0] == 3 else np.array(si.n)
        sh = np.array(si.sh_frame.n)
        sh = sh.reshape(3, -1).T if sh.shape[0] == 3 else sh
        rays = []
        for i in range(RAYS):
            hit = bool(np.isfinite(t[i]))
            rays.append({"o": [f32(x) for x in o[i]], "d": [f32(x) for x in d[i]],
                         "t": f32(t[i]) if hit else None,
                         "n": [round(float(x), 6) for x in n[i]] if hit else None,
                         "sh": [round(float(x), 6) for x in sh[i]] if hit else None})
        out["configs"][name] = {"to_world": [[f32(x) for x in row] for row in m],
                                "hits": int(np.isfinite(t).sum()), "rays": rays}
        print(name, "hits", int(np.isfinite(t).sum()), "of", RAYS)
    path = os.path.join(REPO, "tests", "references", "sdfgrid_probe.json")
    # One ray per line.
    text = json.dumps(out, separators=(",", ":"))
    text = text.replace('{"o"', '\n{"o"')
    with open(path, "w") as f:
        f.write(text + "\n")


if __name__ == "__main__":
    main()
