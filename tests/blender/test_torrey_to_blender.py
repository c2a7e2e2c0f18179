#!/usr/bin/env python3
"""Unit tests for the Blender converter's Blender-free parts (XML, transforms, fov, meshes).

Standard library only, no bpy needed:

    python3 -m unittest discover -s tests/blender -p 'test_*.py'
"""
import math
import os
import struct
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import torrey_to_blender as t2b  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def write(tmp, name, text):
    p = os.path.join(tmp, name)
    with open(p, "w") as f:
        f.write(text)
    return p


SCENE = """<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="5"/></integrator>
  <sensor type="perspective"><string name="fovAxis" value="y"/><float name="fov" value="40"/>
    <transform name="toWorld"><lookat origin="1, 2, 3" target="1, 2, 2" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="32"/></sampler>
    <film type="hdrfilm"><integer name="width" value="200"/><integer name="height" value="100"/></film>
  </sensor>
  <texture type="bitmap" id="tex"><string name="filename" value="img.png"/>
    <float name="uscale" value="2"/><float name="voffset" value="0.25"/></texture>
  <bsdf type="diffuse" id="d"><ref name="reflectance" id="tex"/></bsdf>
  <bsdf type="%s" id="m"><rgb name="reflectance" value="0.9, 0.8, 0.5"/></bsdf>
  <shape type="sphere"><point name="center" x="0" y="1" z="0"/><float name="radius" value="2"/>
    <ref id="m"/></shape>
  <shape type="rectangle"><transform name="toWorld"><scale x="2" y="3" z="1"/><rotate x="1" angle="90"/>
    <translate y="4"/></transform><ref id="d"/><emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>
  <emitter type="point"><point name="position" x="1" y="2" z="3"/><rgb name="intensity" value="1, 2, 3"/></emitter>
</scene>
"""


class SceneParsing(unittest.TestCase):
    def test_reads_camera_materials_shapes_and_lights(self):
        with tempfile.TemporaryDirectory() as tmp:
            s = t2b.read_scene(write(tmp, "s.xml", SCENE % "mirror"))
            cam = s["camera"]
            self.assertEqual((cam["width"], cam["height"], cam["spp"]), (200, 100, 32))
            self.assertEqual(s["max_depth"], 5)
            # lookat: camera +z is the view direction (0, 0, -1), +x is left = (-1, 0, 0) in world
            m = cam["to_world"]
            self.assertEqual([m[i][2] for i in range(3)], [0.0, 0.0, -1.0])
            self.assertEqual([m[i][0] for i in range(3)], [-1.0, 0.0, 0.0])
            self.assertEqual([m[i][3] for i in range(3)], [1.0, 2.0, 3.0])
            sphere, rect = s["shapes"]
            self.assertEqual(sphere["bsdf"]["kind"], "mirror")
            self.assertEqual(sphere["bsdf"]["reflectance"]["constant"], [0.9, 0.8, 0.5])
            tex = rect["bsdf"]["reflectance"]["texture"]
            self.assertEqual(tex["filename"], os.path.join(tmp, "img.png"))
            self.assertEqual((tex["uv_scale"], tex["uv_offset"]), ([2.0, 1.0], [0.0, 0.25]))
            self.assertEqual(rect["emitter"], [5.0, 5.0, 5.0])
            # scale, then rotate +90 about x (y -> z), then translate: local (1, 1, 0) -> (2, 4, 3)
            p = t2b.mat_apply_point(rect["to_world"], [1, 1, 0])
            for got, want in zip(p, [2.0, 4.0, 3.0]):
                self.assertAlmostEqual(got, want, places=12)
            self.assertEqual(s["lights"], [{"kind": "point", "position": [1.0, 2.0, 3.0],
                                            "intensity": [1.0, 2.0, 3.0]}])
            self.assertEqual(s["background"], [0.5, 0.5, 0.5])  # torrey default without <background>

    def test_refuses_materials_without_an_exact_equivalent(self):
        with tempfile.TemporaryDirectory() as tmp:
            for kind in ("phong", "blinn", "blinn_microfacet", "plastic"):
                with self.assertRaisesRegex(t2b.Unsupported, kind):
                    t2b.read_scene(write(tmp, "s.xml", SCENE % kind))

    def test_refuses_mitsuba3_dialect_and_emitter_only_depth(self):
        with tempfile.TemporaryDirectory() as tmp:
            with self.assertRaisesRegex(t2b.Unsupported, "dialect"):
                t2b.read_scene(write(tmp, "a.xml", (SCENE % "mirror").replace("0.6.0", "3.0.0")))
            with self.assertRaisesRegex(t2b.Unsupported, "max_depth 1"):
                t2b.read_scene(write(tmp, "b.xml", (SCENE % "mirror").replace('value="5"', 'value="1"')))

    def test_project_scenes_are_classified(self):
        self.assertEqual(len(t2b.read_scene(os.path.join(REPO, "scenes", "cbox.xml"))["shapes"]), 8)
        with self.assertRaisesRegex(t2b.Unsupported, "plastic"):
            t2b.read_scene(os.path.join(REPO, "scenes", "materials.xml"))


