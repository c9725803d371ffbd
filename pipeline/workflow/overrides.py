"""Dotted-path overrides of a workflow's raw YAML data (``--set``, ``quick:``, ``cases``).

``analyses.swing.t_end`` addresses the list item whose ``name`` is ``swing``;
mapping keys that contain dots (coordinates such as ``LUFF.theta``) are matched
greedily (``drivers.LUFF.theta.value``). Values given as text are parsed as
YAML scalars or flow lists; nothing is evaluated as code.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from typing import Any

from pipeline.core.errors import ConfigError


def parse_assignment(text: str) -> tuple[str, Any]:
    """``"path=value"`` -> (path, value parsed as YAML); ConfigError if malformed."""
    path, sep, raw = text.partition("=")
    if not sep or not path.strip():
        raise ConfigError(f"--set {text!r}: expected path=value, e.g. analyses.swing.t_end=0.5")
    from pipeline.workflow.yaml_io import parse_yaml_text

    # plain data with the file loader's limits (no tags, no alias bombs); YAML 1.2 floats
    # such as 4.8e5 are numbers
    value = parse_yaml_text(raw, f"--set {text[:80]!r}") if raw.strip() else None
    return path.strip(), value


def _child(node: Any, parts: list[str], where: str) -> tuple[Any, Any, int]:
    """(container, key, number of parts used) of the next step down from ``node``."""
    if isinstance(node, Mapping):
        for k in range(len(parts), 0, -1):  # longest key first: keys may contain dots
            key = ".".join(parts[:k])
            if key in node:
                return node, key, k
        return node, parts[0], 1
    if isinstance(node, list):
        head = parts[0]
        for i, item in enumerate(node):
            if isinstance(item, Mapping) and (item.get("name") == head or item.get("label") == head):
                return node, i, 1
        if head.lstrip("-").isdigit() and -len(node) <= int(head) < len(node):
            return node, int(head), 1
        names = [item.get("name", item.get("label")) for item in node if isinstance(item, Mapping)]
        raise ConfigError(f"{where}: no item named {head!r}; items: {names}")
    raise ConfigError(f"{where}: cannot go into a {type(node).__name__} value")


def set_path(data: Any, path: str, value: Any, where: str = "--set") -> None:
    """Set ``path`` in ``data`` (in place). Missing (or empty) mappings on the way are
    created, as ``mkdir -p`` does; a misspelt key then meets the schema, which names it."""
    parts = [p for p in path.split(".")]
    if not all(parts):
        raise ConfigError(f"{where} {path}: empty path segment")
    node = data
    while True:
        container, key, used = _child(node, parts, f"{where} {path}")
        parts = parts[used:]
        if not parts:
            container[key] = copy.deepcopy(value)
            return
        if isinstance(container, Mapping) and container.get(key) is None:
            container[key] = {}
        node = container[key]


def apply_overrides(data: Any, overrides: Mapping[str, Any] | Iterable[tuple[str, Any]],
                    where: str = "--set") -> Any:
    """Copy of ``data`` with every (path, value) applied in order."""
    out = copy.deepcopy(data)
    items = overrides.items() if isinstance(overrides, Mapping) else overrides
    for path, value in items:
        set_path(out, path, value, where)
    return out
