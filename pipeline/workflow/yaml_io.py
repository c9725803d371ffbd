"""YAML loading that remembers where every value came from.

Errors in user files must name the file, the line and the YAML path and say
what was expected; pydantic's ``ValidationError`` only knows the path, so we
keep a map from path to line while loading. Duplicate keys are rejected (plain
PyYAML silently keeps the last one).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from pipeline.core.errors import ConfigError

PathKey = tuple[str | int, ...]
_FLOAT_12 = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)")


def _walk(node: yaml.Node, path: PathKey, lines: dict[PathKey, int], source: str) -> Any:
    lines[path] = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        out: dict[str, Any] = {}
        for key_node, value_node in node.value:
            key = yaml.safe_load(yaml.serialize(key_node)) if not isinstance(
                key_node, yaml.ScalarNode) else key_node.value
            if key in out:
                raise ConfigError(f"{source}:{key_node.start_mark.line + 1}: "
                                  f"{_fmt(path + (key,))}: duplicate key {key!r}")
            out[key] = _walk(value_node, path + (key,), lines, source)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_walk(v, path + (i,), lines, source) for i, v in enumerate(node.value)]
    # Resolve scalars with the safe loader's rules (numbers, bools, null), plus YAML 1.2
    # floats such as 4.8e5 that YAML 1.1 reads as strings (engineers write them so).
    value = yaml.safe_load(yaml.serialize(node))
    if isinstance(value, str) and node.style is None and _FLOAT_12.fullmatch(value):
        return float(value)
    return value


def load_yaml(path: str | Path) -> tuple[Any, dict[PathKey, int]]:
    """Load a YAML file safely; return ``(data, lines)`` with ``lines[path] = line``.

    Raises
    ------
    ConfigError
        Missing file, YAML syntax error (with line) or duplicate keys.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: file not found")
    text = path.read_text()
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark else str(path)
        raise ConfigError(f"{where}: invalid YAML: {getattr(exc, 'problem', exc)}") from exc
    if node is None:
        raise ConfigError(f"{path}: empty YAML file")
    lines: dict[PathKey, int] = {}
    return _walk(node, (), lines, str(path)), lines


def _fmt(path: PathKey) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "<root>"


def _yaml_path(loc: tuple, data: Any) -> PathKey:
    """Drop pydantic's union-tag entries from ``loc``, keeping real YAML keys."""
    path: list[str | int] = []
    node = data
    for part in loc:
        if isinstance(node, dict) and part in node or isinstance(node, list) and isinstance(part, int) and part < len(node):
            node = node[part]
            path.append(part)
    return tuple(path)


def config_error(exc: ValidationError, source: str | Path, data: Any,
                 lines: dict[PathKey, int]) -> ConfigError:
    """One ConfigError listing every problem as ``file:line: yaml.path: message``."""
    msgs = []
    for err in exc.errors():
        path = _yaml_path(tuple(err["loc"]), data)
        line = lines.get(path, lines.get((), 1))
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown key (misspelt?)"
        elif err["type"] == "missing":
            path = path + tuple(p for p in err["loc"][len(path):] if isinstance(p, str))[-1:]
        msgs.append(f"{source}:{line}: {_fmt(path)}: {msg}")
    return ConfigError("\n".join(msgs))
