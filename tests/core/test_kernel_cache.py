"""Numba's kernel cache is rebuilt when any kernel module changes: numba itself checks
only the file that defines a kernel, so a cached step kept running an edited force law
(a sign flipped in a torque kernel passed the compiled-vs-numpy test until the cache was
cleared by hand)."""

from __future__ import annotations

import re
from pathlib import Path

import pipeline
from pipeline.core import kernel_cache


def _fresh(monkeypatch, root):
    monkeypatch.setattr(kernel_cache, "_ROOT", root)
    monkeypatch.setattr(kernel_cache, "_checked", False)
    kernel_cache.check()


def test_a_changed_kernel_module_clears_the_cached_kernels(tmp_path, monkeypatch):
    for name in kernel_cache.KERNEL_MODULES:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(f"# {name}\n")
    cached = tmp_path / "solver" / "__pycache__" / "dae_kernels.step-1.py311.nbi"
    cached.parent.mkdir()
    cached.write_text("old")
    _fresh(monkeypatch, tmp_path)  # no stamp yet: built by an unknown source
    assert not cached.exists() and (tmp_path / "__pycache__" / "kernels.stamp").is_file()
    cached.write_text("new")
    _fresh(monkeypatch, tmp_path)  # same sources: kept
    assert cached.exists()
    (tmp_path / "dynamics/forces/loads.py").write_text("# an edited force law\n")
    _fresh(monkeypatch, tmp_path)  # a callee changed: rebuilt
    assert not cached.exists()


def test_every_module_with_cached_kernels_is_watched():
    root = Path(pipeline.__file__).parent
    cached = {p.relative_to(root).as_posix() for p in root.rglob("*.py")
              if re.search(r"@njit\([^)]*cache=True", p.read_text())}
    # and every module of the force-element package: the dispatchers are composed from
    # the kinds its modules register (a new module changes them), and they call the
    # python_elements module back in object mode (a cached dispatcher holds that call)
    forces = {p.relative_to(root).as_posix() for p in (root / "dynamics/forces").glob("*.py")}
    assert "objmode" in (root / "dynamics/forces/compiled.py").read_text()
    assert "dynamics/forces/python_elements.py" in forces
    # and the modules whose constants the kernels import (numba compiles a global's value
    # in): a changed constant there must rebuild the kernels too
    constants = set()
    for name in cached:
        for m in re.finditer(r"^from pipeline\.(\w+(?:\.\w+)*) import ([A-Z_, ]+)$",
                             (root / name).read_text(), re.MULTILINE):
            constants.add(m.group(1).replace(".", "/") + ".py")
    assert constants == {"solver/generalized_alpha.py"}, constants
    assert cached | forces | constants == set(kernel_cache.KERNEL_MODULES)
