#!/usr/bin/env python3
"""Writes the OBJ meshes used by the project's own scenes into scenes/meshes/.

Standard library only. Run from anywhere:  python3 scenes/generate_meshes.py
Outputs (deterministic, committed):
  cube.obj   the cube [-1,1]^3, 24 vertices (flat per-face normals), uv [0,1]^2 on every face
  torus.obj  a torus around +y (major radius 1, minor radius 0.35), smooth normals,
             uv = (angle around +y, angle around the tube) in [0,1]^2, with a seam
Vertex v in the files is in OBJ convention (v = 0 at the bottom of the image); loaders flip it.
"""
import math
import os

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "meshes")


def fmt(x):
    s = "%.6f" % x
    return "0.000000" if s == "-0.000000" else s


def write_obj(name, comment, positions, normals, uvs, faces):
    """faces: triangles of vertex indices (0-based); positions/normals/uvs share indices."""
    path = os.path.join(OUT, name)
    with open(path, "w") as f:
        f.write("# %s\n# written by scenes/generate_meshes.py\n" % comment)
        for p in positions:
            f.write("v %s %s %s\n" % tuple(fmt(c) for c in p))
        for n in normals:
            f.write("vn %s %s %s\n" % tuple(fmt(c) for c in n))
        for t in uvs:
            f.write("vt %s %s\n" % tuple(fmt(c) for c in t))
        for tri in faces:
            f.write("f %s\n" % " ".join("%d/%d/%d" % (i + 1, i + 1, i + 1) for i in tri))
    print("wrote %s (%d vertices, %d triangles)" % (path, len(positions), len(faces)))


def cube():
    positions, normals, uvs, faces = [], [], [], []
    # (normal axis, sign): build each face from its normal n and two tangents u, v with u x v = n.
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u = [0.0, 0.0, 0.0]
            u[(axis + 1) % 3] = 1.0
            v = [n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]]
            base = len(positions)
            for (a, b) in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                positions.append([n[k] + a * u[k] + b * v[k] for k in range(3)])
                normals.append(list(n))
                uvs.append(((a + 1) / 2, (b + 1) / 2))
            faces.append((base, base + 1, base + 2))
            faces.append((base, base + 2, base + 3))
    write_obj("cube.obj", "cube [-1,1]^3 with per-face normals and uvs", positions, normals, uvs, faces)


def torus(major=1.0, minor=0.35, nu=64, nv=32):
    positions, normals, uvs, faces = [], [], [], []
    # (nu + 1) x (nv + 1) grid: duplicated seam vertices so uvs run 0..1 without wrapping.
    for i in range(nu + 1):
        phi = 2 * math.pi * i / nu
        cp, sp = math.cos(phi), math.sin(phi)
        for j in range(nv + 1):
            th = 2 * math.pi * j / nv
            ct, st = math.cos(th), math.sin(th)
            n = (ct * cp, st, -ct * sp)
            positions.append((cp * (major + minor * ct), minor * st, -sp * (major + minor * ct)))
            normals.append(n)
            uvs.append((i / nu, j / nv))
    row = nv + 1
    for i in range(nu):
        for j in range(nv):
            a, b = i * row + j, (i + 1) * row + j
            # counter-clockwise seen from outside (outward normals)
            faces.append((a, b, b + 1))
            faces.append((a, b + 1, a + 1))
    write_obj("torus.obj", "torus around +y, R=%g r=%g, smooth normals and uvs" % (major, minor),
              positions, normals, uvs, faces)


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    cube()
    torus()
