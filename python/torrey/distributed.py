"""Distributed rendering on Ray: split a render into tiles x sample ranges, render them as Ray
tasks, merge the parts and write the EXR and PNG.

    python -m torrey.distributed SCENE -o OUT.exr [--spp N] [--size WxH] [--seed S]
        [--max-depth D] [--sampler sobol|independent] [-D name=value ...] --slices K
        [--address HOST:PORT] [--shared-path] [--max-retries R] [--quiet]

How the scene reaches the workers: by default through Ray's object store. The driver reads the
scene file and every file it names (meshes, images) into one bundle (`ray.put`, once); each task
takes it as an argument, so Ray copies it to each node once. A worker process writes the bundle
under its temp folder (keyed by the scene's content hash, so once per node) keeping the files'
relative layout, loads the scene from there and keeps the loaded scene (and its BVH) for its
next tasks. Files named by absolute paths are not moved: they must exist on the workers.
With --shared-path the workers instead read the scene from the same path as the driver (a
shared file system: NFS on Slurm, a shared volume on Kubernetes).

Every task returns its part as an EXR in memory; the driver merges them exactly (`torrey merge`),
so the result equals the one-machine render with the same seed. Tasks whose worker or node dies
are retried (--max-retries); a scene error is not retried and is reported with file:line:column.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import torrey

Crop = Tuple[int, int, int, int]
SampleRange = Tuple[int, int]


def split_samples(spp: int, n: int) -> List[SampleRange]:
    """`n` contiguous ranges covering 0..spp; their bounds fall on multiples of 8 when there are
    enough samples (whole packets of eight camera rays)."""
    n = max(1, min(n, spp))
    unit = 8 if spp >= 8 * n else 1
    units = math.ceil(spp / unit)
    bounds = [min(spp, round(units * i / n) * unit) for i in range(n + 1)]
    bounds[-1] = spp
    return [(a, b) for a, b in zip(bounds, bounds[1:]) if a < b]


def split_tiles(width: int, height: int, n: int) -> List[Crop]:
    """`n` (or fewer, for tiny films) tiles of a near-square grid over the film."""
    n = max(1, min(n, width * height))
    best = None
    for nx in range(1, n + 1):
        if n % nx:
            continue
        ny = n // nx
        if nx > width or ny > height:
            continue
        aspect = abs(math.log((width / nx) / (height / ny)))
        if best is None or aspect < best[0]:
            best = (aspect, nx, ny)
    if best is None:
        nx, ny = min(n, width), 1
    else:
        _, nx, ny = best
    xs = [round(width * i / nx) for i in range(nx + 1)]
    ys = [round(height * j / ny) for j in range(ny + 1)]
    return [
        (xs[i], ys[j], xs[i + 1] - xs[i], ys[j + 1] - ys[j])
        for j in range(ny)
        for i in range(nx)
        if xs[i + 1] > xs[i] and ys[j + 1] > ys[j]
    ]


def plan(width: int, height: int, spp: int, slices: int) -> List[Tuple[Crop, SampleRange]]:
    """Splits a render into `slices` pieces: tiles x sample ranges, with the number of sample
    ranges the divisor of `slices` nearest its square root (at most spp). Tiles keep each
    part's output small (merge cost grows with the pixels sent back); sample ranges balance
    the load (every range costs about the same)."""
    slices = max(1, slices)
    divisors = [d for d in range(1, slices + 1) if slices % d == 0 and d <= spp]
    ranges = min(divisors, key=lambda d: (abs(d - math.sqrt(slices)), -d))
    tiles = split_tiles(width, height, slices // ranges)
    return [(t, r) for t in tiles for r in split_samples(spp, ranges)]


def make_bundle(scene: "torrey.Scene") -> Dict:
    """The scene file and every file it names, by path relative to their common folder."""
    paths = [os.path.abspath(scene.path)] + [os.path.abspath(f) for f in scene.files]
    root = os.path.commonpath([os.path.dirname(p) for p in paths])
    files = {}
    for p in paths:
        rel = os.path.relpath(p, root)
        if rel not in files:
            with open(p, "rb") as f:
                files[rel] = f.read()
    return {
        "hash": scene.content_hash,
        "scene": os.path.relpath(paths[0], root),
        "files": files,
    }


# Per worker process: loaded scenes by content hash (a worker runs many tasks of one scene).
_SCENES: Dict[str, "torrey.Scene"] = {}


def _scene_from_bundle(bundle: Dict, defines: Sequence[Tuple[str, str]]) -> "torrey.Scene":
    key = bundle["hash"]
    if key not in _SCENES:
        base = os.path.join(tempfile.gettempdir(), "torrey-scenes", key)
        if not os.path.isdir(base):
            os.makedirs(os.path.dirname(base), exist_ok=True)
            staging = tempfile.mkdtemp(prefix=f".{key}-", dir=os.path.dirname(base))
            for rel, data in bundle["files"].items():
                path = os.path.join(staging, rel)
                os.makedirs(os.path.dirname(path), exist_ok=True)
                with open(path, "wb") as f:
                    f.write(data)
            try:
                os.rename(staging, base)
            except OSError:
                pass  # another worker on this node put it there first
        scene = torrey.load_file(os.path.join(base, bundle["scene"]), **dict(defines))
        if scene.content_hash != key:
            raise RuntimeError(
                f"the scene copied to this worker hashes to {scene.content_hash}, not {key}: "
                "a file it names by absolute path differs here"
            )
        _SCENES[key] = scene
    return _SCENES[key]


def _scene_from_path(path: str, defines: Sequence[Tuple[str, str]], expected_hash: str) -> "torrey.Scene":
    key = f"{path}\0{expected_hash}"
    if key not in _SCENES:
        scene = torrey.load_file(path, **dict(defines))
        if scene.content_hash != expected_hash:
            raise RuntimeError(
                f"{path} on this worker hashes to {scene.content_hash}, not {expected_hash}: "
                "the shared path holds another version of the scene"
            )
        _SCENES[key] = scene
    return _SCENES[key]


def _log_slice(event: str, crop: Crop, sample_range: SampleRange) -> None:
    """With TORREY_SLICE_LOG=DIR in a node's environment, its workers append one line per slice
    they start and finish to DIR/slices.log: which node rendered what, and which slices a dead
    node left unfinished (their retries run elsewhere)."""
    folder = os.environ.get("TORREY_SLICE_LOG")
    if folder:
        os.makedirs(folder, exist_ok=True)
        c, s = crop, sample_range
        with open(os.path.join(folder, "slices.log"), "a") as f:
            f.write(f"{event} {c[0]},{c[1]},{c[2]},{c[3]} {s[0]}..{s[1]} {os.getpid()}\n")


def render_slice_task(source, defines, expected_hash, label, params, crop, sample_range):
    """A Ray task: renders one slice; returns its part EXR bytes and the node it ran on.
    `source` is the scene bundle (object store) or the scene path (shared path)."""
    import ray

    _log_slice("start", crop, sample_range)
    if isinstance(source, dict):
        scene = _scene_from_bundle(source, defines)
    else:
        scene = _scene_from_path(source, defines, expected_hash)
    part = torrey.render_part(scene, crop=crop, sample_range=sample_range, label=label, **params)
    data = part.to_exr_bytes()
    _log_slice("end", crop, sample_range)
    return data, ray.get_runtime_context().get_node_id()


def render_distributed(
    scene_path: str,
    output: str,
    slices: int,
    spp: Optional[int] = None,
    size: Optional[Tuple[int, int]] = None,
    seed: Optional[int] = None,
    max_depth: Optional[int] = None,
    sampler: str = "sobol",
    defines: Optional[Dict[str, str]] = None,
    address: Optional[str] = None,
    shared_path: bool = False,
    max_retries: int = 3,
    progress: Optional[Callable[[int, int], None]] = None,
    threads_per_task: int = 1,
) -> Tuple["torrey.Part", Dict[str, int]]:
    """Renders on a Ray cluster (`address`, or the one `ray.init` finds or starts) and writes
    `output` (EXR) and its PNG; returns the merged part. Each task asks Ray for
    `threads_per_task` CPUs and renders with that many threads."""
    import ray

    defines = {k: str(v) for k, v in (defines or {}).items()}
    scene = torrey.load_file(scene_path, **defines)  # scene errors surface here, located
    width, height = size or scene.size
    total_spp = max(1, spp or scene.spp)
    params = dict(
        spp=total_spp,
        seed=seed,
        size=(width, height),
        max_depth=max_depth,
        sampler=sampler,
        threads=threads_per_task,
    )
    if size is None and scene.crop is not None:
        # The film's crop window (as the command line renders it): split by sample ranges only,
        # so that the parts share the window and merge into it.
        pieces = [(scene.crop, r) for r in split_samples(total_spp, slices)]
    else:
        pieces = plan(width, height, total_spp, slices)

    if not ray.is_initialized():
        ray.init(address=address, log_to_driver=False, configure_logging=False)
    if shared_path:
        source = os.path.abspath(scene_path)
    else:
        source = ray.put(make_bundle(scene))
    # Ray runs as many tasks at once on a node as its CPUs allow; each renders with its share of
    # threads (the parts are the same whatever the thread count). Tasks whose worker process or
    # node dies are resubmitted up to max_retries times; exceptions (scene errors) are not.
    # SPREAD: slices go to all nodes from the start instead of filling the driver's node first.
    task = ray.remote(
        num_cpus=threads_per_task,
        max_retries=max_retries,
        retry_exceptions=False,
        scheduling_strategy="SPREAD",
    )(render_slice_task)
    pending = {}
    for crop, samples in pieces:
        ref = task.remote(
            source, list(defines.items()), scene.content_hash, scene.path, params, crop, samples
        )
        pending[ref] = (crop, samples)
    results = {}
    per_node: Dict[str, int] = {}
    if progress:
        progress(0, len(pieces))
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1)
        for ref in done:
            crop, samples = pending.pop(ref)
            try:
                data, node = ray.get(ref)
            except ray.exceptions.RayTaskError as e:
                if isinstance(getattr(e, "cause", None), torrey.SceneError):
                    raise e.cause from None
                raise
            results[(crop, samples)] = data
            per_node[node] = per_node.get(node, 0) + 1
        if progress:
            progress(len(results), len(pieces))
    names = [f"crop {c[0]},{c[1]},{c[2]},{c[3]} samples {s[0]}..{s[1]}" for c, s in pieces]
    parts = [torrey.Part.from_exr_bytes(results[p], n) for p, n in zip(pieces, names)]
    merged = torrey.merge(parts, names)
    merged.write(output)
    return merged, per_node


def _size(s: str) -> Tuple[int, int]:
    w, sep, h = s.lower().partition("x")
    if not sep:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, got '{s}'")
    return int(w), int(h)


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m torrey.distributed",
        description="Render a torrey scene on a Ray cluster: tiles x sample ranges as Ray tasks, "
        "merged exactly into one EXR and PNG.",
    )
    p.add_argument("scene")
    p.add_argument("-o", "--output", required=True, help="output EXR (a PNG is written beside it)")
    p.add_argument("--spp", type=int)
    p.add_argument("--size", type=_size, help="WIDTHxHEIGHT")
    p.add_argument("--seed", type=int)
    p.add_argument("--max-depth", type=int)
    p.add_argument("--sampler", choices=["sobol", "independent"], default="sobol")
    p.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--slices", type=int, required=True, help="number of Ray tasks (tiles x sample ranges)")
    p.add_argument("--address", help="Ray cluster address HOST:PORT (default: RAY_ADDRESS or a local Ray)")
    p.add_argument("--shared-path", action="store_true", help="workers read the scene from the same path")
    p.add_argument("--max-retries", type=int, default=3, help="retries of a task whose worker dies")
    p.add_argument("--threads-per-task", type=int, default=1, help="CPUs each task asks for and renders with")
    p.add_argument("--quiet", action="store_true")
    a = p.parse_args(argv)
    defines = {}
    for d in a.defines:
        k, sep, v = d.partition("=")
        if not sep:
            p.error(f"-D expects NAME=VALUE, got '{d}'")
        defines[k.strip()] = v.strip()
    start = time.monotonic()

    def progress(done: int, total: int) -> None:
        if not a.quiet:
            line = f"[{time.monotonic() - start:7.1f} s] {done}/{total} slices"
            if sys.stderr.isatty():
                print(f"\r{line}", end="", file=sys.stderr, flush=True)
            else:
                print(line, file=sys.stderr, flush=True)

    try:
        merged, per_node = render_distributed(
            a.scene, a.output, a.slices, a.spp, a.size, a.seed, a.max_depth, a.sampler, defines,
            a.address, a.shared_path, a.max_retries, progress, a.threads_per_task,
        )
    except torrey.SceneError as e:
        print(f"\n{e}" if not a.quiet else str(e), file=sys.stderr)
        return 1
    m = merged.meta
    if not a.quiet and sys.stderr.isatty():
        print(file=sys.stderr)
    print(
        f"{a.scene}: {m['width']}x{m['height']} px, {m['spp']} spp in {a.slices} slices, "
        f"{time.monotonic() - start:.2f} s on {len(per_node)} nodes "
        f"({', '.join(str(n) for n in sorted(per_node.values(), reverse=True))} slices); "
        f"wrote {a.output} and {os.path.splitext(a.output)[0]}.png",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
