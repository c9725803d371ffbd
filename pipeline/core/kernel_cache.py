"""Numba's on-disk kernel cache, kept consistent with the package's sources.

Numba checks a cached kernel against the source file that defines it, not against the
files of the kernels it calls: after an edit or an upgrade of ``pipeline.dynamics.forces.
loads``, the cached ``pipeline.solver.dae_kernels.step`` would still run the old force
law, silently. Each kernel module calls :func:`check` when it is imported (before any of
its kernels runs): the first call in a process hashes every kernel module's source and,
if the hash differs from the one the cache was built with, removes the package's cached
kernels so that they compile afresh.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["KERNEL_MODULES", "check"]

_ROOT = Path(__file__).resolve().parents[1]

#: every module (relative to the package) that defines cached numba kernels or constants
#: compiled into them: every module of the force-element package, whose kinds the
#: dispatchers are composed from (a new element module changes the compiled step too)
KERNEL_MODULES = ("kinematics/compiled.py", "dynamics/compiled.py", "solver/dae_kernels.py",
                  # its constants (NEWTON_SHARE, REFRESH_AFTER) are compiled into the step
                  "solver/generalized_alpha.py",
                  *sorted(p.relative_to(_ROOT).as_posix()
                          for p in (_ROOT / "dynamics" / "forces").glob("*.py")))

_checked = False


def _stamp() -> str:
    h = hashlib.sha256()
    for name in KERNEL_MODULES:
        h.update(name.encode())
        h.update((_ROOT / name).read_bytes())
    return h.hexdigest()


def check() -> None:
    """Remove the package's cached kernels if any kernel module changed since they were
    built (once per process; a cache that cannot be written is left to numba)."""
    global _checked
    if _checked:
        return
    _checked = True
    stamp_file = _ROOT / "__pycache__" / "kernels.stamp"
    stamp = _stamp()
    try:
        if stamp_file.is_file() and stamp_file.read_text() == stamp:
            return
        for cached in _ROOT.rglob("__pycache__/*.nb[ic]"):
            cached.unlink(missing_ok=True)
        stamp_file.parent.mkdir(exist_ok=True)
        tmp = stamp_file.with_name(f"kernels.stamp.{os.getpid()}")
        tmp.write_text(stamp)
        os.replace(tmp, stamp_file)
    except OSError:
        pass  # a read-only install: numba keeps its cache elsewhere


check()  # on import: the kernel modules import this module before defining their kernels
