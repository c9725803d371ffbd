"""No user text is ever evaluated or run: the package calls no eval, exec or compile,
starts no subprocess and no shell (the only way a command could run from an input was a
gmsh script, which is scanned: tests/workflows/test_reliability.py)."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "pipeline"
FORBIDDEN_CALLS = {"eval", "exec", "compile", "__import__"}
FORBIDDEN_MODULES = {"subprocess", "pty"}
FORBIDDEN_ATTRS = {("os", "system"), ("os", "popen"), ("os", "execv"), ("os", "execvp"),
                   ("os", "spawnv"), ("yaml", "load"), ("yaml", "unsafe_load"),
                   ("pickle", "loads"), ("pickle", "load")}


def test_the_package_evaluates_and_runs_nothing_from_its_inputs():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            where = f"{path.relative_to(PACKAGE.parent)}:{getattr(node, 'lineno', 0)}"
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                    and node.func.id in FORBIDDEN_CALLS:
                found.append(f"{where}: {node.func.id}()")
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
                    and (node.value.id, node.attr) in FORBIDDEN_ATTRS:
                found.append(f"{where}: {node.value.id}.{node.attr}")
            if isinstance(node, ast.Import | ast.ImportFrom):
                names = [a.name for a in node.names] if isinstance(node, ast.Import) \
                    else [node.module or ""]
                found += [f"{where}: import {n}" for n in names
                          if n.split(".")[0] in FORBIDDEN_MODULES]
    assert not found, "\n".join(found)
