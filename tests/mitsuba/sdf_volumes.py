"""The `.vol` grids of the sdfgrid verdict scene (tests/scenes/mitsuba/sdfgrid.xml) and of the
ray probe (tests/references/sdfgrid_probe.json): Mitsuba's binary grid volume format, version 3,
float32, written here so that both generators and the scenes share one definition.

Both grids are cubes of samples: Mitsuba 3.9.1 misses most hits on grids whose sample counts
differ between axes (measured: 27 of 4000 rays towards a sphere on a 9 x 7 x 5 grid hit, 4000 of
4000 on 8 x 8 x 8), so its references can only be trusted on cubes. Their headers declare
bounding boxes other than the unit cube on purpose: sdfgrid ignores them (the grid spans
[0, 1]^3 in object space), which the verdict checks.
"""
import os
import struct

import numpy as np


def write_vol(path, data, bbox):
    """data: [z, y, x, channels] float32 (x fastest in the file)."""
    z, y, x, c = data.shape
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(b"VOL")
        f.write(struct.pack("<B", 3))
        f.write(struct.pack("<i", 1))
        f.write(struct.pack("<iii", x, y, z))
        f.write(struct.pack("<i", c))
        f.write(struct.pack("<6f", *bbox))
        f.write(np.ascontiguousarray(data, dtype="<f4").tobytes())


def sample(n, sdf):
    """sdf sampled at the n^3 grid points (i / (n - 1), j / (n - 1), k / (n - 1))."""
    t = np.linspace(0.0, 1.0, n)
    z, y, x = np.meshgrid(t, t, t, indexing="ij")
    return sdf(x, y, z)[..., None].astype(np.float32)


def blob(x, y, z):
    """Two overlapping spheres (the min of their distances): a crease where they meet, which
    analytic and smooth normals shade differently."""
    a = np.sqrt((x - 0.38) ** 2 + (y - 0.45) ** 2 + (z - 0.5) ** 2) - 0.24
    b = np.sqrt((x - 0.64) ** 2 + (y - 0.55) ** 2 + (z - 0.47) ** 2) - 0.19
    return np.minimum(a, b)


def torus(x, y, z):
    """A torus around the y axis, major radius 0.3, minor 0.12."""
    q = np.sqrt((x - 0.5) ** 2 + (z - 0.5) ** 2) - 0.3
    return np.sqrt(q ** 2 + (y - 0.5) ** 2) - 0.12


def write_all(folder):
    write_vol(os.path.join(folder, "blob.vol"), sample(10, blob),
              (-2.0, -2.0, -2.0, 3.0, 3.0, 3.0))
    write_vol(os.path.join(folder, "torus.vol"), sample(14, torus),
              (0.5, 0.0, -1.0, 4.0, 2.0, 1.0))
