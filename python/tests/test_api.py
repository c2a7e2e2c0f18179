"""The Python API: the command line's pixels, exact slicing and merging, errors with
file:line:column, progress from render threads with the GIL released, EXR writing."""

import os
import threading

import numpy as np
import pytest

import torrey
from conftest import max_relative_difference, run_cli, scene_path


@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_render_gives_the_command_line_pixels(torrey_bin, tmp_path, sampler):
    scene = torrey.load_file(scene_path("textured_mesh.xml"))
    for extra, kwargs in [
        ([], {}),
        (["--crop", "5,4,20,10", "--sample-range", "3..11"], dict(crop=(5, 4, 20, 10), sample_range=range(3, 11))),
    ]:
        out = str(tmp_path / f"cli-{sampler}-{len(extra)}.exr")
        run_cli(torrey_bin, scene_path("textured_mesh.xml"), "--size", "32x24", "--spp", "12", "--seed", "3",
                "--sampler", sampler, "-o", out, *extra)
        cli = torrey.Part.read(out)
        image = torrey.render(scene, spp=12, seed=3, size=(32, 24), sampler=sampler, threads=1, **kwargs)
        assert image.dtype == np.float32 and image.shape == (cli.shape[1], cli.shape[0], 3)
        assert image.max() > 0
        # Bit for bit.
        assert np.array_equal(image.view(np.uint32), torrey.part_to_array(cli).view(np.uint32))
        assert torrey.read_image(out).tobytes() == image.tobytes()


@pytest.mark.parametrize("sampler", ["sobol", "independent"])
def test_slices_merge_into_the_one_piece_render(sampler):
    scene = torrey.load_file(scene_path("cbox.xml"))
    settings = dict(spp=21, seed=1, size=(24, 18), sampler=sampler, max_depth=4)
    full = torrey.render_part(scene, **settings)
    pieces = [
        ((0, 0, 24, 7), (0, 21)),
        ((0, 7, 11, 11), (0, 5)),
        ((0, 7, 11, 11), (5, 13)),
        ((0, 7, 11, 11), (13, 21)),
        ((11, 7, 13, 11), (0, 16)),
        ((11, 7, 13, 11), (16, 21)),
    ]
    parts = [torrey.render_part(scene, crop=c, sample_range=r, **settings) for c, r in pieces]
    merged = torrey.merge(parts)
    assert merged.meta == full.meta
    for variance in (False, True):
        d = max_relative_difference(torrey.part_to_array(merged, variance), torrey.part_to_array(full, variance))
        print(f"{sampler}: merged vs one-piece (variance={variance}): max relative difference {d:.3g}")
        assert d < 1e-4
    with pytest.raises(ValueError, match="missing samples 13..21 of crop 0,7,11,11"):
        torrey.merge(parts[:3] + parts[4:])


