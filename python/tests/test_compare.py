"""vitrum.compare runs `vitrum compare`: the same table, and a figure a notebook shows."""

import csv
import math

import pytest

import vitrum
from conftest import SCENE

ARGS = dict(spp=2, reference_spp=8, resolution=(32, 32), seed=4)
CLI_ARGS = ["--spp", "2", "--reference-spp", "8", "--resolution", "32x32", "--seed", "4"]
# Columns that measure time; every other one is a pure function of the arguments.
TIMED = {"seconds", "mrays_per_second", "efficiency", "efficiency_low", "efficiency_high", "seconds_low", "seconds_high"}


def test_compare_gives_the_command_lines_table_and_figure(tmp_path, cli):
    cache = tmp_path / "cache"
    result = vitrum.compare(vitrum.load(SCENE), ["path", "vcm"], out=tmp_path / "py", cache=cache, **ARGS)
    cli("compare", SCENE, "-i", "path,vcm", *CLI_ARGS, "--cache", cache, "--out", tmp_path / "cli", "--quiet")
    with open(tmp_path / "cli" / "compare.csv", newline="") as f:
        expected = list(csv.DictReader(f))
    assert [r["method"] for r in result.rows] == ["path", "vcm"]
    assert len(expected) == 2
    for got, want in zip(result.rows, expected):
        for key, value in want.items():
            if key not in TIMED:
                want_value = vitrum._number(value)
                same_nan = isinstance(want_value, float) and math.isnan(want_value) and math.isnan(got[key])
                assert same_nan or got[key] == want_value, key
    assert result._repr_png_()[:8] == b"\x89PNG\r\n\x1a\n"
    table = result.table
    assert len(table) == 2
    assert vitrum.read_exr(result.render_path("vcm")).shape == (32, 32, 3)


def test_compare_refuses_bad_input_with_the_command_lines_message(tmp_path):
    with pytest.raises(vitrum.InputError, match="nope"):
        vitrum.compare(SCENE, ["path", "nope"], spp=1, out=tmp_path / "x")
