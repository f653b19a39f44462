"""Reading an experiment file's YAML safely (used by :mod:`tendrilkit.params` only).

- at most ``limits.MAX_EXPERIMENT_BYTES`` are read (a 1 GB file or ``/dev/zero``
  cannot exhaust memory);
- PyYAML's safe loader, refusing a key given twice in one mapping (the last
  one would silently win) and a document whose aliases expand to more than
  ``limits.MAX_YAML_NODES`` values (an alias bomb), or that refers to itself;
- :func:`short_repr`: the bounded ``repr`` every error message uses to show a value.

Every problem is one :class:`~tendrilkit.exceptions.ExperimentError` line
naming the file, the line and the problem.
"""

from __future__ import annotations

import reprlib
from pathlib import Path
from typing import Any

import yaml

from tendrilkit import limits as L
from tendrilkit.exceptions import ExperimentError

__all__ = ["parse_yaml", "read_experiment_text", "short_repr"]

_REPR = reprlib.Repr()
_REPR.maxstring = _REPR.maxother = 60
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = _REPR.maxset = 6
_REPR.maxlevel = 3
_REPR.maxlong = 40


def short_repr(value: Any, limit: int = 80) -> str:
    """``repr`` of a value, bounded in work and length (a YAML alias bomb is never expanded)."""
    text = _REPR.repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def read_experiment_text(path: Path, *, max_bytes: int = L.MAX_EXPERIMENT_BYTES) -> str:
    """The text of an experiment file, at most ``max_bytes`` read (``/dev/zero`` cannot exhaust memory)."""
    try:
        with open(path, "rb") as f:
            raw = f.read(max_bytes + 1)
    except OSError as e:
        raise ExperimentError(f"{path}: cannot read the experiment file ({e.strerror or e.__class__.__name__})") from None
    if len(raw) > max_bytes:
        raise ExperimentError(f"{path}: larger than {max_bytes // 1_000_000} MB; expected an experiment YAML file "
                              f"of a few kB")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ExperimentError(f"{path}: not a text file (expected UTF-8 YAML)") from None


class _ExperimentLoader(yaml.SafeLoader):
    """PyYAML's safe loader that refuses a key given twice in one mapping and
    documents that expand (aliases included) to more than ``limits.MAX_YAML_NODES`` nodes."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen: dict = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge" or not isinstance(key_node, yaml.ScalarNode):
                    continue
                key = self.construct_object(key_node, deep=False)
                try:
                    hash(key)
                except TypeError:  # unhashable: the base class reports it
                    continue
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"key {short_repr(key, 40)} is given twice (first on line {seen[key] + 1})",
                        key_node.start_mark)
                seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)

    def get_single_node(self):
        node = super().get_single_node()
        if node is not None:
            _count_nodes(node, L.MAX_YAML_NODES)
        return node


def _count_nodes(root, limit: int) -> int:
    """Nodes of a YAML graph with every alias expanded; raises past ``limit`` or on a recursive alias."""
    sizes: dict[int, int] = {}

    def size(node) -> int:
        key = id(node)
        if key in sizes:
            if sizes[key] < 0:
                raise yaml.composer.ComposerError(None, None, "an alias refers to its own anchor (recursive data)",
                                                  node.start_mark)
            return sizes[key]
        sizes[key] = -1
        n = 1
        if isinstance(node, yaml.SequenceNode):
            for c in node.value:
                n += size(c)
                if n > limit:
                    break
        elif isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                n += size(k) + size(v)
                if n > limit:
                    break
        if n > limit:
            raise yaml.composer.ComposerError(None, None, f"the document expands to more than {limit} values "
                                              f"(aliases repeated); expected an experiment file", node.start_mark)
        sizes[key] = n
        return n

    return size(root)


def parse_yaml(text: str, *, source: Path | str | None = None) -> Any:
    """Parse YAML text safely: no key twice in a mapping, bounded alias expansion.

    Raises :class:`ExperimentError` naming ``source``, the line and the problem.
    """
    where = f"{source}: " if source is not None else ""
    try:
        return yaml.load(text, Loader=_ExperimentLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        kind = "YAML error" if isinstance(e, (yaml.constructor.ConstructorError, yaml.composer.ComposerError)) \
            else "YAML syntax error"
        raise ExperimentError(f"{where}{kind} at {line}{problem}") from None
    except RecursionError:
        raise ExperimentError(f"{where}YAML nested too deeply; expected an experiment file") from None
