"""The force elements of a system in compiled form: packed into one :class:`~pipeline.
dynamics.forces.markers.ForceData` and evaluated by the kernels their own modules define:
the physics of every built-in element, once. The compiled step calls the dispatchers below;
the element classes' methods, statics, linearisation, kinetostatics and the energies
evaluate the same kernels through :class:`CompiledForces` (``System.compiled_forces``).

An element kind lives in one module of this package: its class (a ``KIND`` number, the
YAML ``TYPE`` name and ``pack(mech, markers)``, its rows of the flat data), its kernels and
a module-level ``KERNELS`` tuple of :class:`~pipeline.dynamics.forces.base.Kernels`. The
modules are found here (:func:`element_modules`) and the dispatchers are filled from
their kernels (numba calls a compiled function only by name, so each dispatcher is one
compiled function per term with a slot per kind, :func:`_dispatcher`); the YAML
vocabulary :data:`~pipeline.dynamics.forces.FORCES` follows from the same registry.
Adding a kind touches its own module only (``docs/force_elements.md`` works one through);
``tests/solver/test_compiled_step.py`` fails for an element class without its compiled
form, and ``tests/dynamics/test_forces_oracle.py`` compares every kernel with its numpy
oracle. The on-disk kernel cache is rebuilt when any module of this package changes
(:mod:`pipeline.core.kernel_cache`).

An element without a compiled form (a user's own class) is packed as
:data:`~pipeline.dynamics.forces.python_elements.PYTHON_KIND`: the dispatchers call its
numpy methods back (:mod:`.python_elements`), inside the same compiled step.
"""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import njit, objmode

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)
from pipeline.dynamics.forces import python_elements as P
from pipeline.dynamics.forces.base import ForceElement, Kernels, Load
from pipeline.dynamics.forces.loads import history_rates, history_values
from pipeline.dynamics.forces.markers import ForceData, MarkerTable, line_geometry, line_loads

__all__ = ["KERNELS", "CompiledForces", "Kernels", "compile_forces", "element_force",
           "element_modules", "element_types", "force_factors", "generalized_forces",
           "has_kernels", "line_push", "potential", "state_rates", "uncompiled"]

PYTHON_KIND = P.PYTHON_KIND
_PACKAGE = "pipeline.dynamics.forces"
#: the most kinds the dispatchers hold (a registry of more is refused at import)
MAX_KINDS = 24


def element_modules() -> tuple:
    """The modules of :mod:`pipeline.dynamics.forces` that register element kinds (a
    module-level ``KERNELS`` tuple of :class:`Kernels`), by name."""
    package = importlib.import_module(_PACKAGE)
    found = []
    for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda m: m.name):
        if info.name == "compiled":
            continue
        module = importlib.import_module(f"{_PACKAGE}.{info.name}")
        if isinstance(getattr(module, "KERNELS", None), tuple):
            found.append(module)
    return tuple(found)


def _registry(modules) -> dict:
    """kind -> :class:`Kernels` of the modules' kinds; TypeError for a registration that
    cannot work (a kind or YAML type twice, a class without its own TYPE, a term missing)."""
    out, types = {}, {}
    for module in modules:
        for k in module.KERNELS:
            where = f"{module.__name__}.KERNELS"
            if not isinstance(k, Kernels) or not k.classes:
                raise TypeError(f"{where}: expected Kernels((classes...), potential, ...)")
            if not isinstance(k.kind, int) or k.kind < 0 or k.kind in out:
                raise TypeError(f"{where}: kind {k.kind!r} of {k.classes[0].__name__} is "
                                "taken or not an integer >= 0; give the class a KIND of its own")
            if k.potential is None or (k.push is None) == (k.force is None):
                raise TypeError(f"{where}: {k.classes[0].__name__} needs a potential and "
                                "either a push (a line element) or a force")
            for cls in k.classes:
                name = vars(cls).get("TYPE")
                if not isinstance(name, str) or name in types or cls.KIND != k.kind:
                    raise TypeError(f"{where}: {cls.__name__} needs a TYPE of its own (got "
                                    f"{name!r}) and KIND {k.kind}")
                types[name] = cls
            out[k.kind] = k
    if len(out) > MAX_KINDS:
        raise TypeError(f"{len(out)} element kinds registered: the dispatchers hold "
                        f"{MAX_KINDS} (raise MAX_KINDS in {__name__} and add its slots)")
    return out


