"""vitrum from Python: load a scene, render it to numpy, measure and compare renders.

The package calls the same code as the ``vitrum`` command line, with the same options, so a
render here equals ``vitrum render`` with the same arguments bit for bit::

    import vitrum
    scene = vitrum.load("scenes/cornell-glass.toml")
    r = scene.render("vcm", spp=16, seed=1, resolution=(128, 128))
    r.image          # float32 numpy (height, width, 3), linear radiance
    r.stats["spp"]   # the summary `vitrum render --json` prints
    r.save("vcm.exr")

Options of ``Scene.render`` beyond the named ones are the command line's render options with
``_`` for ``-`` (``max_depth=8`` is ``--max-depth 8``, ``spectral="on"``, ``variance=True``);
they are parsed by the command line's own definitions, so a bad value raises ``InputError``
with the command line's message.

Ctrl-C (KeyboardInterrupt) during a render stops it at its next pass boundary, keeping the
samples done (the command line's rule). By default the KeyboardInterrupt is then re-raised, so
that a loop of renders stops, with the partial render attached as its ``render`` attribute;
``on_interrupt="return"`` returns the partial render instead (its ``stats["interrupted"]`` is
True). The stop is process-wide: renders running in other Python threads stop too.
"""

import csv
import json
import os
import tempfile
import warnings

from . import _vitrum
from ._vitrum import InputError, SceneError, VitrumError

__all__ = [
    "load",
    "Scene",
    "Render",
    "Comparison",
    "diff",
    "compare",
    "read_exr",
    "exr_attributes",
    "methods",
    "VitrumError",
    "InputError",
    "SceneError",
    "__version__",
]

__version__ = _vitrum.VERSION

# Options of `vitrum render` that write files or print, which a render held in memory does not:
# what to use instead.
_OUTPUT_OPTIONS = {
    "output": "Render.save(path)",
    "png": "Render.png() (the preview's PNG bytes)",
    "json": "Render.stats",
    "quiet": "nothing (a render from Python prints only warnings)",
    "density_map": "the command line",
    "scene": "vitrum.load(path).render(...)",
    "integrator": "method=",
}


def _option_text(value):
    """One option value as the command line reads it (floats round-trip exactly)."""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _arguments(options):
    """The command-line arguments of keyword options: ``max_depth=8`` -> ``--max-depth=8``,
    ``True`` -> the bare flag, ``None``/``False`` -> left out, ``resolution=(w, h)`` ->
    ``--resolution=WxH``, a list or tuple -> the option repeated (``region=[...]``)."""
    args = []
    for key, value in options.items():
        if value is None or value is False:
            continue
        flag = "--" + key.replace("_", "-")
        if value is True:
            args.append(flag)
        elif key == "resolution":
            width, height = value
            args.append(f"{flag}={int(width)}x{int(height)}")
        elif isinstance(value, (list, tuple)):
            args.extend(f"{flag}={_option_text(v)}" for v in value)
        else:
            args.append(f"{flag}={_option_text(value)}")
    return args


def _scene_toml(scene):
    """The TOML text of a scene given as a dict (the structure of a scene file)."""
    return _vitrum.toml_of_json(json.dumps(scene, allow_nan=False))


def load(scene, name="<dict>"):
    """Load a scene: a path to a scene file (TOML, or Mitsuba XML), or a dict with the structure
    of a scene file (scenes/README.md), e.g. ``{"camera": {...}, "objects": [...]}``. A dict is
    written as TOML and compiled by the same loader as a file: the defaults and the error
    messages (``<dict>:LINE:COLUMN`` of ``Scene.toml``) are the same; relative file paths in it
    (meshes, textures) are resolved against the current folder. Raises ``SceneError``."""
    if isinstance(scene, dict):
        text = _scene_toml(scene)
        loaded = Scene(_vitrum.load_text(text, name, os.getcwd()), toml=text)
    elif isinstance(scene, (str, os.PathLike)):
        loaded = Scene(_vitrum.load_file(os.fspath(scene)), path=os.fspath(scene))
    else:
        raise TypeError(f"vitrum.load: a path or a dict, not {type(scene).__name__}")
    # The warnings `vitrum render` prints after loading (degenerate triangles skipped, ...).
    for warning in loaded.warnings:
        warnings.warn(f"vitrum: {warning}", stacklevel=2)
    return loaded


