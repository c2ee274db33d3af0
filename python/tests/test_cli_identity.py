"""The package and the command line give the same results for the same arguments, bit for bit."""

import numpy as np
import pytest

import vitrum
from conftest import ROOT, SCENE

CASES = [
    # (scene, keyword arguments, the same as command-line arguments)
    (SCENE, dict(method="vcm", spp=4, seed=1, resolution=(48, 40)), ["-i", "vcm", "--spp", "4", "--seed", "1", "--resolution", "48x40"]),
    (SCENE, dict(method="path", spp=3, seed=7, resolution=(32, 32), max_depth=8), ["-i", "path", "--spp", "3", "--seed", "7", "--resolution", "32x32", "--max-depth", "8"]),
    (SCENE, dict(method="whitted", resolution=(32, 24)), ["-i", "whitted", "--resolution", "32x24"]),
    (SCENE, dict(method="bpt", spp=2, resolution=(24, 24), replicas=2, sampler="independent"), ["-i", "bpt", "--spp", "2", "--resolution", "24x24", "--replicas", "2", "--sampler", "independent"]),
    (ROOT / "scenes" / "dispersion.toml", dict(method="path", spp=2, resolution=(32, 32), spectral="on"), ["-i", "path", "--spp", "2", "--resolution", "32x32", "--spectral", "on"]),
]


def bits(array):
    """The array's bits, so that NaNs and signed zeros compare too."""
    return np.ascontiguousarray(array, dtype=np.float32).view(np.uint32)


@pytest.mark.parametrize("scene_path,kwargs,args", CASES, ids=lambda c: None)
def test_the_package_renders_what_the_command_line_renders(scene_path, kwargs, args, cli_json, tmp_path):
    exr = tmp_path / "cli.exr"
    cli_stats = cli_json("render", scene_path, *args, "-o", exr, "--quiet")
    render = vitrum.load(scene_path).render(**kwargs)
    assert np.array_equal(bits(render.image), bits(vitrum.read_exr(exr)))
    stats = render.stats
    for key in ["spp", "requested_spp", "seed", "width", "height", "max_depth", "merging", "rays", "spectral", "noise", "non_finite_samples", "samples_per_pixel", "engine", "scene_hash"]:
        assert stats[key] == cli_stats[key], key
    # The saved file has the command line's channels and attributes, times aside.
    saved = render.save(tmp_path / "py.exr")
    a, b = vitrum.exr_attributes(saved), vitrum.exr_attributes(exr)
    for key in set(a) | set(b):
        if key != "renderTimeSeconds":
            assert a.get(key) == b.get(key), key
    assert vitrum.diff(saved, exr)["mse"] == 0


def test_a_dict_scene_renders_what_its_file_renders():
    import tomllib

    with open(SCENE, "rb") as f:
        desc = tomllib.load(f)
    from_dict = vitrum.load(desc).render("vcm", spp=2, seed=5, resolution=(32, 32))
    from_file = vitrum.load(SCENE).render("vcm", spp=2, seed=5, resolution=(32, 32))
    assert np.array_equal(bits(from_dict.image), bits(from_file.image))
    # Varied in code: another glass changes the image.
    desc["materials"]["glass"]["ior"] = 1.2
    varied = vitrum.load(desc).render("vcm", spp=2, seed=5, resolution=(32, 32))
    assert not np.array_equal(varied.image, from_file.image)
