"""The package's dependency rules (STYLE.md §4), checked on the import statements."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "pipeline"

#: third-party module -> the only subpackages allowed to import it
ONLY_IN = {
    "gmsh": ("meshing",),
    "pyvista": ("post",),
    "pydantic": ("workflow", "study"),
    "yaml": ("workflow",),
    "numba": ("kinematics", "dynamics", "solver"),
    "distributed": ("core", "study"),  # core: the one case runner
    "dask": ("core", "study"),
    "pyarrow": ("study", "workflow"),  # workflow: the run's results store
}
#: subpackage -> pipeline subpackages it must not import (the solver side stays FE-free)
FORBIDDEN = {
    "kinematics": ("meshing", "fem", "modes", "invariants", "dynamics", "post", "workflow"),
    "dynamics": ("meshing", "fem", "modes", "post", "workflow", "solver"),
    "solver": ("meshing", "fem", "modes", "invariants", "post", "workflow"),
    "invariants": ("post", "workflow"),
    "fem": ("modes", "invariants", "kinematics", "dynamics", "post", "workflow"),
    "meshing": ("fem", "modes", "invariants", "kinematics", "dynamics", "post", "workflow"),
    "core": ("meshing", "fem", "modes", "invariants", "kinematics", "dynamics", "post",
             "workflow", "study"),
    # studies sit on top of workflows; nothing below imports them
    "workflow": ("study",),
    "post": ("study", "workflow"),
}
FE_LIBS = ("skfem", "gmsh")


def _imports(path: Path):
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module


def _modules():
    return sorted(p for p in ROOT.rglob("*.py"))


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_module_respects_layers(path):
    sub = path.relative_to(ROOT).parts[0] if len(path.relative_to(ROOT).parts) > 1 else ""
    for name in _imports(path):
        top = name.split(".")[0]
        if top in ONLY_IN:
            assert sub in ONLY_IN[top], f"{path.name} imports {top} outside {ONLY_IN[top]}"
        if sub in ("kinematics", "dynamics", "solver"):
            assert top not in FE_LIBS, f"{path.name}: the solver side imports {top}"
        if top == "pipeline" and "." in name:
            target = name.split(".")[1]
            assert target not in FORBIDDEN.get(sub, ()), \
                f"{sub}/{path.name} imports pipeline.{target} against the layering"


def _imported_modules(path: Path):
    """Every ``pipeline`` name a module imports (``from a import b`` gives ``a.b``)."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names if a.name.startswith("pipeline"))
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                and node.module.startswith("pipeline"):
            # resolved by the caller to the submodule ``a.b`` or else the module ``a``
            yield from (f"{node.module}.{a.name}" for a in node.names)


def _module_name(path: Path) -> str:
    parts = ("pipeline",) + path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def test_no_import_cycles():
    """No module imports, even inside a function, a module that imports it back (STYLE.md §4)."""
    modules = {_module_name(p): p for p in _modules()}
    graph = {}
    for name, path in modules.items():
        targets = set()
        for imported in _imported_modules(path):
            # ``from pipeline.a import b`` names module pipeline.a.b when that is a module
            while imported and imported not in modules:
                imported = imported.rpartition(".")[0]
            if imported and imported != name:
                targets.add(imported)
        graph[name] = targets
    cycles, state = [], {}

    def visit(node, stack):
        state[node] = "open"
        for nxt in sorted(graph[node]):
            if state.get(nxt) == "open":
                cycles.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt, stack + [nxt])
        state[node] = "done"

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)
