"""Reading YAML for nudge: one loader for part files, certification configs and
studies, with one-line errors.

Two departures from PyYAML's YAML 1.1 defaults, both towards YAML 1.2:

* ``1e-5``, ``1E9`` and ``.5e3`` are numbers (YAML 1.1 needs a dot in the
  mantissa, so PyYAML reads ``1e-5`` as the string ``"1e-5"``: a part file
  rejected ``1e9`` as "expected a number" while a config silently took
  ``1e5``).  Integers stay integers.
* A key given twice in one mapping is an error (PyYAML keeps the last one).
"""
from __future__ import annotations

import pathlib
import re
from typing import Union

import yaml

from sweeps.errors import UserError


class YamlError(UserError):
    """A YAML file that cannot be read; the one-line message names the file and where."""


class Loader(yaml.SafeLoader):
    """``yaml.SafeLoader`` with YAML 1.2 floats and unique keys."""


# a private copy of the resolver table: never change PyYAML's SafeLoader for others
Loader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)(?:[eE][-+]?[0-9]+)?$"),
    list("-+0123456789."))


def _construct_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"key {key!r} is given twice", key_node.start_mark)
        seen.add(key)
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def parse_yaml(text: str):
    """Parse YAML text with :class:`Loader`.

    Raises:
      YamlError: a one-line message with the line and column.
    """
    try:
        return yaml.load(text, Loader=Loader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.YAMLError as exc:
        raise YamlError(f"YAML syntax error: {yaml_message(exc)}") from None


def read_yaml(path: Union[str, pathlib.Path], what: str = "file") -> tuple[object, str]:
    """Read and parse a YAML file; returns ``(document, text)``.

    Args:
      path: the file.
      what: what the file is, for messages (``"part file"``, ``"config"``).

    Raises:
      YamlError: missing or unreadable file or a syntax error; one line starting
        with the path.
    """
    path = pathlib.Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise YamlError(f"{path}: no such {what}") from None
    except IsADirectoryError:
        raise YamlError(f"{path}: is a directory, expected a {what} (.yaml)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise YamlError(f"{path}: cannot read the {what} ({exc})") from None
    try:
        return parse_yaml(text), text
    except YamlError as exc:
        raise YamlError(f"{path}: {exc}") from None


def dump_yaml(doc) -> str:
    """YAML text of a plain document (block style, keys in their order)."""
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=100)


def yaml_message(exc: yaml.YAMLError) -> str:
    """A one-line description of a YAML error with its line and column."""
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or str(exc)
    context = getattr(exc, "context", None)
    text = f"{context}, {problem}" if context else problem
    text = " ".join(str(text).split())
    if mark is not None:
        text += f" (line {mark.line + 1}, column {mark.column + 1})"
    return text
