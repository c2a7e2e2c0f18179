"""Distributed rendering on a real Ray cluster on this machine: a head and worker nodes started
with `ray start` on a loopback address (one CPU each; see cluster.py). A render split across the
nodes equals the one-piece render; a node killed while it renders (its slices retried
elsewhere) still gives the same image; a missing asset is a clear error with file:line:column."""

import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

ray = pytest.importorskip("ray")

import torrey  # noqa: E402
import torrey.distributed as dist  # noqa: E402
from cluster import LocalCluster  # noqa: E402
from conftest import max_relative_difference, run_cli, scene_path  # noqa: E402


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    logs = tmp_path_factory.mktemp("slice-logs")
    c = LocalCluster()
    c.slice_logs = str(logs)
    try:
        c.start_head(num_cpus=1, env={"TORREY_SLICE_LOG": os.path.join(logs, "head")})
        c.connect(nodes=1)
        c.add_node(num_cpus=1, env={"TORREY_SLICE_LOG": os.path.join(logs, "node1")})
        c.wait_for_nodes(2)
        c.warm_up()
        yield c
    finally:
        c.shutdown()


def slice_log(cluster, node):
    path = os.path.join(cluster.slice_logs, node, "slices.log")
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return [line.split()[:3] for line in f]


def one_piece(torrey_bin, tmp_path, scene, size, spp, seed, sampler="sobol"):
    out = str(tmp_path / "one-piece.exr")
    run_cli(torrey_bin, scene, "--size", size, "--spp", str(spp), "--seed", str(seed), "--sampler", sampler, "-o", out)
    return torrey.Part.read(out)


def test_plan_covers_the_render_once():
    for w, h, spp, k in [(32, 24, 20, 6), (7, 3, 5, 64), (4096, 2160, 16384, 1000), (1, 1, 1, 3)]:
        pieces = dist.plan(w, h, spp, k)
        assert len(pieces) <= k
        covered = np.zeros((h, w), np.int64) if w * h < 10**6 else None
        for (x, y, cw, ch), (a, b) in pieces:
            assert 0 <= a < b <= spp and cw > 0 and ch > 0
            if covered is not None:
                covered[y:y + ch, x:x + cw] += b - a
        if covered is not None:
            assert (covered == spp).all()


def test_render_across_two_nodes_equals_the_one_piece_render(cluster, torrey_bin, tmp_path):
    out = str(tmp_path / "dist.exr")
    scene = scene_path("textured_mesh.xml")
    env = dict(os.environ)
    run = subprocess.run(
        [sys.executable, "-m", "torrey.distributed", scene, "-o", out, "--size", "32x24", "--spp", "2000",
         "--seed", "5", "--slices", "8", "--address", cluster.address],
        capture_output=True, text=True, env=env, timeout=300,
    )
    assert run.returncode == 0, run.stderr + cluster.logs()
    assert "8/8 slices" in run.stderr and "on 2 nodes" in run.stderr, run.stderr
    assert os.path.exists(out[:-4] + ".png")
    merged = torrey.Part.read(out)
    reference = one_piece(torrey_bin, tmp_path, scene, "32x24", 2000, 5)
    assert merged.meta == reference.meta
    d = max_relative_difference(torrey.part_to_array(merged), torrey.part_to_array(reference))
    print(f"two nodes vs one piece: max relative difference {d:.3g}")
    assert d < 1e-4
    # Both nodes rendered slices.
    assert slice_log(cluster, "head") and slice_log(cluster, "node1")