class Scene:
    """A compiled scene. ``render`` renders it; ``name``, ``hash``, ``resolution``, ``method``
    (the scene file's default) and ``warnings`` describe it; ``toml`` is the text of a scene
    built from a dict (``None`` for a file, whose ``path`` is set)."""

    def __init__(self, native, path=None, toml=None):
        self._native = native
        self.path = path
        self.toml = toml

    name = property(lambda self: self._native.name, doc="The file path, or the dict scene's name.")
    hash = property(lambda self: self._native.hash, doc="Hash of the scene text and files it reads.")
    warnings = property(lambda self: self._native.warnings, doc="Warnings found while compiling.")
    resolution = property(lambda self: self._native.resolution, doc="(width, height) of the camera.")
    method = property(lambda self: self._native.method, doc="The scene file's default method.")

    def __repr__(self):
        width, height = self.resolution
        return f"<vitrum.Scene {self.name} {width}x{height}>"

    def render(
        self,
        method=None,
        spp=None,
        time=None,
        seed=None,
        resolution=None,
        threads=None,
        on_interrupt="raise",
        **settings,
    ):
        """Render with ``method`` (default: the scene's) at ``spp`` samples per pixel or for
        ``time`` seconds, ``seed``, ``resolution=(width, height)`` and ``threads`` (default all
        cores); further ``settings`` are ``vitrum render``'s options (``max_depth=8``,
        ``spectral="on"``, ``replicas=4``, ``exposure=-1``). Unset options take the scene
        file's values, as on the command line. Releases the GIL while rendering. Ctrl-C stops
        the render with the samples done, then raises KeyboardInterrupt with the partial render
        as its ``render`` attribute, or returns it with ``on_interrupt="return"``."""
        if on_interrupt not in ("raise", "return"):
            raise ValueError(f'on_interrupt={on_interrupt!r}: "raise" or "return"')
        for key in settings:
            if key in _OUTPUT_OPTIONS:
                raise InputError(f"{key}=: not an option of Scene.render; use {_OUTPUT_OPTIONS[key]}")
        options = dict(integrator=method, spp=spp, time=time, seed=seed, resolution=resolution, threads=threads)
        options.update(settings)
        native, signal = self._native.render(_arguments(options))
        render = Render(native, self)
        if signal is not None and on_interrupt == "raise":
            signal.render = render
            raise signal
        return render


class Render:
    """A render in memory: ``image`` (float32 numpy (height, width, 3), linear), ``variance``
    (the same shape, or None), ``stats`` (the summary ``vitrum render --json`` prints),
    ``save(path)`` (the EXR ``vitrum render`` writes) and ``png()`` (its ``--png`` preview,
    which a notebook shows)."""

    def __init__(self, native, scene):
        self._native = native
        self.scene = scene
        self._saved = None

    @property
    def image(self):
        """The image: float32 numpy array (height, width, 3), linear radiance."""
        return self._native.image()

    @property
    def variance(self):
        """The variance of each pixel's estimate (its squared standard error), or None."""
        return self._native.variance()

    @property
    def stats(self):
        """The summary of ``vitrum render --json`` as a dict (``output``: the last file saved)."""
        return json.loads(self._native.summary(self._saved))

    @property
    def interrupted(self):
        """What Ctrl-C interrupted (the EXR's ``vitrum:interrupted``), or None."""
        return self._native.interrupted

    def save(self, path):
        """Write the render as ``vitrum render -o PATH`` does (EXR with the variance and replica
        channels and the metadata); returns the path."""
        path = os.fspath(path)
        self._native.save(path)
        self._saved = path
        return path

    def png(self, exposure=None):
        """The tone-mapped preview ``vitrum render --png`` writes, as PNG bytes (``exposure`` in
        stops, default the render's)."""
        return self._native.png(exposure)

    def _repr_png_(self):
        return self.png()

    def __repr__(self):
        s = self.stats
        return f"<vitrum.Render {s['integrator']} {s['width']}x{s['height']} {s['spp']} spp {s['seconds']:.3f} s>"


def _exr_path(image, folder, name):
    """A path to an EXR of ``image``: a path as it is, a Render saved into ``folder``."""
    if isinstance(image, Render):
        return image.save(os.path.join(folder, name))
    if isinstance(image, (str, os.PathLike)):
        return os.fspath(image)
    raise TypeError(f"an EXR path or a vitrum.Render, not {type(image).__name__}")


