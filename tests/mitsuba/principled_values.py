#!/usr/bin/env python3
"""eval and pdf of Mitsuba 3's `principled` and `principledthin` at fixed direction pairs, for
crates/renderer/src/bsdfs/tests_principled.rs (MITSUBA_VALUES there).

    tests/mitsuba/.venv/bin/python tests/mitsuba/principled_values.py

Variant llvm_ad_rgb (as the verdict references). Directions are (theta degrees, phi radians);
`wi` is Mitsuba's si.wi (torrey's wo, towards the viewer), `wo` the other direction.
"""
import math

import mitsuba as mi

mi.set_variant("llvm_ad_rgb")

MODELS = {
    "principled_coat": {"type": "principled", "base_color": {"type": "rgb", "value": [0.8, 0.3, 0.2]},
                        "roughness": 0.4, "metallic": 0.3, "spec_tint": 0.5, "sheen": 0.6,
                        "sheen_tint": 0.4, "clearcoat": 0.7, "clearcoat_gloss": 0.6,
                        "flatness": 0.3, "specular": 0.6},
    "principled_glass": {"type": "principled", "base_color": {"type": "rgb", "value": [0.6, 0.8, 0.9]},
                         "roughness": 0.3, "spec_trans": 0.7, "anisotropic": 0.5, "eta": 1.4,
                         "metallic": 0.1, "sheen": 0.3},
    "principled_metal": {"type": "principled", "base_color": {"type": "rgb", "value": [0.9, 0.6, 0.3]},
                         "roughness": 0.25, "metallic": 1.0, "anisotropic": 0.8},
    "thin_glossy": {"type": "principledthin", "base_color": {"type": "rgb", "value": [0.7, 0.1, 0.1]},
                    "roughness": 0.15, "spec_tint": 0.1, "anisotropic": 0.5, "spec_trans": 0.8,
                    "diff_trans": 0.3, "eta": 1.33},
    "thin_diffuse": {"type": "principledthin", "base_color": {"type": "rgb", "value": [0.3, 0.6, 0.4]},
                     "roughness": 0.6, "diff_trans": 1.2, "sheen": 0.5, "sheen_tint": 0.5,
                     "flatness": 0.5, "spec_trans": 0.3},
}

PAIRS = [((30.0, 0.3), (40.0, 3.5)), ((60.0, 0.1), (20.0, 3.0)), ((10.0, 1.0), (75.0, 2.0)),
         ((30.0, 0.3), (160.0, 3.3)), ((45.0, 0.2), (150.0, 0.4)), ((150.0, 0.5), (20.0, 3.9)),
         ((170.0, 0.5), (120.0, 2.0)), ((130.0, 2.0), (140.0, 5.0)), ((80.0, 0.0), (85.0, 3.0))]


def d(t):
    th, ph = math.radians(t[0]), t[1]
    return mi.Vector3f(math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th))


for name, desc in MODELS.items():
    b = mi.load_dict(desc)
    ctx = mi.BSDFContext()
    for wi, wo in PAIRS:
        si = mi.SurfaceInteraction3f()
        si.wi = d(wi)
        v = b.eval(ctx, si, d(wo))
        p = b.pdf(ctx, si, d(wo))
        vals = ", ".join(f"{float(v[i][0]):.5e}" for i in range(3))
        print(f'    ("{name}", {wi}, {wo}, [{vals}], {float(p[0]):.5e}),')