#: kind -> its :class:`Kernels`, from every element module
KERNELS = _registry(element_modules())


def element_types() -> dict:
    """YAML ``type:`` -> element class, of every registered class."""
    return {vars(c)["TYPE"]: c for k in KERNELS.values() for c in k.classes}


# ---------------------------------------------------------------- composed dispatchers
def _dispatcher(term: str, default):
    """A compiled ``(kind, *args)`` calling ``term``'s kernel of that kind with args, and
    returning ``default`` for a kind without one.

    One flat function per term with a slot per kind (unused slots hold a kind no element
    has): numba calls a compiled function only by name, and a chain of one compiled
    closure per kind gave the same code but took the main job's first run 30 s more CPU
    to compile (146 s against 113 s)."""
    @njit
    def unused(*args):
        return default

    entries = [(int(kind), getattr(k, term)) for kind, k in KERNELS.items()
               if getattr(k, term) is not None]
    entries += [(-2, unused)] * (MAX_KINDS - len(entries))
    (k0, k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15, k16, k17, k18,
     k19, k20, k21, k22, k23) = [k for k, _ in entries]
    (f0, f1, f2, f3, f4, f5, f6, f7, f8, f9, f10, f11, f12, f13, f14, f15, f16, f17, f18,
     f19, f20, f21, f22, f23) = [f for _, f in entries]

    @njit
    def dispatch(kind, *args):
        if kind == k0:
            return f0(*args)
        if kind == k1:
            return f1(*args)
        if kind == k2:
            return f2(*args)
        if kind == k3:
            return f3(*args)
        if kind == k4:
            return f4(*args)
        if kind == k5:
            return f5(*args)
        if kind == k6:
            return f6(*args)
        if kind == k7:
            return f7(*args)
        if kind == k8:
            return f8(*args)
        if kind == k9:
            return f9(*args)
        if kind == k10:
            return f10(*args)
        if kind == k11:
            return f11(*args)
        if kind == k12:
            return f12(*args)
        if kind == k13:
            return f13(*args)
        if kind == k14:
            return f14(*args)
        if kind == k15:
            return f15(*args)
        if kind == k16:
            return f16(*args)
        if kind == k17:
            return f17(*args)
        if kind == k18:
            return f18(*args)
        if kind == k19:
            return f19(*args)
        if kind == k20:
            return f20(*args)
        if kind == k21:
            return f21(*args)
        if kind == k22:
            return f22(*args)
        if kind == k23:
            return f23(*args)
        return default
    return dispatch


def _member(kinds):
    """A compiled ``(kind) -> bool``: is kind among ``kinds``?"""
    members = tuple(int(k) for k in kinds)

    @njit
    def test(kind):
        for k in members:
            if kind == k:
                return True
        return False
    return test


_push = _dispatcher("push", (np.nan, np.nan))
_force = _dispatcher("force", None)
_potential = _dispatcher("potential", 0.0)
_loads = _dispatcher("loads", 0)
_rates = _dispatcher("rates", None)
_is_line = _member([kind for kind, k in KERNELS.items() if k.push is not None])


def has_kernels(f) -> bool:
    """Does force element ``f`` have a compiled form (its exact class registered)?"""
    entry = KERNELS.get(getattr(type(f), "KIND", None))
    return entry is not None and type(f) in entry.classes


def uncompiled(forces) -> list[str]:
    """The names of the elements among ``forces`` that have no compiled form."""
    return [getattr(f, "name", type(f).__name__) for f in forces if not has_kernels(f)]


