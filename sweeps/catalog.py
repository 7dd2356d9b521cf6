"""The bundled parts and studies, and how a name in a command or a config finds a file.

Bundled files live in the repository's ``examples/`` folder (nudge is installed
in place, ``pip install -e .``): parts (``examples/<name>.yaml``; the CAD files
some of them name, ``examples/bracket.stl``, ``examples/plate.dxf``), certification
configs (``examples/certify_*.yaml``) and parameter studies
(``examples/studies/<name>.yaml``).

Resolution order for a part or study reference: a path as given (relative to
the referring config's folder, then to the working folder), then a bundled name
with or without ``.yaml``.
"""
from __future__ import annotations

import pathlib
from typing import Optional, Union

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
STUDIES = EXAMPLES / "studies"


def bundled_parts() -> dict[str, pathlib.Path]:
    """``{name: path}`` of the bundled part files."""
    return {p.stem: p for p in sorted(EXAMPLES.glob("*.yaml")) if not p.stem.startswith("certify_")}


def bundled_studies() -> dict[str, pathlib.Path]:
    """``{name: path}`` of the bundled parameter studies."""
    return {p.stem: p for p in sorted(STUDIES.glob("*.yaml"))}


def bundled_certify_configs() -> dict[str, pathlib.Path]:
    """``{name: path}`` of the bundled certification configs."""
    return {p.stem: p for p in sorted(EXAMPLES.glob("certify_*.yaml"))}


def _find(ref: str, base: Optional[pathlib.Path], bundled: dict,
          cad: bool = False) -> Optional[pathlib.Path]:
    p = pathlib.Path(ref).expanduser()
    candidates = [p] if p.is_absolute() else ([base / p] if base is not None else []) + [p]
    for c in candidates:
        if c.is_file():
            return c
    name = p.name[:-5] if p.name.endswith(".yaml") else p.name
    if p.parent == pathlib.Path(".") and name in bundled:
        return bundled[name]
    if cad and p.parent == pathlib.Path(".") and _is_cad(p) \
            and (EXAMPLES / p.name).is_file():   # a bundled CAD file (examples/bracket.stl)
        return EXAMPLES / p.name
    return None


def _is_cad(p: pathlib.Path) -> bool:
    from sweeps.cad import cad_kind

    return cad_kind(p) is not None


def find_part(ref: Union[str, pathlib.Path], base: Optional[pathlib.Path] = None) -> pathlib.Path:
    """The part file ``ref`` names (see the module docstring).

    Raises:
      FileNotFoundError: with a message listing the bundled part names.
    """
    got = _find(str(ref), base, bundled_parts(), cad=True)
    if got is None:
        raise FileNotFoundError(f"no such part file, and no bundled part of that name (bundled: "
                                f"{', '.join(bundled_parts())})")
    return got


def find_study(ref: Union[str, pathlib.Path]) -> pathlib.Path:
    """The study config ``ref`` names: a file in the working folder, else a bundled study.

    Raises:
      FileNotFoundError: with a message listing the bundled studies.
    """
    got = _find(str(ref), None, bundled_studies())
    if got is None:
        raise FileNotFoundError(f"no such study config, and no bundled study of that name "
                                f"(bundled: {', '.join(bundled_studies())})")
    return got
