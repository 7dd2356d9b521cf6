"""The layers' boundaries (mjx's rule: a curated ``__init__`` over the
internals).  Layers import one way, ``sweeps -> robustness -> planning ->
kernels``; a module of one layer imports another layer only through that
layer's ``__init__`` (``kernels``, ``planning``, ``robustness``, or the
``robustness.physics`` sub-package that keeps MuJoCo out of ``import
robustness``), and only names its ``__all__`` lists."""
import ast
import importlib
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
LAYERS = ("kernels", "planning", "robustness", "sweeps")
BOUNDARIES = ("kernels", "planning", "robustness", "robustness.physics")


def _imports(layer):
    for path in sorted((ROOT / layer).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                yield path, node.lineno, node.module, [a.name for a in node.names]
            elif isinstance(node, ast.Import):
                for a in node.names:
                    yield path, node.lineno, a.name, None


def _where(path, line):
    return f"{path.relative_to(ROOT)}:{line}"


@pytest.mark.parametrize("layer", LAYERS)
def test_layers_import_one_way(layer):
    below = LAYERS[:LAYERS.index(layer)]
    bad = [f"{_where(p, ln)} imports {mod}" for p, ln, mod, _ in _imports(layer)
           if mod.split(".")[0] in LAYERS and mod.split(".")[0] not in below + (layer,)]
    assert not bad, "a lower layer imports a higher one:\n" + "\n".join(bad)


@pytest.mark.parametrize("layer", LAYERS)
def test_other_layers_only_through_their_init(layer):
    bad = []
    for p, ln, mod, names in _imports(layer):
        top = mod.split(".")[0]
        if top not in LAYERS or top == layer:
            continue
        if mod not in BOUNDARIES:
            bad.append(f"{_where(p, ln)}: {mod} is another layer's internals "
                       f"(import from {'robustness.physics' if mod.startswith('robustness.physics') else top})")
            continue
        public = set(importlib.import_module(mod).__all__)
        bad += [f"{_where(p, ln)}: {mod}.{n} is not in {mod}.__all__" for n in names or ()
                if n not in public]
    assert not bad, "\n".join(bad)


def test_the_check_finds_an_internal_import(tmp_path, monkeypatch):
    """The test above can fail: an import of kernels.planar from a planning
    module is reported."""
    fake = tmp_path / "planning"
    fake.mkdir()
    (fake / "x.py").write_text("from kernels.planar import wrap_angle_np\nfrom kernels import rot2\n")
    import sys

    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    found = [(mod, names) for _, _, mod, names in _imports("planning")]
    assert ("kernels.planar", ["wrap_angle_np"]) in found
    with pytest.raises(AssertionError, match="kernels.planar is another layer's internals"):
        test_other_layers_only_through_their_init("planning")


@pytest.mark.parametrize("package", BOUNDARIES)
def test_every_exported_name_exists(package):
    mod = importlib.import_module(package)
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert not missing and len(set(mod.__all__)) == len(mod.__all__), missing


@pytest.mark.parametrize("package", BOUNDARIES)
def test_doors_export_names_not_modules(package):
    """A layer's door lists functions, values and types, never a whole module
    (through which the layers above would reach its internals)."""
    import types

    mod = importlib.import_module(package)
    modules = [n for n in mod.__all__ if isinstance(getattr(mod, n), types.ModuleType)]
    assert not modules, f"{package}.__all__ exports modules: {modules}"


def test_doors_import_each_name_when_first_used():
    """``kernels``, ``planning`` and ``robustness`` are lazy doors
    (``kernels.open_door``): importing them, or the planner's options, the
    support families' names and the thread count, imports no JAX; a name is
    its home module's object, also where a submodule has the same name
    (``kernels.tumble``, module and kernel); an unknown name is an
    AttributeError; a name exported twice is refused."""
    import subprocess
    import sys

    code = """
import sys, types
import kernels, planning, robustness
from planning import PushOptions
from kernels import PLAN_SUPPORTS
from robustness import cpu_threads
light = 'jax' not in sys.modules
import kernels.tumble as module_first      # the submodule loaded before the name is used
from kernels import tumble, open_door
from kernels.tumble import tumble as home
try:
    kernels.no_such_name
    missing = False
except AttributeError:
    missing = True
sys.modules['fake_door'] = types.ModuleType('fake_door')
try:
    open_door('fake_door', [('kernels.planar', ('rot2',)), ('kernels.linsolve', ('rot2',))])
    twice = False
except ValueError as exc:
    twice = "exported twice" in str(exc)
print(light, tumble is home, callable(module_first), missing, twice,
      planning.PushOptions is PushOptions, sorted(set(kernels.__all__) - set(dir(kernels))))
"""
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["True"] * 6 + ["[]"], r.stdout