def compile_forces(system, forces=None) -> tuple[ForceData, tuple]:
    """(the flat data of ``system.forces``, each element's history, None, or
    :data:`~.python_elements.TIME` for an element without a compiled form). ``forces``:
    these elements instead, on their own (their states first in z, in order)."""
    mech = system.mechanism
    markers = MarkerTable(mech)
    kinds, ints, pars, cons, tables, hist = [], [], [], [], [], []
    rows = 0
    if forces is None:
        forces = system.forces
        offsets = {id(f): sl.start for f, sl in system.state_slices}
    else:
        sizes = [len(getattr(f, "STATES", ())) for f in forces]
        offsets = {id(f): int(sum(sizes[:k])) for k, f in enumerate(forces) if sizes[k]}
    python = []  # (row, element) of the elements evaluated by their numpy methods
    for f in forces:
        if not has_kernels(f):
            python.append((len(kinds), f))
            kinds.append(PYTHON_KIND)
            ints.append([0, 0, 0, 0, offsets.get(id(f), -1)])
            pars.append([])
            cons.append(bool(getattr(f, "conservative", False)))
            hist.append(P.TIME)
            continue
        i, p, table = f.pack(mech, markers)
        if table is not None:
            i = [i[0], i[1], rows, len(table)]
            tables.append(np.asarray(table, dtype=float))
            rows += len(table)
        kinds.append(type(f).KIND)
        ints.append(list(i) + [offsets.get(id(f), -1)])
        pars.append(list(p))
        cons.append(bool(f.conservative))
        hist.append(getattr(f, f.HISTORY, None))
    table = np.concatenate(tables) if tables else np.zeros((0, 3))
    width = max([6] + [len(p) for p in pars])
    par = np.zeros((len(pars), width))
    for e, p in enumerate(pars):
        par[e, :len(p)] = p
    data = ForceData(np.array(kinds, dtype=np.int64).reshape(-1),
                     np.array(ints, dtype=np.int64).reshape(-1, 5), par,
                     np.array(cons, dtype=np.bool_).reshape(-1), table, *markers.arrays())
    for row, f in python:
        data.ints[row, 0] = P.register(system, f, data.ints)
    return data, tuple(hist)


def force_factors(histories: tuple, times: np.ndarray) -> np.ndarray:
    """(k, 2F): each force element's history value at the times (k,) s (1 without one),
    then the rates a controller's feed-forward reads (its reference's; 0 elsewhere)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    F = len(histories)
    out = np.ones((times.size, 2 * F))
    out[:, F:] = 0.0
    for j, h in enumerate(histories):
        if h is P.TIME:
            out[:, j] = times
            out[:, F + j] = 1.0
        elif h is not None:
            out[:, j] = history_values(h, times)
            if getattr(h, "feedforward", False):  # a controller's reference rate
                out[:, F + j] = history_rates(h, times)
    return out


@njit(cache=True)
def line_push(e, z, length, rate, factor, d):
    """(push, its non-conservative part), N, of line element e at its length (m) and rate
    (m/s); kind not a line element's: (nan, nan)."""
    return _push(d.kind[e], e, z, length, rate, factor, d)


@njit(cache=True)
def element_force(e, q, v, z, A, dA, factor, d, Q, Qnc):
    """Add element e's generalized force to Q (n,) and its non-conservative part to Qnc
    (n,) at (q, v) and the elements' states z (nz,) with the link poses A, dA and the
    history factors (2F,)."""
    kind = d.kind[e]
    if _is_line(kind):
        length, dl = line_geometry(d.ints[e, 0], d.ints[e, 1], q, A, dA, d)
        f, fnc = line_push(e, z, length, dl @ v, factor, d)
        for i in range(q.shape[0]):
            Q[i] += f * dl[i]
            Qnc[i] += fnc * dl[i]
    elif kind == PYTHON_KIND:
        key, t = d.ints[e, 0], factor[e]
        with objmode():
            P.element_force(key, q, v, z, A, dA, t, Q, Qnc)
    else:
        _force(kind, e, q, v, z, A, dA, factor, d, Q, Qnc)


@njit(cache=True)
def generalized_forces(q, v, z, A, dA, factor, d, Q, Qnc):
    """Add every element's generalized force to Q (n,) and its non-conservative part to
    Qnc (n,) (:func:`element_force`)."""
    for e in range(d.kind.shape[0]):
        element_force(e, q, v, z, A, dA, factor, d, Q, Qnc)


