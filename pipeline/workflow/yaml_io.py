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

#: limits of one YAML file: workflows and link specs are small; tables belong in CSV files
MAX_BYTES = 8 * 1024 * 1024
MAX_NODES = 200_000  # values after alias expansion (an alias bomb expands to billions)
MAX_DEPTH = 64
_T = "tag:yaml.org,2002:"
#: the tags of plain YAML data (a timestamp is kept as its text)
SAFE_SCALARS = {f"{_T}{t}" for t in ("str", "int", "float", "bool", "null", "timestamp")}


class _Walk:
    """Python data from a composed YAML node graph, with a line for every path and limits
    on size and depth (aliases are expanded, so they count each time)."""

    def __init__(self, source: str):
        self.source, self.lines, self.nodes = source, {}, 0
        self._scalar = yaml.SafeLoader("")  # resolves one scalar node at a time

    def fail(self, node: yaml.Node, path: PathKey, msg: str) -> ConfigError:
        return ConfigError(f"{self.source}:{node.start_mark.line + 1}: {_fmt(path)}: {msg}")

    def __call__(self, node: yaml.Node, path: PathKey) -> Any:
        self.nodes += 1
        if self.nodes > MAX_NODES:  # named at the top-level key that holds them
            line = self.lines.get(path[:1], node.start_mark.line + 1)
            raise ConfigError(f"{self.source}:{line}: {_fmt(path[:1])}: more than {MAX_NODES} "
                              "values (after expanding aliases); put large tables in a CSV "
                              "file")
        if len(path) > MAX_DEPTH:
            raise self.fail(node, path, f"nested deeper than {MAX_DEPTH} levels (or an "
                                        "alias that contains itself)")
        self.lines.setdefault(path, node.start_mark.line + 1)
        if isinstance(node, yaml.MappingNode):
            if node.tag != f"{_T}map":
                raise self.fail(node, path, f"tag {node.tag!r} is not allowed (plain YAML only)")
            out: dict[str, Any] = {}
            for key_node, value_node in node.value:
                if not isinstance(key_node, yaml.ScalarNode) or \
                        key_node.tag not in SAFE_SCALARS:
                    raise self.fail(key_node, path, "keys must be plain names or numbers")
                key = key_node.value
                if key in out:
                    raise self.fail(key_node, path + (key,), f"duplicate key {key!r}")
                out[key] = self(value_node, path + (key,))
            return out
        if isinstance(node, yaml.SequenceNode):
            if node.tag != f"{_T}seq":
                raise self.fail(node, path, f"tag {node.tag!r} is not allowed (plain YAML only)")
            return [self(v, path + (i,)) for i, v in enumerate(node.value)]
        if node.tag not in SAFE_SCALARS:
            raise self.fail(node, path, f"tag {node.tag!r} is not allowed (plain YAML only)")
        if node.tag == f"{_T}timestamp":
            return node.value
        try:
            value = self._scalar.construct_object(node)
        except (yaml.YAMLError, ValueError, OverflowError) as exc:
            raise self.fail(node, path, f"cannot read {node.value!r}: {exc}") from None
        # YAML 1.2 floats such as 4.8e5, which YAML 1.1 reads as strings (engineers write
        # them so)
        if isinstance(value, str) and node.style is None and _FLOAT_12.fullmatch(value):
            return float(value)
        return value


def parse_yaml_text(text: str, source: str) -> Any:
    """Plain YAML data from a string (a ``--set`` value) with the file loader's limits and
    tags; ``source`` names it in errors. Empty text is None."""
    if len(text) > MAX_BYTES:
        raise ConfigError(f"{source}: longer than {MAX_BYTES // 2**20} MB")
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{source}: invalid YAML: {getattr(exc, 'problem', exc)}") from None
    except RecursionError:
        raise ConfigError(f"{source}: invalid YAML: nested too deeply") from None
    return None if node is None else _Walk(source)(node, ())


def load_yaml(path: str | Path) -> tuple[Any, dict[PathKey, int]]:
    """Load a YAML file safely; return ``(data, lines)`` with ``lines[path] = line``.

    Plain YAML data only: the safe schema's scalars, mappings with scalar keys and
    sequences; no tags beyond those, at most ``MAX_BYTES``, ``MAX_NODES`` values after
    expanding aliases and ``MAX_DEPTH`` levels.

    Raises
    ------
    ConfigError
        Missing or unreadable file, not UTF-8, YAML syntax error (with line), duplicate keys,
        a tag or key that is not plain data, a limit exceeded.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: file not found")
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise ConfigError(f"{path}: {size / 2**20:.1f} MB; YAML inputs are limited to "
                              f"{MAX_BYTES // 2**20} MB (put large tables in a CSV file)")
        raw = path.read_bytes()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise ConfigError(f"{path}:{line}: not UTF-8 text (byte {exc.start}: "
                          f"{raw[exc.start:exc.start + 1]!r})") from None
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark else str(path)
        raise ConfigError(f"{where}: invalid YAML: {getattr(exc, 'problem', exc)}") from None
    except RecursionError:
        raise ConfigError(f"{path}: invalid YAML: nested too deeply") from None
    if node is None:
        raise ConfigError(f"{path}: empty YAML file")
    walk = _Walk(str(path))
    return walk(node, ()), walk.lines


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


def error_message(err: dict) -> str:
    """What a pydantic error dict says, in the workflow's words."""
    if err["type"] == "extra_forbidden":
        return "unknown key (misspelt?)"
    return err["msg"].removeprefix("Value error, ")


def error_lines(errors, source: str | Path, data: Any, lines: dict[PathKey, int]) -> list[str]:
    """``file:line: yaml.path: message`` of each pydantic error dict."""
    found = []
    for err in errors:
        path = _yaml_path(tuple(err["loc"]), data)
        line = lines.get(path, lines.get((), 1))
        if err["type"] == "missing":
            path = path + tuple(p for p in err["loc"][len(path):] if isinstance(p, str))[-1:]
        found.append((err, path, line))
    paths = [path for _, path, _ in found]
    msgs = []
    for err, path, line in found:
        if err["type"].endswith("_type") and any(len(p) > len(path) and p[:len(path)] == path
                                                 for p in paths):
            continue  # a union branch the input's type never took (a mapping is no list)
        if err["type"] == "literal_error" and not isinstance(err.get("input"), str) and any(
                p == path and e is not err for e, p, _ in found):
            continue  # the words a number could have been instead ("auto"): beside the point
        msgs.append(f"{source}:{line}: {_fmt(path)}: {error_message(err)}")
    return msgs


def config_error(exc: ValidationError, source: str | Path, data: Any,
                 lines: dict[PathKey, int]) -> ConfigError:
    """One ConfigError listing every problem as ``file:line: yaml.path: message``."""
    return ConfigError("\n".join(error_lines(exc.errors(), source, data, lines)))
