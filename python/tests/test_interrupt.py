"""Ctrl-C stops a render cleanly with the samples done."""

import json
import signal
import subprocess
import sys
import textwrap
import threading
import time
import _thread

import pytest

import vitrum
from conftest import SCENE

LONG = dict(method="path", spp=1_000_000, resolution=(64, 64), seed=1)


@pytest.fixture
def python_sigint_handler():
    """Python's own SIGINT handler, as in an interactive session: a process started in the
    background by a shell inherits SIGINT ignored, and Python then leaves it ignored."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_sigint_stops_a_render_with_the_samples_done_and_raises_keyboard_interrupt():
    script = textwrap.dedent(
        f"""
        import json, signal, sys, vitrum
        signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a terminal
        scene = vitrum.load({str(SCENE)!r})
        print("rendering", flush=True)
        try:
            scene.render(**{LONG!r})
        except KeyboardInterrupt as e:
            print(json.dumps({{"stats": e.render.stats, "interrupted": e.render.interrupted,
                              "mean": float(e.render.image.mean())}}), flush=True)
            sys.exit(0)
        sys.exit(3)
        """
    )
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "rendering"
    time.sleep(1.5)
    sent = time.perf_counter()
    child.send_signal(signal.SIGINT)
    try:
        out, _ = child.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        child.kill()
        raise AssertionError("the render did not stop within 60 s of SIGINT")
    stopped_in = time.perf_counter() - sent
    assert child.returncode == 0, out
    found = json.loads(out)
    stats = found["stats"]
    assert stats["interrupted"] is True
    assert 1 <= stats["spp"] < 1_000_000 and stats["requested_spp"] == 1_000_000
    assert found["interrupted"].startswith(f"SIGINT after {stats['spp']} of 1000000 samples per pixel")
    assert found["mean"] > 0
    assert stopped_in < 10, f"took {stopped_in:.1f} s to stop"


def test_an_interrupt_from_a_thread_returns_the_partial_render_when_asked(python_sigint_handler):
    scene = vitrum.load(SCENE)
    timer = threading.Timer(1.0, _thread.interrupt_main)
    timer.start()
    r = scene.render(on_interrupt="return", **LONG)
    timer.join()
    assert r.stats["interrupted"] is True and 1 <= r.stats["spp"] < 1_000_000
    # The stop does not outlive the render: the next one runs to its budget.
    again = scene.render("path", spp=2, resolution=(16, 16))
    assert again.stats["interrupted"] is False and again.stats["spp"] == 2
