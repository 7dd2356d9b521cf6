"""Length units at the edge: the one table of units and the one rule that reads them.

Inside nudge every length is in metres.  At the edge a length may be written

- as a plain number: metres in a config (study or certify), the part's own
  unit in a part file (its ``units:``, else its CAD file's unit, else metres);
- as a string with a unit: ``"0.05 mm"``, ``"50um"``, ``"0.002 in"``, ``"1.5cm"``,
  ``"0.01 m"`` (:data:`UNITS`), converted here, once.

:func:`lengths_to_metres` applies the rule to a config document before it is
validated: the fields of :data:`CONFIG_LENGTHS` (tolerances, execution errors,
success tolerances, the planner's lengths, ranges of them) are the ones where
a unit string is read; anywhere else a unit string is a type error of the
field that names it.
"""
from __future__ import annotations

import math
import re

#: metres per unit (the names a part file's ``units:`` and a unit string accept)
UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "in": 0.0254}

UNIT_NAMES = " | ".join(UNITS)

_LENGTH = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-zA-Z]+)\s*$")


class LengthError(ValueError):
    """A length that cannot be read (the message names the field and the fix)."""


class UnitMissingError(ValueError):
    """A file that carries no unit and whose size is implausible in metres (the
    message names the file, its size and the fix)."""


def unit_factor(name, field: str = "units") -> float:
    """Metres per ``name`` (one of :data:`UNITS`).

    Raises:
      LengthError: naming ``field`` and the units accepted.
    """
    if isinstance(name, str) and name.strip().lower() in UNITS:
        return UNITS[name.strip().lower()]
    raise LengthError(f"{field}: expected one of {UNIT_NAMES}, got {name!r}")


def parse_length(v, field: str, default_unit: float = 1.0) -> float:
    """A length in metres from a number (in ``default_unit`` metres per unit) or
    a string ``'<number> <unit>'`` (:data:`UNITS`).

    Raises:
      LengthError: a bool, another type, an unknown unit or a non-finite value;
        the message names ``field``.
    """
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        raise LengthError(f"{field}: expected a length (a number, or with a unit such as "
                          f"'0.05 mm'), got {v!r}")
    if isinstance(v, str):
        m = _LENGTH.match(v)
        if m is None or m.group(2).lower() not in UNITS:
            raise LengthError(f"{field}: expected a length with a unit ({UNIT_NAMES}), e.g. "
                              f"'0.05 mm', got {v!r}")
        x = float(m.group(1)) * UNITS[m.group(2).lower()]
    else:
        x = float(v) * default_unit
    if not math.isfinite(x):
        raise LengthError(f"{field}: must be a finite length, got {v!r}")
    return x


def is_length_string(v) -> bool:
    """Whether ``v`` is a string of the form ``'<number> <unit>'``."""
    return isinstance(v, str) and _LENGTH.match(v) is not None


#: The config fields (section -> fields) that hold a length in metres, or a list of them
CONFIG_LENGTHS = {
    "tolerances": ("tau_v", "tau_com", "sigma_v"),
    "execution": ("start_xy", "distance_abs", "tumble_slip_xy"),
    "eps": ("pos_eps_m",),
    "friction": ("c",),
    "planner": ("support_c", "tumble_tau_v", "workspace"),
}


def lengths_to_metres(doc: dict, prefix: str = "") -> dict:
    """``doc`` (a config document) with every unit string in a length field of
    :data:`CONFIG_LENGTHS` converted to metres (a number); other values as they
    are (the config's validation reports them).  Returns a new dict; ``doc`` is
    not changed.

    Raises:
      LengthError: a string in a length field that is not a length; the
        message names the dotted field (``tolerances.tau_v``).
    """
    if not isinstance(doc, dict):
        return doc
    out = dict(doc)
    for section, fields in CONFIG_LENGTHS.items():
        sec = doc.get(section)
        if not isinstance(sec, dict):
            continue
        new = dict(sec)
        for f in fields:
            if f in sec:
                new[f] = _convert(sec[f], f"{prefix}{section}.{f}")
        out[section] = new
    return out


def at_path(path: str, value):
    """A value set at the dotted config ``path`` (a swept axis, a ``--set``):
    a length string (or list of them) in metres when ``path`` is a length field
    of :data:`CONFIG_LENGTHS`, else ``value`` as it is."""
    head, _, last = path.rpartition(".")
    if last in CONFIG_LENGTHS.get(head, ()):
        return _convert(value, path)
    return value


def _convert(v, field: str):
    if isinstance(v, str):
        return parse_length(v, field)
    if isinstance(v, (list, tuple)):
        return [_convert(x, f"{field}[{i}]") for i, x in enumerate(v)]
    return v
