"""The API: loading, rendering, the render's arrays, stats, files and previews."""

import numpy as np
import pytest

import vitrum
from conftest import ROOT, SCENE


@pytest.fixture(scope="module")
def scene():
    return vitrum.load(SCENE)


@pytest.fixture(scope="module")
def render(scene):
    return scene.render("path", spp=4, seed=3, resolution=(40, 30))


def test_a_scene_describes_itself(scene):
    assert scene.name == str(SCENE)
    assert scene.resolution == (800, 800)
    assert scene.method == "whitted"
    assert len(scene.hash) == 16
    assert vitrum.load(str(SCENE)).hash == scene.hash


def test_a_render_is_linear_float32_height_by_width_by_3(render):
    image = render.image
    assert image.shape == (30, 40, 3) and image.dtype == np.float32
    assert np.isfinite(image).all() and image.mean() > 0
    variance = render.variance
    assert variance.shape == image.shape and variance.dtype == np.float32 and (variance >= 0).all()


def test_stats_are_the_json_summary(render):
    s = render.stats
    assert (s["integrator"], s["spp"], s["seed"], s["width"], s["height"]) == ("path", 4, 3, 40, 30)
    assert s["requested_spp"] == 4 and s["interrupted"] is False and s["output"] is None
    assert s["rays"]["primary"] == 4 * 40 * 30
    assert s["noise"]["std_error"] > 0


def test_save_writes_the_exr_that_read_exr_reads_back(render, tmp_path):
    path = render.save(tmp_path / "x.exr")
    assert np.array_equal(vitrum.read_exr(path), render.image)
    attributes = vitrum.exr_attributes(path)
    assert attributes["vitrum:integrator"] == "path" and attributes["vitrum:spp"] == "4"
    assert render.stats["output"] == str(tmp_path / "x.exr")


def test_the_preview_is_a_png(render):
    png = render._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert render.png(exposure=2) != png


def test_options_take_the_scene_defaults_when_unset(scene):
    r = scene.render(resolution=(16, 16))
    assert r.stats["integrator"] == "whitted" and r.stats["max_depth"] == 5 and r.stats["spp"] == 1


def test_settings_are_the_command_line_options(scene):
    r = scene.render("vcm", spp=2, resolution=(16, 16), max_depth=3, radius_alpha=0.5, replicas=2)
    s = r.stats
    assert s["max_depth"] == 3 and s["merging"]["alpha"] == 0.5
    assert "2 independent replicas" in s["noise"]["basis"]
    assert scene.render("path", spp=1, resolution=(8, 8), no_variance=True).variance is None


def test_a_time_budget_renders_whole_passes(scene):
    s = scene.render("path", time=0.2, resolution=(16, 16)).stats
    assert s["spp"] >= 1 and s["requested_spp"] is None


def test_methods_lists_every_integrator():
    m = vitrum.methods()
    assert {"path", "vcm", "whitted", "bpt"} <= set(m) and all(m.values())


def test_rendering_releases_the_gil(scene):
    # A Python thread keeps running while another renders.
    import threading
    import time

    done = threading.Event()
    ticks = 0

    def work():
        scene.render("path", spp=64, resolution=(64, 64), threads=1)
        done.set()

    worker = threading.Thread(target=work)
    worker.start()
    start = time.perf_counter()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    worker.join()
    elapsed = time.perf_counter() - start
    assert elapsed > 0.05, "the render was too short to tell"
    # At most one tick per millisecond; with the GIL held by the render there would be ~1.
    assert ticks > 10, f"{ticks} ticks in {elapsed:.3f} s"