def test_scene_errors_carry_file_line_column(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="0.6.0">\n  <shape type="sphere">\n    <float name="radius" value="oops"/>\n  </shape>\n</scene>\n')
    with pytest.raises(torrey.SceneError) as e:
        torrey.load_file(bad)
    assert isinstance(e.value, ValueError)
    assert (e.value.file, e.value.line) == (str(bad), 3)
    assert str(e.value).startswith(f"{bad}:3:{e.value.column}: error:")
    assert "oops" in str(e.value)

    missing = tmp_path / "missing.xml"
    missing.write_text('<scene version="0.6.0">\n  <texture type="bitmap" id="t">\n'
                       '    <string name="filename" value="nowhere.png"/>\n  </texture>\n</scene>\n')
    with pytest.raises(torrey.SceneError, match=r"missing.xml:3:\d+: error: .*nowhere.png"):
        torrey.load_file(missing)


def test_defines_set_scene_defaults(tmp_path):
    xml = tmp_path / "d.xml"
    xml.write_text('<scene version="0.6.0">\n  <default name="spp" value="4"/>\n  <sensor type="perspective">\n'
                   '    <sampler type="independent"><integer name="sampleCount" value="$spp"/></sampler>\n'
                   '  </sensor>\n</scene>\n')
    assert torrey.load_file(xml).spp == 4
    assert torrey.load_file(xml, spp=7).spp == 7


def test_progress_comes_from_render_threads_with_the_gil_released():
    scene = torrey.load_file(scene_path("cbox.xml"))
    calls = []
    ticks = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            ticks[0] += 1
            stop.wait(0.001)

    def progress(done, total):
        calls.append((done, total, ticks[0], threading.get_ident()))

    spinner = threading.Thread(target=spin)
    spinner.start()
    try:
        torrey.render(scene, spp=64, size=(96, 64), threads=2, progress=progress)
    finally:
        stop.set()
        spinner.join()
    assert [c[0] for c in calls] == list(range(1, len(calls) + 1))
    assert calls[-1][1] == len(calls) == 24  # 6 x 4 tiles of 16 pixels
    assert all(c[3] != threading.get_ident() for c in calls), "called from the render threads"
    # A Python thread ran while the render was going: the GIL was free.
    assert calls[-1][2] > calls[0][2]

    def failing(done, total):
        raise KeyError("stop")

    with pytest.raises(KeyError, match="stop"):
        torrey.render(scene, spp=1, size=(8, 8), progress=failing)


def test_write_exr_round_trip(tmp_path):
    a = np.random.default_rng(1).random((5, 7, 3)).astype(np.float32) * 10
    path = tmp_path / "a.exr"
    torrey.write_exr(path, a)
    assert np.array_equal(torrey.read_image(path), a)
    with pytest.raises(ValueError, match=r"shape \(height, width, 3\)"):
        torrey.write_exr(path, np.zeros((4, 4)))


def test_bad_arguments_raise_value_errors():
    scene = torrey.load_file(scene_path("cbox.xml"))
    with pytest.raises(ValueError, match="reaches outside the 8x8 film"):
        torrey.render(scene, size=(8, 8), spp=1, crop=(4, 4, 8, 8))
    with pytest.raises(ValueError, match="beyond the render's 4 spp"):
        torrey.render(scene, size=(8, 8), spp=4, sample_range=(2, 6))
    with pytest.raises(ValueError, match="sampler must be"):
        torrey.render(scene, size=(8, 8), spp=1, sampler="halton")


def test_aovs_come_back_with_mitsubas_names(torrey_bin, tmp_path):
    """The aov integrator's channels, as the command line writes them, bit for bit."""
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "scenes", "aov", "aov.xml")
    scene = torrey.load_file(path)
    part = torrey.render_part(scene, spp=8, seed=2)
    layers = torrey.aovs(part)
    for name in ["my_image.A", "dd.y.T", "nn.X", "aa.R", "ux.U", "pi.I", "si.I"]:
        assert layers[name].shape == (36, 48) and layers[name].dtype == np.float32
    assert layers["dd.y.T"].max() > 3 and layers["dd.y.T"].min() == 0
    out = str(tmp_path / "aov.exr")
    run_cli(torrey_bin, path, "--spp", "8", "--seed", "2", "-o", out)
    cli = torrey.aovs(torrey.Part.read(out))
    assert sorted(cli) == sorted(layers)
    for name in layers:
        assert np.array_equal(cli[name], layers[name]), name


def test_adaptive_sampling_and_time_limits():
    scene = torrey.load_file(scene_path("cbox.xml"))
    part = torrey.render_part(scene, spp=128, seed=1, size=(32, 24), noise_threshold=0.1)
    n = torrey.counts(part)
    assert n.dtype == np.uint32 and n.min() == 8 and n.max() == 128
    assert "noise_threshold=0.1" in part.meta["settings"]
    timed = torrey.render_part(scene, spp=1 << 20, size=(32, 24), time_limit=0.3)
    n = torrey.counts(timed)
    # Sobol samples: powers of two, the last pass taking part of the pixels one doubling further.
    lo, hi = int(n.min()), int(n.max())
    assert lo > 1 and hi in (lo, 2 * lo) and (lo & (lo - 1)) == 0, (lo, hi)


def test_denoise_or_a_clear_error():
    scene = torrey.load_file(scene_path("cbox.xml"))
    try:
        image = torrey.render(scene, spp=4, size=(32, 24), denoise=True)
    except RuntimeError as e:
        assert "install-oidn.sh" in str(e)
        return
    part = torrey.render_part(scene, spp=4, size=(32, 24), denoise=True)
    assert np.array_equal(torrey.part_to_array(part, denoised=True), image)
    assert not np.array_equal(torrey.part_to_array(part), image)
    assert {"albedo.R", "normal.Z"} <= set(part.channels)
    # The guides' prefilter: "fast" is another image, "accurate" the default; a typo is an error.
    fast = torrey.part_to_array(part.denoised("fast"), denoised=True)
    assert np.array_equal(torrey.part_to_array(part.denoised(), denoised=True), image)
    assert not np.array_equal(fast, image)
    with pytest.raises(ValueError, match="expected 'accurate' or 'fast'"):
        part.denoised("slow")
