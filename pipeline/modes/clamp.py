"""Clamping the reference interface of a tied model, exactly.

The clamped coordinates x_c are a subset ``keep`` of the tied coordinates
u_r; the eliminated ones ``dep`` are linear in them, u_r[dep] = D x_c, so
u_r = L x_c with a sparse L (n_red, n_c) and K_c = L^T K_r L, M_c = L^T M_r L.

* RBE2 reference: ``dep`` are its 6 master DOFs and D = 0 (they are zero).
* RBE3 reference: the constraint is G u = G T u_r = 0 (6 averaged motions).
  It is eliminated exactly by pivoting: QR with column pivoting of C = G T
  restricted to the interface's own DOFs picks the 6 best-conditioned
  columns C_d; then u_r[dep] = -C_d^-1 C_keep x_c (a sparse null-space basis
  of C). No penalty, no Lagrange multipliers, no approximation.
* Chord reference (:func:`clamp_chord`, both interfaces RBE2): the reference's
  translations and its rotation about the chord e (from the reference to the far
  interface) are zero, and the far interface moves along the chord only
  (n_1 . t = n_2 . t = 0): the link's body frame follows the line through its two
  pins, and its modes are those of a link pinned at both ends (a connecting rod's
  pinned-pinned bending, its axial and torsion modes). Six rows on master DOFs,
  eliminated by the same pivoting.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from pipeline.core.errors import ConfigError, ModalError
from pipeline.fem.interfaces import TiedModel
from pipeline.modes.eigen import DEFAULT_ORDERING, factorize


@dataclass(frozen=True)
class ClampedSpace:
    """u_r = L x_c for a tied model clamped at its reference interface.

    Attributes
    ----------
    reference : name of the clamped interface.
    keep : (n_c,) tied indices that are the clamped coordinates.
    dep : (d,) tied indices eliminated (d = 6).
    L : (n_red, n_c) CSR expansion from clamped to tied coordinates.
    method : "rbe2-masters", "rbe3-pivot" or "chord".
    chord : the far interface of a chord reference, else None.
    """

    reference: str
    keep: np.ndarray
    dep: np.ndarray
    L: sp.csr_matrix
    method: str
    chord: str | None = None

    @property
    def n_c(self) -> int:
        return int(self.keep.size)

    def project(self, A: sp.spmatrix) -> sp.csr_matrix:
        """L^T A L for a (n_red, n_red) sparse matrix.

        L = S + E: S selects ``keep`` and E (nonzero on the ``dep`` rows only, none for an
        RBE2 reference) expresses the eliminated coordinates. So L^T A L is the selection
        A[keep, keep] plus terms of rank <= 6 through A's ``dep`` rows and columns, a
        fraction of the cost of two sparse products on a large link.
        """
        A = sp.csr_matrix(A)
        kept_rows = A[self.keep]  # the large selection, made once
        K = kept_rows[:, self.keep]
        E = self.L[self.dep]  # (d, n_c)
        if E.nnz == 0:
            return K
        dep_rows = A[self.dep]
        return sp.csr_matrix(K + kept_rows[:, self.dep] @ E + E.T @ dep_rows[:, self.keep]
                             + E.T @ (dep_rows[:, self.dep] @ E))

    def index_of(self, tied_dofs: np.ndarray) -> np.ndarray:
        """Positions in x_c of tied indices (which must be kept coordinates)."""
        pos = np.searchsorted(self.keep, tied_dofs)
        pos = np.clip(pos, 0, self.keep.size - 1)
        if not np.array_equal(self.keep[pos], tied_dofs):
            raise ModalError(f"tied DOFs {tied_dofs} are eliminated by the clamp of "
                             f"{self.reference!r}")
        return pos


def clamp_reference(tied: TiedModel, reference: str) -> ClampedSpace:
    """Clamp the interface ``reference`` of ``tied`` (see module doc).

    Raises
    ------
    ConfigError
        Unknown interface name.
    ModalError
        An RBE3 reference whose averaged motions cannot be pivoted on (rank < 6).
    """
    itf = tied.interface(reference)
    n_red = tied.n_red
    if itf.kind == "rbe2":
        dep = np.asarray(tied.master_dofs[itf.name])
        keep = np.setdiff1d(np.arange(n_red), dep)
        L = sp.csr_matrix((np.ones(keep.size), (keep, np.arange(keep.size))),
                          shape=(n_red, keep.size))
        return ClampedSpace(itf.name, keep, dep, L, "rbe2-masters")
    return _clamp_rbe3(tied, itf.name)


def clamp_chord(tied: TiedModel, reference: str, far: str) -> ClampedSpace:
    """Chord reference between the RBE2 interfaces ``reference`` and ``far`` (module doc).

    Raises
    ------
    ConfigError
        Unknown interfaces, not RBE2, the same one twice, or coincident origins.
    """
    where = f"link {tied.model_name!r}: modes.chord"
    ref, other = tied.interface(reference), tied.interface(far)
    if ref.kind != "rbe2" or other.kind != "rbe2":
        raise ConfigError(f"{where}: expected two RBE2 interfaces, got {ref.name!r} "
                          f"({ref.kind}) and {other.name!r} ({other.kind})")
    chord = np.asarray(other.origin, dtype=float) - np.asarray(ref.origin, dtype=float)
    if ref.name == other.name or np.linalg.norm(chord) == 0.0:
        raise ConfigError(f"{where}: expected an interface away from the reference "
                          f"{ref.name!r}, got {far!r}")
    e = chord / np.linalg.norm(chord)
    n1 = np.cross(e, [1.0, 0, 0] if abs(e[0]) < 0.9 else [0, 1.0, 0])
    n1 /= np.linalg.norm(n1)
    n2 = np.cross(e, n1)
    a, b = np.asarray(tied.master_dofs[ref.name]), np.asarray(tied.master_dofs[other.name])
    rows = np.zeros((6, 12))
    rows[:3, :3] = np.eye(3)  # the reference's translations
    rows[3, 3:6] = e  # its rotation about the chord
    rows[4, 6:9], rows[5, 6:9] = n1, n2  # the far end off the chord
    cols = np.concatenate([a, b])
    C = sp.csc_matrix((rows[np.nonzero(rows)], (np.nonzero(rows)[0],
                                                cols[np.nonzero(rows)[1]])),
                      shape=(6, tied.n_red))
    return _eliminate(tied, ref.name, C, np.unique(cols), "chord", far=other.name)


def _clamp_rbe3(tied: TiedModel, name: str) -> ClampedSpace:
    C = sp.csc_matrix(tied.rbe3_operators[name] @ tied.transform)  # (6, n_red)
    masters = np.concatenate([np.asarray(v) for v in tied.master_dofs.values()] or [[]])
    cols = np.flatnonzero(np.diff(C.indptr))
    cand = np.setdiff1d(cols, masters.astype(np.int64))
    if cand.size < 6:
        raise ModalError(f"link {tied.model_name!r}: interface {name!r}: cannot clamp an RBE3 "
                         f"whose nodes are all tied to RBE2 interfaces")
    return _eliminate(tied, name, C, cand, "rbe3-pivot")


def _eliminate(tied: TiedModel, name: str, C: sp.csc_matrix, cand: np.ndarray, method: str,
               far: str | None = None) -> ClampedSpace:
    """The space C u_r = 0 (6 rows), pivoting on 6 of the candidate columns."""
    Cc = C[:, cand].toarray()
    _, R, piv = la.qr(Cc, mode="economic", pivoting=True)
    if abs(R[5, 5]) <= 1e-10 * abs(R[0, 0]):
        raise ModalError(f"link {tied.model_name!r}: interface {name!r}: the averaged motion "
                         f"has rank < 6 on its free DOFs; cannot clamp it")
    dep = np.sort(cand[piv[:6]])
    keep = np.setdiff1d(np.arange(tied.n_red), dep)
    C_d = C[:, dep].toarray()
    C_keep = C[:, keep]
    D = -la.solve(C_d, C_keep.toarray())  # (6, n_c), nonzero on interface DOFs only
    Dc = sp.coo_matrix(D)
    rows = np.concatenate([keep, dep[Dc.row]])
    cols = np.concatenate([np.arange(keep.size), Dc.col])
    vals = np.concatenate([np.ones(keep.size), Dc.data])
    L = sp.csr_matrix((vals, (rows, cols)), shape=(tied.n_red, keep.size))
    return ClampedSpace(name, keep, dep, L, method, far)


def reference_space(tied: TiedModel, reference: str, chord: str | None = None) -> ClampedSpace:
    """The clamp of the modes: the reference interface, or the chord to ``chord``."""
    return clamp_reference(tied, reference) if chord is None else \
        clamp_chord(tied, reference, chord)


def check_reference(tied: TiedModel, reference) -> str:
    """Name of the reference interface (accepts an Interface or a name)."""
    name = getattr(reference, "name", reference)
    if not isinstance(name, str):
        raise ConfigError(f"link {tied.model_name!r}: reference: expected an interface name, "
                          f"got {reference!r}")
    tied.interface(name)
    return name


class ClampedProblem:
    """A tied model in its clamped space (the modes' reference conditions) with K_c, M_c
    and one factorisation of K_c, made on first use and shared by everything that needs
    it: the eigen solve and the static load cases of the geometric stiffness (a 500 k
    DOF link's factorisation takes about a minute; it used to be made three times).

    Attributes
    ----------
    space : ClampedSpace.  K, M : (n_c, n_c) CSR clamped stiffness (N/m) and mass (kg).
    """

    def __init__(self, tied: TiedModel, reference: str, chord: str | None = None):
        self.space = reference_space(tied, reference, chord)
        self.K = self.space.project(tied.stiffness)
        self.M = self.space.project(tied.mass)
        self._where = f"link {tied.model_name!r}"
        self._lu = {}

    def factor(self, ordering: str | None = None):
        """A factorisation of K_c (:func:`pipeline.modes.eigen.factorize`), cached per
        ordering; the one :meth:`share` was given, if any."""
        ordering = ordering or DEFAULT_ORDERING
        if "shared" in self._lu:
            return self._lu["shared"]
        if ordering not in self._lu:
            self._lu[ordering] = factorize(self.K, ordering, where=self._where)
        return self._lu[ordering]

    def share(self, solver) -> None:
        """Use ``solver`` (an object with ``solve(b)`` for K_c, e.g. the Craig-Bampton
        block solve on the factor of K_ii) for every later static solve instead of
        factorising K_c again."""
        self._lu["shared"] = solver