@njit(cache=True)
def element_rates(e, q, v, z, A, dA, factor, d, zd):
    """Write the rates of element e's own states into zd (nz,) at (q, v, z)."""
    if d.kind[e] == PYTHON_KIND:
        if d.ints[e, 4] >= 0:
            key, t = d.ints[e, 0], factor[e]
            with objmode():
                P.element_rates(key, q, v, z, A, dA, t, zd)
    else:
        _rates(d.kind[e], e, q, v, z, A, dA, factor, d, zd)


@njit(cache=True)
def state_rates(q, v, z, A, dA, factor, d, zd):
    """zd (nz,) = the rates of the elements' own states at (q, v, z)."""
    for e in range(d.kind.shape[0]):
        element_rates(e, q, v, z, A, dA, factor, d, zd)


@njit(cache=True)
def element_potential(e, q, A, dA, d):
    """Potential energy (J) of element e's conservative part."""
    kind = d.kind[e]
    if kind == PYTHON_KIND:
        key = d.ints[e, 0]
        with objmode(x="float64"):
            x = P.element_potential(key, q, A, dA)
        return x
    return _potential(kind, e, q, A, dA, d)


@njit(cache=True)
def potential(q, A, dA, d):
    """Potential energy (J) of the conservative elements."""
    V = 0.0
    for e in range(d.kind.shape[0]):
        V += element_potential(e, q, A, dA, d)
    return V


@njit(cache=True)
def element_loads(e, q, v, z, A, dA, factor, d, rows):
    """rows (2, 10) = element e's physical loads (:func:`~.markers.load_row`); returns how
    many (0: an element on a coordinate, whose force the joint transmits)."""
    kind = d.kind[e]
    if _is_line(kind):
        length, dl = line_geometry(d.ints[e, 0], d.ints[e, 1], q, A, dA, d)
        f, _ = line_push(e, z, length, dl @ v, factor, d)
        return line_loads(d.ints[e, 0], d.ints[e, 1], f, q, A, dA, d, rows)
    elif kind == PYTHON_KIND:
        return 0
    return _loads(kind, e, q, v, z, A, dA, factor, d, rows)


