"""torrey from Python: load a Mitsuba-style scene, render it into a numpy array, write EXRs.

    import torrey
    scene = torrey.load_file("scenes/cbox.xml", spp="16")      # keyword defines, like -D spp=16
    image = torrey.render(scene, spp=64, seed=1, size=(320, 240))  # float32 (240, 320, 3)
    torrey.write_exr("cbox.exr", image)

The pixels are the command line's for the same scene, settings and seed. `denoise=True` denoises
with Intel Open Image Denoise (a build with the `denoise` feature), `noise_threshold=T` samples
adaptively, `time_limit=SECONDS` renders in passes until the time is up; `aovs(part)` gives the
AOVs of Mitsuba's `aov` integrator and the denoiser's guides as arrays. Scene errors raise
`torrey.SceneError` (a ValueError) whose message starts with `file:line:column` and which has
`file`, `line` and `column` attributes. `render` releases the GIL; `progress(done, total)` is called
after each finished tile. Distributed rendering on Ray: `python -m torrey.distributed --help`.
"""

from __future__ import annotations

import os
from typing import Callable, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import Part, Scene, SceneError

__all__ = [
    "load_file", "render", "render_part", "part_to_array", "aovs", "counts", "merge", "write_exr",
    "read_image",
    "Scene", "Part", "SceneError",
]

Range = Union[Tuple[int, int], range]


def load_file(path: Union[str, os.PathLike], **defines) -> Scene:
    """Reads a scene file. Keyword arguments set `<default>` parameters (values are turned into
    strings), as `torrey -D name=value` does."""
    return _native.load_file(os.fspath(path), [(k, _define_value(v)) for k, v in defines.items()])


def _define_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


def _sample_range(sample_range: Optional[Range]) -> Optional[Tuple[int, int]]:
    if sample_range is None:
        return None
    if isinstance(sample_range, range):
        if sample_range.step != 1:
            raise ValueError("sample_range must be contiguous (step 1)")
        return (sample_range.start, sample_range.stop)
    first, end = sample_range
    return (int(first), int(end))


def render_part(
    scene: Scene,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    size: Optional[Tuple[int, int]] = None,
    max_depth: Optional[int] = None,
    sample_range: Optional[Range] = None,
    crop: Optional[Sequence[int]] = None,
    threads: Optional[int] = None,
    sampler: str = "sobol",
    progress: Optional[Callable[[int, int], None]] = None,
    label: Optional[str] = None,
    denoise: bool = False,
    noise_threshold: Optional[float] = None,
    time_limit: Optional[float] = None,
    denoise_prefilter: str = "accurate",
) -> Part:
    """Renders a slice and returns it as a `Part` (mean, variance, per-pixel counts, the AOV and
    guide channels, and the metadata `merge` checks). `label` replaces the scene path recorded
    in the metadata. denoise: take the guides and denoise (`part_to_array(part, denoised=True)`);
    denoise_prefilter: "accurate" (each noisy guide denoised first) or "fast" (the command line's
    --denoise-prefilter).
    noise_threshold: adaptive sampling, each pixel until its relative standard error is under it
    (spp the cap). time_limit: seconds, rendering in passes until they are up."""
    return _native.render(
        scene,
        spp,
        seed,
        None if size is None else (int(size[0]), int(size[1])),
        max_depth,
        _sample_range(sample_range),
        None if crop is None else tuple(int(c) for c in crop),
        threads,
        sampler,
        progress,
        label,
        denoise,
        None if noise_threshold is None else float(noise_threshold),
        None if time_limit is None else float(time_limit),
        denoise_prefilter,
    )


def part_to_array(part: Part, variance: bool = False, denoised: bool = False) -> np.ndarray:
    """A part's mean (or variance of the mean, or its denoised image) as float32
    (height, width, 3)."""
    w, h = part.shape
    if denoised:
        data = part.denoised_bytes()
        if data is None:
            raise ValueError("the part was not denoised (render with denoise=True)")
    else:
        data = part.variance_bytes() if variance else part.mean_bytes()
    return np.frombuffer(data, dtype=np.float32).reshape(h, w, 3).copy()


def aovs(part: Part) -> dict:
    """The part's other channels (Mitsuba's AOVs under its names, e.g. `dd.y.T`, `nn.X`; the
    wrapped integrator's image `<name>.R/G/B/A`; the denoiser's `albedo.R/G/B`, `normal.X/Y/Z`),
    each float32 (height, width)."""
    w, h = part.shape
    return {
        name: np.frombuffer(part.channel_bytes(name), dtype=np.float32).reshape(h, w).copy()
        for name in part.channels
    }


def counts(part: Part) -> np.ndarray:
    """Samples per pixel, uint32 (height, width)."""
    w, h = part.shape
    return np.frombuffer(part.count_bytes(), dtype=np.uint32).reshape(h, w).copy()


def render(
    scene: Scene,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    size: Optional[Tuple[int, int]] = None,
    max_depth: Optional[int] = None,
    sample_range: Optional[Range] = None,
    crop: Optional[Sequence[int]] = None,
    threads: Optional[int] = None,
    sampler: str = "sobol",
    progress: Optional[Callable[[int, int], None]] = None,
    denoise: bool = False,
    noise_threshold: Optional[float] = None,
    time_limit: Optional[float] = None,
    denoise_prefilter: str = "accurate",
) -> np.ndarray:
    """Renders `scene` and returns the mean radiance (with denoise=True the denoised image) as
    float32 (height, width, 3).

    spp, seed, max_depth: default to the scene's. size: (width, height) of the whole film (the
    camera is kept). sample_range: (first, end) or range(first, end) of global sample indices
    (default all of 0..spp). crop: (x, y, width, height) window of the film; the array then has
    the window's size. threads: worker threads (default all cores). sampler: "sobol" or
    "independent". progress(done, total): called after each tile, with the GIL. denoise,
    noise_threshold, time_limit, denoise_prefilter: see `render_part`.
    """
    part = render_part(scene, spp, seed, size, max_depth, sample_range, crop, threads, sampler,
                       progress, None, denoise, noise_threshold, time_limit, denoise_prefilter)
    return part_to_array(part, denoised=denoise)


def merge(parts: Sequence[Part], names: Optional[Sequence[str]] = None) -> Part:
    """Merges parts of one render (crops and sample ranges), as `torrey merge` does."""
    names = list(names) if names is not None else [f"part {i}" for i in range(len(parts))]
    return _native.merge(list(parts), names)


def write_exr(path: Union[str, os.PathLike], array) -> None:
    """Writes a (height, width, 3) array as a linear float32 RGB EXR."""
    a = np.ascontiguousarray(array, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"expected an array of shape (height, width, 3), got {a.shape}")
    h, w, _ = a.shape
    _native.write_exr(os.fspath(path), a.tobytes(), w, h)


def read_image(path: Union[str, os.PathLike]) -> np.ndarray:
    """Reads an image (EXR, PNG, JPEG, HDR, ...) as linear float32 (height, width, 3), decoded
    as torrey decodes textures (8-bit images are sRGB)."""
    data, w, h = _native.read_image(os.fspath(path))
    return np.frombuffer(data, dtype=np.float32).reshape(h, w, 3).copy()
