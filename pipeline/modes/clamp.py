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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from pipeline.core.errors import ConfigError, ModalError
from pipeline.fem.interfaces import TiedModel


@dataclass(frozen=True)
class ClampedSpace:
    """u_r = L x_c for a tied model clamped at its reference interface.

    Attributes
    ----------
    reference : name of the clamped interface.
    keep : (n_c,) tied indices that are the clamped coordinates.
    dep : (d,) tied indices eliminated (d = 6).
    L : (n_red, n_c) CSR expansion from clamped to tied coordinates.
    method : "rbe2-masters" or "rbe3-pivot".
    """

    reference: str
    keep: np.ndarray
    dep: np.ndarray
    L: sp.csr_matrix
    method: str

    @property
    def n_c(self) -> int:
        return int(self.keep.size)

    def project(self, A: sp.spmatrix) -> sp.csr_matrix:
        """L^T A L for a (n_red, n_red) sparse matrix (exact selection for RBE2)."""
        return sp.csr_matrix(self.L.T.tocsr() @ A @ self.L)

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


def _clamp_rbe3(tied: TiedModel, name: str) -> ClampedSpace:
    C = sp.csc_matrix(tied.rbe3_operators[name] @ tied.transform)  # (6, n_red)
    masters = np.concatenate([np.asarray(v) for v in tied.master_dofs.values()] or [[]])
    cols = np.flatnonzero(np.diff(C.indptr))
    cand = np.setdiff1d(cols, masters.astype(np.int64))
    if cand.size < 6:
        raise ModalError(f"link {tied.model_name!r}: interface {name!r}: cannot clamp an RBE3 "
                         f"whose nodes are all tied to RBE2 interfaces")
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
    return ClampedSpace(name, keep, dep, L, "rbe3-pivot")


def check_reference(tied: TiedModel, reference) -> str:
    """Name of the reference interface (accepts an Interface or a name)."""
    name = getattr(reference, "name", reference)
    if not isinstance(name, str):
        raise ConfigError(f"link {tied.model_name!r}: reference: expected an interface name, "
                          f"got {reference!r}")
    tied.interface(name)
    return name