@dataclass(frozen=True, eq=False)
class CompiledForces:
    """A system's force elements in compiled form, evaluated from Python (statics,
    linearisation, kinetostatics, energies, each element's methods).

    data, histories : :func:`compile_forces`'s.  elements : the elements in row order.
    nz : the length of the system's element states z.  mechanism : the system's.
    """

    data: ForceData
    histories: tuple
    elements: tuple
    nz: int
    mechanism: Any
    system: Any = field(repr=False)
    _rows: dict = field(default_factory=dict, repr=False)

    @classmethod
    def of(cls, system, forces=None) -> CompiledForces:
        """``system``'s elements (or ``forces``, elements evaluated on their own with their
        states first in z, in order) in compiled form."""
        elements = tuple(system.forces if forces is None else forces)
        data, histories = compile_forces(system, elements if forces is not None else None)
        nz = sum(len(getattr(f, "STATES", ())) for f in elements)
        out = cls(data, histories, elements, nz, system.mechanism, system)
        out._rows.update({id(f): e for e, f in enumerate(elements)})
        return out

    def _tree_arrays(self, tree, q):
        if tree.dA is None:  # the kernels need dA/dq: the pose's derivatives
            from pipeline.kinematics.poses import evaluate_tree

            tree = evaluate_tree(self.mechanism, q)
        return tree.A, tree.dA

    def _factors(self, t: float) -> np.ndarray:
        return force_factors(self.histories, np.array([t]))[0]

    def _states(self, z) -> np.ndarray:
        """z (nz,) as an array; the first element with states names itself where z is
        None (contract rule 7)."""
        if self.nz == 0:
            return np.zeros(0)
        if z is None:
            next(f for f in self.elements if getattr(f, "STATES", ())).own_states(None)
        z = np.asarray(z, dtype=float)
        if z.shape != (self.nz,):
            raise ValueError(f"element states: expected ({self.nz},), got {z.shape}")
        return z

    def forces(self, tree, q, qd, t: float, z=None) -> tuple[np.ndarray, np.ndarray]:
        """(Q (n,), its non-conservative part (n,)) of every element at (q, qd, t) and the
        elements' states z (nz,); ``tree`` the TreeState at q."""
        Q, Qnc = np.zeros(q.size), np.zeros(q.size)
        if not self.elements:  # no kernel to compile (a fresh machine's first run)
            return Q, Qnc
        A, dA = self._tree_arrays(tree, q)
        generalized_forces(q, qd, self._states(z), A, dA, self._factors(t), self.data, Q, Qnc)
        return Q, Qnc

    def potential(self, tree, q) -> float:
        """Potential energy (J) of every element's conservative part at q."""
        if not self.elements:
            return 0.0
        A, dA = self._tree_arrays(tree, q)
        return float(potential(q, A, dA, self.data))

    def rates(self, tree, q, qd, t: float, z) -> np.ndarray:
        """(nz,) the rates of the elements' own states at (q, qd, t, z)."""
        zd = np.zeros(self.nz)
        if not self.nz:
            return zd
        A, dA = self._tree_arrays(tree, q)
        state_rates(q, qd, self._states(z), A, dA, self._factors(t), self.data, zd)
        return zd

    # -------------------------------------------------------------- one element
    def _element(self, f, z):
        """(the CompiledForces holding f, its row, the states z in that one's layout)."""
        e = self._rows.get(id(f))
        if e is None or self.elements[e] is not f:  # not this system's: on its own
            own = CompiledForces.of(self.system, (f,))
            return own, 0, own._states(z if own.nz else None)
        full = np.zeros(self.nz)
        k = len(getattr(f, "STATES", ()))
        if k:
            start = int(self.data.ints[e, 4])
            full[start:start + k] = f.own_states(z)
        return self, e, full

    def element_forces(self, f, tree, q, qd, t: float, z=None):
        """(Q (n,), its non-conservative part (n,)) of element f alone; z its own states."""
        if not has_kernels(f):
            return ForceElement.generalized_force(f, self.system, tree, q, qd, t, z), \
                ForceElement.nonconservative_force(f, self.system, tree, q, qd, t, z)
        c, e, zz = self._element(f, z)
        A, dA = c._tree_arrays(tree, q)
        Q, Qnc = np.zeros(q.size), np.zeros(q.size)
        element_force(e, q, qd, zz, A, dA, c._factors(t), c.data, Q, Qnc)
        return Q, Qnc

    def element_potential(self, f, tree, q) -> float:
        """V (J) of element f's conservative part at q."""
        if not has_kernels(f):  # a user's subclass of a built-in: its own methods
            return ForceElement.potential_energy(f, self.system, tree, q)
        c, e, _ = self._element(f, np.zeros(len(getattr(f, "STATES", ()))))
        A, dA = c._tree_arrays(tree, q)
        return float(element_potential(e, q, A, dA, c.data))

    def element_rates(self, f, tree, q, qd, t: float, z) -> np.ndarray:
        """(k,) the rates of element f's own states z (k,)."""
        if not has_kernels(f):
            raise NotImplementedError(f"force element '{f.name}' ({type(f).__name__}) has "
                                      "no compiled form and no state_rates method")
        c, e, zz = self._element(f, z)
        A, dA = c._tree_arrays(tree, q)
        zd = np.zeros(c.nz)
        element_rates(e, q, qd, zz, A, dA, c._factors(t), c.data, zd)
        start = int(c.data.ints[e, 4])
        return zd[start:start + len(f.STATES)]

    def element_loads(self, f, tree, q, qd, t: float, z=None) -> tuple[Load, ...]:
        """Element f's physical loads (ground axes; none for an element on a coordinate)."""
        if not has_kernels(f):
            return ForceElement.loads(f, self.system, tree, q, qd, t)
        c, e, zz = self._element(f, z)
        A, dA = c._tree_arrays(tree, q)
        rows = np.zeros((2, 10))
        k = element_loads(e, q, qd, zz, A, dA, c._factors(t), c.data, rows)
        links = self.mechanism.links
        return tuple(Load(links[int(r[0])].name, r[1:4].copy(), r[4:7].copy(), r[7:10].copy())
                     for r in rows[:k])
