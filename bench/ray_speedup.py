"""Scaling of distributed rendering on this machine, with Ray nodes of one CPU each started with
`ray start` as in python/tests:
- speedup from one to two nodes: the same render (cbox, 64x48, 2048 spp, 16 slices, one thread
  per task), timed twice per cluster size after a warm-up task on every node;
- per-task overhead: 64 slices of an 8x8, 64-spp render (almost no rendering) on two nodes;
- merge cost: encoding, decoding and merging the parts of a 512x512 film (16 tiles x 4 sample
  ranges), per million part pixels, without Ray.
Run with the venv of .ci/python.sh: `.venv-python/bin/python bench/ray_speedup.py`."""

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python", "tests"))

from cluster import LocalCluster, use_fresh_auth_token  # noqa: E402

use_fresh_auth_token()

import torrey  # noqa: E402
import torrey.distributed as dist  # noqa: E402

SCENE = os.path.join(os.path.dirname(__file__), "..", "scenes", "cbox.xml")


def timed(out: str) -> float:
    start = time.monotonic()
    dist.render_distributed(SCENE, out, slices=16, spp=2048, size=(64, 48), seed=1)
    return time.monotonic() - start


def main() -> None:
    c = LocalCluster()
    out = os.path.join(c.temp, "speedup.exr")
    try:
        c.start_head(num_cpus=1)
        c.connect(nodes=1)
        c.warm_up()
        one = [timed(out) for _ in range(2)]
        c.add_node(num_cpus=1)
        c.wait_for_nodes(2)
        c.warm_up()
        two = [timed(out) for _ in range(2)]
        start = time.monotonic()
        dist.render_distributed(SCENE, out, slices=64, spp=64, size=(8, 8), seed=1)
        per_task = (time.monotonic() - start) / 64
    finally:
        c.shutdown()
    scene = torrey.load_file(SCENE)
    pieces = dist.plan(512, 512, 4, 64)
    parts = [torrey.render_part(scene, spp=4, size=(512, 512), crop=cr, sample_range=r) for cr, r in pieces]
    start = time.monotonic()
    blobs = [p.to_exr_bytes() for p in parts]
    encode = time.monotonic() - start
    start = time.monotonic()
    parts = [torrey.Part.from_exr_bytes(b) for b in blobs]
    decode = time.monotonic() - start
    start = time.monotonic()
    torrey.merge(parts)
    merge = time.monotonic() - start
    mpx = sum(p.shape[0] * p.shape[1] for p in parts) / 1e6
    print(f"per-task overhead (2 nodes, 64 near-empty slices): {per_task * 1000:.0f} ms")
    print(
        f"per million part pixels: encode {encode / mpx:.2f} s, decode {decode / mpx:.2f} s, "
        f"merge {merge / mpx:.2f} s; {sum(map(len, blobs)) / mpx / 1e6:.1f} MB of EXR"
    )
    print(f"1 node: {min(one):.2f} s (runs {', '.join(f'{t:.2f}' for t in one)})")
    print(f"2 nodes: {min(two):.2f} s (runs {', '.join(f'{t:.2f}' for t in two)})")
    print(f"speedup: {min(one) / min(two):.2f}x; load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
