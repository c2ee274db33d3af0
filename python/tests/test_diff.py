"""vitrum.diff gives the numbers of `vitrum diff --json`."""

import pytest

import vitrum
from conftest import SCENE


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    folder = tmp_path_factory.mktemp("diff")
    scene = vitrum.load(SCENE)
    test = scene.render("path", spp=4, seed=1, resolution=(32, 32)).save(folder / "test.exr")
    reference = scene.render("vcm", spp=16, seed=2, resolution=(32, 32)).save(folder / "reference.exr")
    return test, reference


def without_paths(metrics):
    return {k: v for k, v in metrics.items() if k not in ("test", "reference")}


@pytest.mark.parametrize(
    "kwargs,args",
    [
        (dict(), []),
        (dict(region=(4, 8, 16, 12)), ["--crop", "4,8,16,12"]),
        (dict(exposure=-1.5), ["--exposure=-1.5"]),
    ],
)
def test_diff_equals_the_command_line(images, cli_json, kwargs, args):
    test, reference = images
    expected = cli_json("diff", test, reference, *args)
    got = vitrum.diff(test, reference, **kwargs)
    assert got == expected
    assert got["split"] is not None and got["mse"] > 0


def test_renders_are_judged_as_the_files_they_save(images):
    test, reference = images
    r = vitrum.load(SCENE).render("path", spp=4, seed=1, resolution=(32, 32))
    assert without_paths(vitrum.diff(r, reference)) == without_paths(vitrum.diff(test, reference))


def test_a_region_outside_the_image_is_the_command_lines_error(images, cli):
    test, reference = images
    with pytest.raises(vitrum.InputError, match=r"--crop 30,30,8,8 does not fit inside the 32x32 images"):
        vitrum.diff(test, reference, region=(30, 30, 8, 8))
