"""Errors are Python exceptions carrying the command line's messages; bad input never crashes."""

import pytest

import vitrum
from conftest import SCENE


def cli_message(cli, *args):
    """The command line's error message (without `vitrum: error: `) and its exit code."""
    done = cli(*args, check=False)
    lines = [l for l in done.stderr.splitlines() if l.startswith("vitrum: error: ")]
    assert lines, done.stderr
    return lines[0].removeprefix("vitrum: error: "), done.returncode


@pytest.fixture(scope="module")
def scene():
    return vitrum.load(SCENE)


@pytest.mark.parametrize(
    "kwargs,args",
    [
        (dict(method="vcm", spp=0), ["-i", "vcm", "--spp", "0"]),
        (dict(method="nope", spp=1), ["-i", "nope", "--spp", "1"]),
        (dict(method="path", spp=1, strategy="merge"), ["-i", "path", "--spp", "1", "--strategy", "merge"]),
        (dict(method="path", spp=1, reflectance=2.0), ["-i", "path", "--spp", "1", "--reflectance", "2.0"]),
        (dict(method="ssaa", variance=True), ["-i", "ssaa", "--variance"]),
    ],
)
def test_bad_options_raise_the_command_line_message(scene, cli, tmp_path, kwargs, args):
    message, code = cli_message(cli, "render", SCENE, *args, "-o", tmp_path / "x.exr")
    assert code == 2
    with pytest.raises(vitrum.InputError) as e:
        scene.render(resolution=(8, 8), **kwargs)
    assert str(e.value) == message


def test_values_the_command_line_cannot_parse_raise_its_parser_message(scene):
    with pytest.raises(vitrum.InputError, match="invalid value 'deep' for '--max-depth"):
        scene.render("path", max_depth="deep")
    with pytest.raises(vitrum.InputError, match="unexpected argument '--colour"):
        scene.render("path", colour="red")
    with pytest.raises(vitrum.InputError, match="--resume: a render part is written to a file"):
        scene.render("path", resume="x.exr")
    with pytest.raises(vitrum.InputError, match=r"png=: not an option of Scene.render; use Render.png\(\)"):
        scene.render("path", png="x.png")


def test_scene_errors_name_file_line_and_column_as_the_command_line_does(cli, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SCENE.read_text().replace("fov = 39.0", 'fov = "wide"'))
    message, code = cli_message(cli, "render", bad, "-o", tmp_path / "x.exr")
    assert code == 2 and f"{bad}:" in message and "camera.fov" in message
    with pytest.raises(vitrum.SceneError) as e:
        vitrum.load(bad)
    assert str(e.value) == message
    assert isinstance(e.value, vitrum.InputError) and isinstance(e.value, vitrum.VitrumError)
    with pytest.raises(vitrum.SceneError, match="No such file"):
        vitrum.load(tmp_path / "missing.toml")


def test_dict_scene_errors_point_into_its_toml():
    with pytest.raises(vitrum.SceneError) as e:
        vitrum.load({"camera": {"fov": "wide"}})
    assert str(e.value).startswith("<dict>:2:7: field `camera.fov`: expected a number")
    with pytest.raises(vitrum.SceneError, match=r"objects\[0\].radius is None"):
        vitrum.load({"objects": [{"shape": "sphere", "radius": None}]})
    with pytest.raises(vitrum.SceneError, match="unknown field `colour`"):
        vitrum.load({"render": {"colour": 1}})
    with pytest.raises(TypeError):
        vitrum.load(42)


def test_bad_images_raise_input_errors(tmp_path):
    (tmp_path / "x.exr").write_bytes(b"not an exr")
    with pytest.raises(vitrum.InputError):
        vitrum.read_exr(tmp_path / "x.exr")
    with pytest.raises(vitrum.InputError, match="cannot read the test image"):
        vitrum.diff(tmp_path / "x.exr", tmp_path / "x.exr")


def test_save_refuses_what_the_command_line_refuses(scene, tmp_path):
    r = scene.render("path", spp=1, resolution=(8, 8))
    with pytest.raises(vitrum.InputError, match="must end in .exr"):
        r.save(tmp_path / "x.png")
    with pytest.raises(vitrum.InputError, match="does not exist"):
        r.save(tmp_path / "no" / "x.exr")