def diff(test, reference, region=None, exposure=None, error_map=None):
    """The metrics of ``vitrum diff TEST REFERENCE --json`` as a dict. ``test`` and ``reference``
    are EXR paths or renders (a render is judged as the EXR it saves, with its variance).
    ``region``: ``(x, y, width, height)`` (``--crop``) or the path of a mask PNG (``--mask``);
    ``exposure``: stops of the preview metrics; ``error_map``: a PNG path to write."""
    with tempfile.TemporaryDirectory(prefix="vitrum-diff-") as folder:
        args = [_exr_path(test, folder, "test.exr"), _exr_path(reference, folder, "reference.exr")]
        if isinstance(region, (str, os.PathLike)):
            args += ["--mask", os.fspath(region)]
        elif region is not None:
            args += ["--crop", ",".join(str(int(v)) for v in region)]
        args += _arguments(dict(exposure=exposure, error_map=error_map))
        return json.loads(_vitrum.diff(args))


def _number(text):
    """A CSV field as a number when it is one (int, else float), else the text; '' is None."""
    if text == "":
        return None
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


class Comparison:
    """The result of ``vitrum compare``: ``rows`` (the table compare.csv as dicts), ``table``
    (a pandas DataFrame of them when pandas is installed, else the rows), ``figure`` (the path
    of compare.png, which a notebook shows), ``folder`` (every file: ``METHOD.exr``,
    ``reference.exr``, ``compare.md``, ``index.html``) and ``render_path(method)``."""

    def __init__(self, folder):
        self.folder = folder
        with open(os.path.join(folder, "compare.csv"), newline="") as f:
            self.rows = [{k: _number(v) for k, v in row.items()} for row in csv.DictReader(f)]

    @property
    def figure(self):
        """The path of the figure, compare.png."""
        return os.path.join(self.folder, "compare.png")

    @property
    def table(self):
        """The rows as a pandas DataFrame (when pandas is installed), else as a list of dicts."""
        try:
            import pandas
        except ImportError:
            return self.rows
        return pandas.DataFrame(self.rows)

    def render_path(self, method):
        """The EXR of ``method``'s render."""
        return os.path.join(self.folder, f"{method}.exr")

    def _repr_png_(self):
        with open(self.figure, "rb") as f:
            return f.read()

    def __repr__(self):
        methods = ", ".join(str(r["method"]) for r in self.rows)
        return f"<vitrum.Comparison of {methods} in {self.folder}>"


def compare(scene, methods, time=None, spp=None, out=None, **settings):
    """Run ``vitrum compare`` on ``scene`` (a Scene, a path or a dict) for ``methods`` (a list or
    ``"path,vcm"``), at equal ``time`` seconds or equal ``spp``; further ``settings`` are its
    options (``reference_spp=64``, ``reference="ref.exr"``, ``seed=1``, ``resolution=(w, h)``,
    ``max_depth=8``, ``quiet`` is implied). The files go to ``out`` (default a new temporary
    folder). Returns a Comparison. A scene built from a dict is written to ``out/scene.toml``
    first (its relative file paths then resolve against ``out``)."""
    out = os.fspath(out) if out is not None else tempfile.mkdtemp(prefix="vitrum-compare-")
    if isinstance(scene, dict):
        scene = load(scene)
    if isinstance(scene, Scene):
        if scene.path is None:
            os.makedirs(out, exist_ok=True)
            path = os.path.join(out, "scene.toml")
            with open(path, "w") as f:
                f.write(scene.toml)
            scene = path
        else:
            scene = scene.path
    if not isinstance(methods, str):
        methods = ",".join(methods)
    args = [os.fspath(scene), f"--integrators={methods}", f"--out={out}", "--quiet"]
    args += _arguments(dict(time=time, spp=spp, **settings))
    signal = _vitrum.compare(args)
    if signal is not None:
        raise signal
    return Comparison(out)


def read_exr(path):
    """The RGB image of an EXR file (a ``vitrum render`` output, say) as float32 numpy (height,
    width, 3)."""
    return _vitrum.read_exr(os.fspath(path))[0]


def exr_attributes(path):
    """The header attributes of an EXR file as a dict of strings (``vitrum:spp``, ...)."""
    return dict(_vitrum.read_exr(os.fspath(path))[1])


def methods():
    """The methods, as ``{name: description}`` (``vitrum integrators``)."""
    return dict(_vitrum.methods())