class Camera(unittest.TestCase):
    def fov(self, axis, w, h, fov=60.0):
        return t2b.horizontal_fov({"fov": fov, "fov_axis": axis, "width": w, "height": h})

    def test_horizontal_fov_for_each_axis(self):
        self.assertAlmostEqual(self.fov("x", 200, 100), 60.0)
        tx = math.tan(math.radians(30)) * 2  # y fov 60 on a 2:1 film
        self.assertAlmostEqual(self.fov("y", 200, 100), math.degrees(2 * math.atan(tx)))
        td = math.tan(math.radians(30)) * 200 / math.hypot(200, 100)
        self.assertAlmostEqual(self.fov("diagonal", 200, 100), math.degrees(2 * math.atan(td)))
        self.assertAlmostEqual(self.fov("smaller", 200, 100), self.fov("y", 200, 100))
        self.assertAlmostEqual(self.fov("larger", 100, 200), self.fov("y", 100, 200))


class Meshes(unittest.TestCase):
    def test_obj_flips_v_triangulates_and_dedups(self):
        with tempfile.TemporaryDirectory() as tmp:
            p = write(tmp, "q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 0.25\nvt 0 1\n"
                                    "f 1/1 2/2 3/3 4/4\n")
            m = t2b.read_obj(p)
            self.assertEqual(m["tris"], [[0, 1, 2], [0, 2, 3]])
            self.assertEqual(m["uvs"], [[0.0, 1.0], [1.0, 1.0], [1.0, 0.75], [0.0, 0.0]])
            self.assertIsNone(m["normals"])
            n = t2b.smooth_normals(m)
            self.assertEqual(n[0], [0.0, 0.0, 1.0])

    def test_ply_ascii_and_binary_keep_uv(self):
        verts = [(0, 0, 0, 0.0, 0.0), (1, 0, 0, 1.0, 0.0), (0, 1, 0, 0.0, 0.5)]
        head = ("ply\nformat {} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                "property float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\n"
                "end_header\n")
        with tempfile.TemporaryDirectory() as tmp:
            a = write(tmp, "a.ply", head.format("ascii") + "".join("%g %g %g %g %g\n" % v for v in verts)
                      + "3 0 1 2\n")
            b = os.path.join(tmp, "b.ply")
            with open(b, "wb") as f:
                f.write(head.format("binary_little_endian").encode())
                for v in verts:
                    f.write(struct.pack("<5f", *v))
                f.write(struct.pack("<B3i", 3, 0, 1, 2))
            for p in (a, b):
                m = t2b.read_ply(p)
                self.assertEqual(m["tris"], [[0, 1, 2]])
                self.assertEqual(m["uvs"], [[0.0, 0.0], [1.0, 0.0], [0.0, 0.5]])  # not flipped

    def test_sphere_mesh_is_outward_with_mitsuba_uv(self):
        m = t2b.sphere_mesh([1.0, 2.0, 3.0], 0.5)
        P, N, UV = m["positions"], m["normals"], m["uvs"]
        for tri in m["tris"][:: max(1, len(m["tris"]) // 500)]:
            a, b, c = (P[i] for i in tri)
            n = t2b.vcross(t2b.vsub(b, a), t2b.vsub(c, a))
            centroid = [(a[k] + b[k] + c[k]) / 3 - [1.0, 2.0, 3.0][k] for k in range(3)]
            self.assertGreater(t2b.vdot(n, centroid), 0.0)
        for i in range(0, len(P), 97):
            d = [(P[i][k] - [1.0, 2.0, 3.0][k]) / 0.5 for k in range(3)]
            self.assertAlmostEqual(t2b.vdot(d, N[i]), 1.0, places=9)
            if 0 < UV[i][1] < 1:  # Mitsuba: u = phi / 2pi, v = theta / pi
                self.assertAlmostEqual(math.acos(max(-1.0, min(1.0, d[2]))) / math.pi, UV[i][1], places=9)
                phi = math.atan2(d[1], d[0]) % (2 * math.pi)
                self.assertAlmostEqual(math.cos(phi), math.cos(2 * math.pi * UV[i][0]), places=6)


if __name__ == "__main__":
    unittest.main()
