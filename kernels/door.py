"""A layer's door that imports what it names when it is first used (PEP 562).

``kernels``, ``planning`` and ``robustness`` list each exported name with its
home module; importing them then costs nothing, and ``from planning import
PushOptions`` imports only :mod:`planning.pushing.options` (and, through it,
:mod:`kernels.families`): no JAX.  That is what lets ``nudge plan-push``'s
parser generate its flags from :class:`planning.PushOptions`' fields before
any work (``--help`` imports no JAX, ``tests/test_answers.py``), and a command
line check ``$NUDGE_THREADS`` with :func:`robustness.cpu_threads`.  A name is
imported once and then held in the package like an eagerly imported one.

A submodule of the same name as an exported function (``kernels.tumble``, the
module, and ``kernels.tumble``, the kernel the door exports) does not shadow
the function: the import system's binding of the submodule on its package is
ignored for a door's names (``from kernels.tumble import X`` still reads the
module from ``sys.modules``).
"""
from __future__ import annotations

import importlib
import sys
import types


class _Door(types.ModuleType):
    """A package module whose ``_homes`` names are imported on first use."""

    def __getattr__(self, name):
        try:
            home, attr = self.__dict__["_homes"][name]
        except KeyError:
            raise AttributeError(f"module {self.__name__!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(home), attr)
        self.__dict__[name] = value
        return value

    def __setattr__(self, name, value):
        if isinstance(value, types.ModuleType) and name in self.__dict__.get("_homes", ()):
            return   # a submodule bound over a name the door exports (module docstring)
        super().__setattr__(name, value)

    def __dir__(self):
        return sorted(set(self.__dict__) | set(self.__dict__.get("_homes", ())))


def open_door(package: str, homes, aliases: dict | None = None) -> list:
    """Make the package ``package`` (already in ``sys.modules``: call it from its
    ``__init__``) a door over ``homes`` (pairs ``(home module, the names it
    exports)``; a module may come more than once) and ``aliases`` (exported
    name -> ``(home module, name there)``).  Returns the exported names, in
    order (the package's ``__all__``).

    Raises:
      ValueError: a name exported twice.
    """
    where = {}
    pairs = [(name, (home, name)) for home, names in homes for name in names]
    for name, place in pairs + list((aliases or {}).items()):
        if name in where:
            raise ValueError(f"{package}: {name!r} exported twice ({where[name][0]}, {place[0]})")
        where[name] = place
    module = sys.modules[package]
    module.__class__ = _Door
    module.__dict__["_homes"] = where
    return list(where)
