"""The README's Python example runs and prints the same numbers as the command line.

Every ```python block of the repository's README.md runs (in order, in one namespace, in a
temporary folder where `scenes` is the repository's scenes folder). What it prints is what the
```text block after the last one shows, with every number masked; and every number it prints is
printed by the command-line lines of the ```sh block after that (run with the release binary), as
the README says. $VITRUM_README names another Markdown file to read instead."""

import os
import re
import subprocess

from conftest import ROOT, cli_binary

FENCE = re.compile(r"^```(\w+)[ \t]*\n(.*?)^```[ \t]*$", re.S | re.M)
NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def masked(text):
    return [NUMBER.sub("#", line).rstrip() for line in text.strip().splitlines()]


def test_the_readme_python_example_prints_the_command_lines_numbers(monkeypatch, capsys, tmp_path):
    readme = os.environ.get("VITRUM_README", str(ROOT / "README.md"))
    with open(readme) as f:
        blocks = FENCE.findall(f.read())
    python = [i for i, (kind, _) in enumerate(blocks) if kind == "python"]
    assert python, f"{readme} has no ```python block: the README's Python example is missing"
    after = blocks[python[-1] + 1 :]
    shown = next((text for kind, text in after[:1] if kind == "text"), None)
    assert shown is not None, "the README shows what the Python example prints in a ```text block after it"
    commands = next((text for kind, text in after if kind == "sh"), None)
    assert commands is not None, "the README gives the command-line lines after the Python example"

    (tmp_path / "scenes").symlink_to(ROOT / "scenes")
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__readme__"}
    for n, i in enumerate(python):
        exec(compile(blocks[i][1], f"{readme} python block {n + 1}", "exec"), namespace)
    printed = capsys.readouterr().out
    assert masked(printed) == masked(shown), f"the example printed\n{printed}\nthe README shows\n{shown}"

    cli_numbers = set()
    for line in commands.strip().splitlines():
        line = line.split(" #")[0].strip()
        if not line or line.startswith("#"):
            continue
        program, *args = line.split()
        assert program == "vitrum", line
        done = subprocess.run([str(cli_binary()), *args], capture_output=True, text=True, cwd=tmp_path)
        assert done.returncode == 0, f"{line}: {done.stderr}"
        cli_numbers |= {float(n) for n in NUMBER.findall(done.stdout + done.stderr)}
    missing = [n for n in NUMBER.findall(printed) if float(n) not in cli_numbers]
    assert not missing, f"the Python example printed numbers the command line does not: {missing}\n{printed}"
