"""Shared fixtures: the repository root, the command-line binary the package is checked
against, and running it."""

import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenes" / "cornell-glass.toml"


def cli_binary():
    """The `vitrum` binary: $VITRUM_BIN, else the repository's release build."""
    path = pathlib.Path(os.environ.get("VITRUM_BIN", ROOT / "target" / "release" / "vitrum"))
    if not path.is_file():
        pytest.fail(f"no vitrum binary at {path}: run `cargo build --release` or set VITRUM_BIN")
    return path


@pytest.fixture
def cli():
    """Runs `vitrum ARGS...`; returns the completed process (text output, not checked)."""

    def run(*args, check=True):
        done = subprocess.run([str(cli_binary()), *map(str, args)], capture_output=True, text=True, cwd=ROOT)
        if check and done.returncode != 0:
            pytest.fail(f"vitrum {' '.join(map(str, args))} failed ({done.returncode}): {done.stderr}")
        return done

    return run


@pytest.fixture
def cli_json(cli):
    """Runs `vitrum ARGS... --json` and returns the JSON it prints."""

    def run(*args):
        return json.loads(cli(*args, "--json").stdout)

    return run
