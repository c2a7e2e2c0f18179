#!/usr/bin/env python3
"""Mitsuba 3.9.1's render of tests/scenes/aov/aov.xml (its `aov` integrator: every AOV type torrey
writes) for tests/aov.rs: every channel as Mitsuba names it, 48 x 36 at 1024 spp, into
tests/references/aov/aov.exr (the film's own multichannel EXR).

    source tests/mitsuba/setup.sh
    tests/mitsuba/.venv/bin/python tests/mitsuba/make_aov_reference.py
"""
import os

import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))

mi.set_variant("llvm_ad_rgb")
scene = mi.load_file(os.path.join(REPO, "tests/scenes/aov/aov.xml"))
mi.render(scene, spp=1024, seed=0)
bitmap = scene.sensors()[0].film().bitmap()
out = os.path.join(REPO, "tests/references/aov/aov.exr")
os.makedirs(os.path.dirname(out), exist_ok=True)
bitmap.write(out)
print(out, [f.name for f in bitmap.struct_()])
