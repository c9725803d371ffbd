"""Clamped-interface modes of a tied link (the thesis' "tangent frame" modes)."""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable

import numpy as np

from pipeline.core.errors import ConfigError, ModalError
from pipeline.core.progress import stage
from pipeline.fem.interfaces import Interface, TiedModel
from pipeline.modes.basis import ModalBasis, frequencies_from_eigenvalues, sign_flips
from pipeline.modes.clamp import ClampedProblem, check_reference
from pipeline.modes.craig_bampton import craig_bampton_basis
from pipeline.modes.eigen import (
    DEFAULT_ORDERING,
    DENSE_BELOW,
    CholmodFactor,
    check_mode_count,
    lowest_modes,
)

logger = logging.getLogger(__name__)


def clamped_modes(tied: TiedModel, reference: str | Interface, n_modes: int | None = None,
                  f_max: float | None = None, craig_bampton: bool = False,
                  interfaces: Iterable[str | Interface] | None = None, *,
                  ordering: str = DEFAULT_ORDERING, chord: str | None = None,
                  problem: ClampedProblem | None = None) -> ModalBasis:
    """Fixed-interface normal modes (optionally Craig-Bampton) clamped at ``reference``,
    or with the chord reference to interface ``chord``.

    Parameters
    ----------
    tied : TiedModel
        The link with its interfaces tied (:func:`pipeline.fem.interfaces.tie_interfaces`).
    reference : name (or Interface) of the clamped interface. RBE2: its 6
        master DOFs are zero; RBE3: its 6 averaged motions G u = 0, eliminated
        exactly by pivoting (:mod:`pipeline.modes.clamp`).
    n_modes : number of (fixed-interface) normal modes; 0 allowed with Craig-Bampton.
    f_max : keep the normal modes with frequency <= f_max, Hz.
    craig_bampton : add static constraint modes of ``interfaces`` and orthonormalise.
    interfaces : Craig-Bampton interfaces (RBE2, not the reference); default all
        other RBE2 interfaces.
    ordering : SuperLU fill-reducing ordering (see :mod:`pipeline.modes.eigen`).
    chord : instead of clamping the reference, hold it in translation and about the chord
        to this RBE2 interface, which moves along the chord only
        (:func:`pipeline.modes.clamp.clamp_chord`): pinned-pinned modes.
    problem : the clamped problem of ``tied`` (its reference conditions, chord included,
        and its factorisation, shared with later static solves); built here from
        ``reference`` and ``chord`` if not given.

    Returns
    -------
    ModalBasis
        Mass-normalised, ordered by frequency, deterministic signs.

    Raises
    ------
    ModalError
        More modes than clamped DOFs; a cut-off that selects no mode; a singular model.
    ConfigError
        Unknown interfaces, Craig-Bampton on a non-RBE2 interface, neither n_modes nor f_max.
    """
    where = f"link {tied.model_name!r}"
    ref = check_reference(tied, reference)
    if problem is not None:
        if problem.space.reference != ref:
            raise ConfigError(f"{where}: the clamped problem is clamped at "
                              f"{problem.space.reference!r}, not at {ref!r}")
        chord = problem.space.chord
    cb_names = _cb_interfaces(tied, ref, interfaces) if craig_bampton else ()
    if craig_bampton and chord is not None:
        raise ConfigError(f"{where}: modes.chord and modes.craig_bampton exclude each other "
                          "(the chord reference already holds the far interface)")
    if craig_bampton and not cb_names:
        raise ConfigError(f"{where}: craig_bampton needs at least one RBE2 interface besides "
                          f"the reference {ref!r}")
    if n_modes is None and f_max is None:
        raise ConfigError(f"{where}: clamped modes: give n_modes or f_max")
    t0 = time.perf_counter()
    with stage(f"clamping {where} at {ref!r}" + (f" (chord to {chord!r})" if chord else "")):
        if problem is None:
            problem = ClampedProblem(tied, ref, chord)
        space, K_c, M_c = problem.space, problem.K, problem.M
    what = "Craig-Bampton modes" if craig_bampton else "clamped modes"
    factor = "of K_ii (Craig-Bampton)" if craig_bampton else None
    with stage(f"{what} of {where} ({space.n_c} DOFs)"):
        if craig_bampton:
            boundary = np.concatenate([space.index_of(tied.master_dofs[n]) for n in cb_names])
            lam, X, kinds = craig_bampton_basis(K_c, M_c, boundary, n_modes, f_max,
                                           ordering=ordering, where=where, problem=problem)
        else:
            lu = problem.factor(ordering) if space.n_c >= DENSE_BELOW else None
            factor = "none (dense)" if lu is None else \
                "CHOLMOD" if isinstance(lu, CholmodFactor) else "SuperLU"
            lam, X = _complete_pairs(K_c, M_c, n_modes, f_max, ordering, where, lu)
            kinds = ("normal",) * lam.size
        check_connected(tied, space, where)
        warn = _round_off_modes(lam, K_c, M_c, where, ref)
    X_r = space.L @ X
    shapes = tied.transform @ X_r
    flips = sign_flips(shapes)
    shapes, X_r = shapes * flips, X_r * flips
    KX, MX = tied.stiffness @ X_r, tied.mass @ X_r
    settings = {
        "reference": ref, "reference_kind": tied.interface(ref).kind,
        "clamp_method": space.method, "n_modes": n_modes, "f_max": f_max,
        "craig_bampton": bool(craig_bampton), "cb_interfaces": list(cb_names),
        "chord": chord,
        "ordering": ordering, "eigensolver": "eigsh shift-invert (sigma=0) / dense eigh",
        "factorisation": factor,
        "n_dof": tied.n_dof, "n_clamped": space.n_c,
        "seconds": round(time.perf_counter() - t0, 4),
        "warnings": [warn] if warn else [],
    }
    logger.info("%s: %d modes, %.4g..%.4g Hz", where, lam.size,
                *frequencies_from_eigenvalues(lam[[0, -1]]))
    return ModalBasis(frequencies_from_eigenvalues(lam), shapes, X_r,
                      _sym(X_r.T @ KX), _sym(X_r.T @ MX), kinds, ref, settings)


