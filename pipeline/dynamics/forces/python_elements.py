"""Force elements without a compiled form (a user's own class) inside the compiled step.

Such an element keeps its numpy methods (the contract of :mod:`.base`): the compiled
dispatchers of :mod:`.compiled` call them back through numba's object mode, so a machine
carrying one runs the same compiled Newton step as every other machine, with this one
element evaluated in Python (states of its own included).

How the call finds its element: :func:`register` files (the system, the element) under an
integer key that the element's row of the flat data carries (``ints[e, 0]``); the row's
time is its history factor (:data:`TIME`: the factor of such an element is t itself). The
entry lives as long as the flat data that names it (a finaliser on its ``ints`` array) and
holds the system weakly, so a run's data and its system go away together.

An evaluation that fails with an arithmetic, value or linear-algebra error writes NaN,
which the step treats as a failed evaluation (a smaller step follows), as it does for a
compiled element whose force is not finite. Any other exception, and the pipeline's own
errors (a ConfigError is a ValueError too), propagate to the caller.
"""

from __future__ import annotations

import itertools
import weakref

import numpy as np

from pipeline.core.errors import PipelineError
from pipeline.dynamics.forces.base import element_forces
from pipeline.kinematics.poses import TreeState

__all__ = ["PYTHON_KIND", "TIME", "element_force", "element_potential", "element_rates",
           "register"]

#: ``kind`` of an element evaluated by its numpy methods (the compiled kinds are >= 0)
PYTHON_KIND = -1

#: the "history" of such an element: its factor is the time itself (s)
TIME = object()

_FAILED = (ArithmeticError, ValueError, np.linalg.LinAlgError)
_KEYS = itertools.count()
_LIVE: dict[int, tuple[weakref.ref, object]] = {}


def register(system, element, owner: np.ndarray) -> int:
    """The key under which the compiled step finds ``element`` of ``system``, filed for
    as long as ``owner`` (the flat data's ``ints`` array) lives."""
    key = next(_KEYS)
    _LIVE[key] = (weakref.ref(system), element)
    weakref.finalize(owner, _LIVE.pop, key, None)
    return key


def _entry(key: int):
    ref, element = _LIVE[int(key)]
    system = ref()
    if system is None:  # pragma: no cover - the data outlived its system
        raise RuntimeError(f"force element {getattr(element, 'name', key)!r}: its system "
                           "is gone")
    return system, element


def _tree(A, dA):
    """The TreeState the contract promises (poses and dA/dq), from the compiled step's own
    link poses A (L, 4, 4) and dA (L, n, 4, 4)."""
    return TreeState(np.asarray(A), np.asarray(dA), None, None)


def element_force(key, q, v, z, A, dA, t, Q, Qnc) -> None:
    """Add the element's Q (n,) to Q and its non-conservative part to Qnc at (q, v) (n,),
    the system's element states z (nz,), the link poses A, dA and time t (s)."""
    system, f = _entry(key)
    q, v = np.asarray(q), np.asarray(v)
    try:
        F, Fnc = element_forces(system, f, _tree(A, dA), q, v, float(t),
                                np.asarray(z) if system.state_slices else None)
    except PipelineError:
        raise
    except _FAILED:
        F = Fnc = np.full(q.shape, np.nan)
    Q += F
    Qnc += Fnc


def element_rates(key, q, v, z, A, dA, t, zd) -> None:
    """Write the element's state rates into its slice of zd (nz,) at (q, v, z, t)."""
    system, f = _entry(key)
    sl = next(s for g, s in system.state_slices if g is f)
    q, v, z = np.asarray(q), np.asarray(v), np.asarray(z)
    try:
        zd[sl] = f.state_rates(system, _tree(A, dA), q, v, float(t), z[sl])
    except PipelineError:
        raise
    except _FAILED:
        zd[sl] = np.nan


def element_potential(key, q, A, dA) -> float:
    """V (J) of the element's conservative part at q (n,)."""
    system, f = _entry(key)
    q = np.asarray(q)
    try:
        return float(f.potential_energy(system, _tree(A, dA), q))
    except PipelineError:
        raise
    except _FAILED:
        return float("nan")
