#!/usr/bin/env python3
"""Minimal OpenEXR writer: scanline, float32 R,G,B, ZIP compression (16-line blocks).
Mitsuba's own writer only does PIZ/DWAB, and the references are stored as ZIP.
Needs numpy. Usage:  from exr_zip import write_exr_zip; write_exr_zip("a.exr", rgb_hxwx3)
Run directly to self-test against Mitsuba's reader:  .venv/bin/python tests/mitsuba/exr_zip.py
"""
import struct
import zlib

import numpy as np


def _attr(name, typ, payload):
    return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(payload)) + payload


def _zip_block(raw):
    b = np.frombuffer(raw, dtype=np.uint8)
    t = np.concatenate([b[0::2], b[1::2]])
    d = t.copy()
    d[1:] = (t[1:].astype(np.int16) - t[:-1].astype(np.int16) + 128) & 0xFF
    comp = zlib.compress(d.tobytes(), 9)
    return comp if len(comp) < len(raw) else raw


def write_exr_zip(path, rgb):
    img = np.ascontiguousarray(np.asarray(rgb, dtype=np.float32)[..., :3])
    h, w, _ = img.shape
    chans = b""
    for c in (b"B", b"G", b"R"):  # channels sorted by name
        chans += c + b"\0" + struct.pack("<i", 2) + b"\0\0\0\0" + struct.pack("<ii", 1, 1)
    chans += b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = b"\x76\x2f\x31\x01" + struct.pack("<i", 2)
    header += _attr("channels", "chlist", chans)
    header += _attr("compression", "compression", bytes([3]))
    header += _attr("dataWindow", "box2i", box)
    header += _attr("displayWindow", "box2i", box)
    header += _attr("lineOrder", "lineOrder", bytes([0]))
    header += _attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
    header += _attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
    header += _attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
    header += b"\0"
    nblocks = (h + 15) // 16
    chunks = []
    for k in range(nblocks):
        rows = img[16 * k:16 * k + 16]  # (n, w, 3)
        # per scanline: all B, then all G, then all R
        raw = np.ascontiguousarray(rows[:, :, ::-1].transpose(0, 2, 1)).astype("<f4").tobytes()
        data = _zip_block(raw)
        chunks.append(struct.pack("<ii", 16 * k, len(data)) + data)
    offset = len(header) + 8 * nblocks
    table = b""
    for ch in chunks:
        table += struct.pack("<Q", offset)
        offset += len(ch)
    with open(path, "wb") as f:
        f.write(header + table + b"".join(chunks))


if __name__ == "__main__":
    import os
    import tempfile
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    rng = np.random.default_rng(0)
    for (h, w) in ((64, 64), (37, 50), (1, 1)):
        a = (rng.random((h, w, 3)) * 4).astype(np.float32)
        a[0, 0] = [0.0, 0.5, 1.0]
        p = os.path.join(tempfile.mkdtemp(), "t.exr")
        write_exr_zip(p, a)
        b = np.array(mi.Bitmap(p))[..., :3]
        assert b.shape == a.shape and np.array_equal(a, b), (h, w)
    print("exr_zip: round trip through Mitsuba's OpenEXR reader OK")