#: relative gap below which two frequencies count as repeated (a symmetric section)
REPEATED_RTOL = 1e-3


def _complete_pairs(K_c, M_c, n_modes, f_max, ordering, where, lu=None):
    """The lowest modes by count and/or cut-off, one more when the count would split a
    repeated frequency (Iy = Iz: the partner of the last mode would be missing, and the
    last mode an arbitrary mix of the two planes)."""
    check_mode_count(n_modes, where)  # 0 modes: Craig-Bampton only
    n = K_c.shape[0]
    if n_modes is None or n_modes + 1 > n:
        return lowest_modes(K_c, M_c, n_modes, f_max, ordering=ordering, lu=lu, where=where)
    lam, X = lowest_modes(K_c, M_c, n_modes + 1, f_max, ordering=ordering, lu=lu, where=where)
    if lam.size == n_modes + 1:
        w = np.sqrt(np.maximum(lam[-2:], 0.0))
        if abs(w[1] - w[0]) <= REPEATED_RTOL * w[1]:
            logger.info("%s: %d modes instead of %d: mode %d repeats the frequency of mode %d",
                        where, n_modes + 1, n_modes, n_modes + 1, n_modes)
            return lam, X
    return lam[:n_modes], X[:, :n_modes]


def check_connected(tied: TiedModel, space, where: str) -> None:
    """ModalError unless every part of the model is connected, through its stiffness, to the
    clamped interface: a part that is not (two solids that touch without sharing a mesh, a
    node outside every element) would move as a rigid body. Exact and free of scale."""
    from scipy.sparse.csgraph import connected_components

    K = tied.stiffness.tocsr()
    if not K.data.all():  # a stored zero couples nothing (copied only then: K is large)
        K = K.copy()
        K.eliminate_zeros()
    # weak components of the (symmetric) pattern: the same sets as undirected ones,
    # without building K + K^T
    n, labels = connected_components(K, directed=True, connection="weak")
    if n == 1:
        return
    held = np.unique(labels[np.asarray(space.dep)])
    free = np.setdiff1d(np.arange(n), held)
    if free.size:
        sizes = [int(np.sum(labels == c)) for c in free]
        raise ModalError(f"{where}: clamped at {space.reference!r}, {free.size} part(s) of the "
                         f"model ({sum(sizes)} of {K.shape[0]} DOFs) are not connected to it "
                         "and would move as rigid bodies (solids that touch without sharing "
                         "their mesh, or a detached part): fuse them in the geometry")


def _round_off_modes(lam: np.ndarray, K_c, M_c, where: str, ref: str) -> str:
    """A warning ("" if none) for modes whose omega^2 is within round-off of the model's
    stiffest element (below 1e-12 of max K_ii / M_ii).

    A rigid mode that the connectivity check cannot see (parts joined at one node or along
    one edge) comes out there; so does the genuine first mode of a very fine mesh (a 24 m
    boom at 5 mm beam elements: 4e-17 of it), since the largest eigenvalue grows as the
    element size^-4. The two cannot be told apart from the eigenvalues in double precision,
    so this is a warning, not an error; a mechanism then shows in the dynamics' deformation
    check."""
    d = M_c.diagonal()
    scale = float(np.max(K_c.diagonal()[d > 0] / d[d > 0]))
    low = int(np.sum(lam < 1e-12 * scale))
    if not low:
        return ""
    msg = (f"{where}: clamped at {ref!r}, {low} mode(s) have omega^2 {lam[:low]} within "
           f"round-off of the stiffest element (1e-12 x {scale:.3g}): either a very fine "
           "mesh (then the modes are fine) or parts joined at a single node or edge (then "
           "they are mechanisms)")
    logger.warning("%s", msg)
    return msg


def _cb_interfaces(tied: TiedModel, ref: str, interfaces) -> tuple[str, ...]:
    if interfaces is None:
        return tuple(i.name for i in tied.interfaces if i.kind == "rbe2" and i.name != ref)
    names = tuple(getattr(i, "name", i) for i in interfaces)
    for name in names:
        itf = tied.interface(name)
        if name == ref:
            raise ConfigError(f"link {tied.model_name!r}: interface {name!r} is the reference; "
                              f"it cannot also carry Craig-Bampton constraint modes")
        if itf.kind != "rbe2":
            raise ConfigError(f"link {tied.model_name!r}: interface {name!r}: Craig-Bampton "
                              f"constraint modes need kind 'rbe2', got {itf.kind!r}")
    if len(set(names)) != len(names):
        raise ConfigError(f"link {tied.model_name!r}: duplicate Craig-Bampton interfaces {names}")
    return names


def _sym(A: np.ndarray) -> np.ndarray:
    return 0.5 * (A + A.T)