def test_a_node_killed_mid_render_leaves_the_image_unchanged(cluster, torrey_bin, tmp_path):
    victim = cluster.add_node(num_cpus=1, env={"TORREY_SLICE_LOG": os.path.join(cluster.slice_logs, "victim")})
    cluster.wait_for_nodes(3)
    cluster.warm_up()
    scene = scene_path("cbox.xml")
    result = {}

    def driver():
        try:
            result["part"], result["per_node"] = dist.render_distributed(
                scene, str(tmp_path / "killed.exr"), slices=12, spp=3072, size=(32, 24), seed=2,
                sampler="independent", max_retries=3,
            )
        except BaseException as e:  # reported by the test thread
            result["error"] = e

    thread = threading.Thread(target=driver)
    thread.start()
    # Wait until the victim is rendering a slice (started, not finished), then kill the node.
    in_flight = None
    deadline = time.monotonic() + 120
    while in_flight is None and time.monotonic() < deadline and thread.is_alive():
        log = slice_log(cluster, "victim")
        started = {tuple(l[1:]) for l in log if l[0] == "start"}
        ended = {tuple(l[1:]) for l in log if l[0] == "end"}
        if started - ended:
            in_flight = sorted(started - ended)[0]
            cluster.kill_node(victim)
        time.sleep(0.01)
    thread.join(timeout=300)
    assert in_flight is not None, "the victim never rendered a slice"
    assert "error" not in result, result.get("error")
    # The slice the victim was rendering was rendered again by another node.
    survivors = slice_log(cluster, "head") + slice_log(cluster, "node1")
    assert ["end", *in_flight] in survivors
    # Bit for bit the image of the same slices rendered and merged in this process, without Ray.
    loaded = torrey.load_file(scene)
    local = torrey.merge([
        torrey.render_part(loaded, spp=3072, size=(32, 24), seed=2, sampler="independent", crop=c, sample_range=r)
        for c, r in dist.plan(32, 24, 3072, 12)
    ])
    killed = torrey.part_to_array(result["part"])
    assert np.array_equal(killed.view(np.uint32), torrey.part_to_array(local).view(np.uint32))
    reference = one_piece(torrey_bin, tmp_path, scene, "32x24", 3072, 2, "independent")
    d = max_relative_difference(killed, torrey.part_to_array(reference))
    print(f"killed node: slice {in_flight} retried; max relative difference {d:.3g}")
    assert d < 1e-4
    assert result["part"].meta == reference.meta


def test_missing_asset_is_a_clear_error(cluster, tmp_path):
    bad = tmp_path / "missing_mesh.xml"
    bad.write_text('<scene version="0.6.0">\n  <shape type="obj">\n'
                   '    <string name="filename" value="meshes/not_there.obj"/>\n  </shape>\n</scene>\n')
    env = dict(os.environ)
    out = tmp_path / "never.exr"
    run = subprocess.run(
        [sys.executable, "-m", "torrey.distributed", str(bad), "-o", str(out), "--slices", "2",
         "--address", cluster.address],
        capture_output=True, text=True, env=env, timeout=300,
    )
    assert run.returncode == 1
    assert f"{bad}:3:" in run.stderr and "not_there.obj" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr
    assert not out.exists()


def test_scene_error_on_a_worker_reaches_the_driver(cluster, tmp_path):
    """A worker that cannot read the scene (here: a shared path the driver can read but whose
    image vanished before the workers loaded it) fails the render with the located error."""
    import shutil

    folder = tmp_path / "shared"
    folder.mkdir()
    (folder / "t.png").write_bytes(open(os.path.join(os.path.dirname(scene_path("x")), "..", "textures", "checker.png"), "rb").read())
    xml = folder / "s.xml"
    xml.write_text('<scene version="0.6.0">\n  <texture type="bitmap" id="t">\n'
                   '    <string name="filename" value="t.png"/>\n  </texture>\n'
                   '  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>'
                   '<integer name="height" value="8"/></film></sensor>\n</scene>\n')
    scene = torrey.load_file(xml)
    os.remove(folder / "t.png")
    source = str(xml)
    task = ray.remote(num_cpus=1, max_retries=0)(dist.render_slice_task)
    ref = task.remote(source, [], scene.content_hash, str(xml), dict(spp=1), (0, 0, 8, 8), (0, 1))
    with pytest.raises(ray.exceptions.RayTaskError) as e:
        ray.get(ref)
    assert isinstance(e.value.cause, torrey.SceneError)
    assert e.value.cause.line == 3 and "t.png" in str(e.value.cause)
    shutil.rmtree(folder)


def test_film_crop_window_is_rendered_as_the_command_line_does(cluster, torrey_bin, tmp_path):
    xml = tmp_path / "cropped.xml"
    xml.write_text(open(scene_path("cbox.xml")).read().replace(
        '<integer name="height" value="256"/>',
        '<integer name="height" value="256"/><integer name="crop_offset_x" value="100"/>'
        '<integer name="crop_offset_y" value="60"/><integer name="crop_width" value="20"/>'
        '<integer name="crop_height" value="12"/>'))
    (tmp_path / "meshes").symlink_to(os.path.join(os.path.dirname(scene_path("cbox.xml")), "meshes"))
    part, _ = dist.render_distributed(str(xml), str(tmp_path / "d.exr"), slices=3, spp=24)
    out = str(tmp_path / "cli.exr")
    run_cli(torrey_bin, str(xml), "--spp", "24", "-o", out)
    reference = torrey.Part.read(out)
    assert part.meta == reference.meta and part.meta["crop"] == (100, 60, 20, 12)
    assert max_relative_difference(torrey.part_to_array(part), torrey.part_to_array(reference)) < 1e-4
