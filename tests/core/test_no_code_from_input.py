"""No user text is ever evaluated or run: the package calls no eval, exec or compile and
starts no shell; its one subprocess is its own meshing process, whose command is fixed
(the only way a command could run from an input was a gmsh script, which is scanned:
tests/workflows/test_reliability.py)."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "pipeline"
FORBIDDEN_CALLS = {"eval", "exec", "compile", "__import__"}
FORBIDDEN_MODULES = {"subprocess", "pty"}
#: the one module that may start a process: the meshing child, a fixed command
SUBPROCESS_ALLOWED = "pipeline/meshing/budget.py"
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
                          if n.split(".")[0] in FORBIDDEN_MODULES
                          and not (n == "subprocess" and where.startswith(SUBPROCESS_ALLOWED))]
    assert not found, "\n".join(found)


def test_the_one_subprocess_runs_the_package_s_own_meshing_child_with_a_fixed_command():
    """Every subprocess call in the allowed module has a literal argument list
    ``[sys.executable, "-m", "pipeline.meshing.mesh_child", <folder>]`` and no shell."""
    tree = ast.parse((PACKAGE.parent / SUBPROCESS_ALLOWED).read_text())
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call)
             and isinstance(n.func, ast.Attribute) and isinstance(n.func.value, ast.Name)
             and n.func.value.id == "subprocess"]
    assert len(calls) == 1
    argv = calls[0].args[0]
    assert isinstance(argv, ast.List) and ast.unparse(argv.elts[0]) == "sys.executable"
    assert [ast.literal_eval(e) for e in argv.elts[1:3]] == ["-m", "pipeline.meshing.mesh_child"]
    assert all(k.arg != "shell" for k in calls[0].keywords)
