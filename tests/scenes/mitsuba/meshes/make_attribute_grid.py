#!/usr/bin/env python3
"""Writes attribute_grid.ply (beside this script): a 6 x 6 vertex grid on [-1, 1]^2 (z = 0,
50 triangles) with Mitsuba-named attributes for the mesh_attribute verdict scene: float
vertex colours `r g b` (vertex_color, smooth over the grid), a one-channel vertex property
`shade_0` (vertex_shade) and float face colours `r g b` (face_color)."""
import math
import os

N = 6
verts, faces = [], []
for j in range(N):
    for i in range(N):
        x, y = -1 + 2 * i / (N - 1), -1 + 2 * j / (N - 1)
        r = 0.5 + 0.4 * math.sin(2.0 * x + 0.5)
        g = 0.5 + 0.4 * math.cos(1.7 * y - 0.3)
        b = 0.5 + 0.4 * math.sin(1.3 * (x + y))
        shade = 0.2 + 0.7 * ((i + j) % 3) / 2
        verts.append((x, y, 0.0, r, g, b, shade))
k = 0
for j in range(N - 1):
    for i in range(N - 1):
        a, b, c, d = j * N + i, j * N + i + 1, (j + 1) * N + i + 1, (j + 1) * N + i
        for tri in ((a, b, c), (a, c, d)):
            col = ((0.15 + 0.7 * ((k * 37) % 11) / 10), (0.15 + 0.7 * ((k * 53) % 7) / 6),
                   (0.15 + 0.7 * ((k * 29) % 5) / 4))
            faces.append((tri, col))
            k += 1

path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "attribute_grid.ply")
with open(path, "w") as f:
    f.write("ply\nformat ascii 1.0\ncomment torrey mesh_attribute verdict grid\n")
    f.write("element vertex %d\n" % len(verts))
    for p in ("x", "y", "z", "r", "g", "b", "shade_0"):
        f.write("property float %s\n" % p)
    f.write("element face %d\nproperty list uchar int vertex_indices\n" % len(faces))
    for p in ("r", "g", "b"):
        f.write("property float %s\n" % p)
    f.write("end_header\n")
    for v in verts:
        f.write(" ".join("%.6g" % c for c in v) + "\n")
    for tri, col in faces:
        f.write("3 %d %d %d %s\n" % (tri + (" ".join("%.6g" % c for c in col),)))
print("wrote", path)
