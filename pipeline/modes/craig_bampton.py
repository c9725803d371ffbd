"""Craig-Bampton basis on a clamped model: constraint modes + fixed-interface modes.

Partition the clamped coordinates into boundary b (the 6 master DOFs of each
Craig-Bampton interface) and interior i. The basis is

    B = [[Phi_i, Psi_i], [0, I]],   Psi_i = -K_ii^-1 K_ib,

with Phi_i the lowest fixed-interface modes of (K_ii, M_ii) (boundary also
clamped). One sparse factorisation of K_ii serves both the static solves and
the shift-invert eigen solve (shift 0). The reduced pair B^T K B, B^T M B is
then solved densely, B Q, so the final basis is mass-normalised and
K-diagonal with the reduced model's frequencies (which bound the clamped
model's from above, Rayleigh-Ritz).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from pipeline.core.errors import ConfigError, ModalError
from pipeline.modes.eigen import DEFAULT_ORDERING, factorize, lowest_modes


class BlockSolve:
    """Solves K x = b of a clamped model on the factor of its interior block K_ii (the
    Craig-Bampton factor): b's interior part through K_ii, the boundary through the dense
    Schur complement S = K_bb + K_bi Psi_i (the Guyan stiffness),

        x_b = S^-1 (b_b - K_bi K_ii^-1 b_i),   x_i = K_ii^-1 b_i + Psi_i x_b,

    so a link reduced by Craig-Bampton needs no factorisation of the whole of K.
    """

    def __init__(self, K: sp.spmatrix, boundary: np.ndarray, lu, Psi: np.ndarray):
        K = sp.csr_matrix(K)
        self.shape = K.shape
        self._b = np.asarray(boundary, dtype=np.int64)
        self._i = np.setdiff1d(np.arange(K.shape[0]), self._b)
        self._K_bi = K[self._b][:, self._i]
        self._lu, self._Psi = lu, Psi
        S = K[self._b][:, self._b].toarray() + self._K_bi @ Psi
        self._S = la.cho_factor(_sym(S))

    def solve(self, b: np.ndarray) -> np.ndarray:
        """x with K x = b, b (n,) or (n, k)."""
        b = np.asarray(b, dtype=float)
        y = np.asarray(self._lu.solve(b[self._i]))
        x_b = la.cho_solve(self._S, b[self._b] - self._K_bi @ y)
        x = np.empty_like(b)
        x[self._i] = y + self._Psi @ x_b
        x[self._b] = x_b
        return x


def craig_bampton_basis(K: sp.spmatrix, M: sp.spmatrix, boundary: np.ndarray,
                  n_modes: int | None = None, f_max: float | None = None, *,
                  ordering: str = DEFAULT_ORDERING, where: str = "model", problem=None
                  ) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Orthonormalised Craig-Bampton basis of a clamped model.

    Parameters
    ----------
    K, M : (n, n) sparse clamped stiffness (N/m) and mass (kg).
    boundary : (n_b,) indices of the boundary (interface master) DOFs.
    n_modes : number of fixed-interface modes (0 allowed: Guyan reduction).
    f_max : cut-off for the fixed-interface modes, Hz.
    ordering : SuperLU ordering for K_ii.
    where : label for messages.
    problem : the ClampedProblem of (K, M), given its static solves on the factor of K_ii
        (:class:`BlockSolve`, :meth:`pipeline.modes.clamp.ClampedProblem.share`).

    Returns
    -------
    lam : (m,) eigenvalues of the reduced model, omega^2, ascending.
    X : (n, m) basis vectors, X^T M X = I, X^T K X = diag(lam).
    kinds : (m,) "constraint" for the n_b vectors with the largest share of
        constraint-mode coefficients, "normal" for the others.
    """
    n = K.shape[0]
    boundary = np.asarray(boundary, dtype=np.int64)
    if boundary.size == 0:
        raise ConfigError(f"{where}: craig_bampton needs at least one RBE2 interface besides "
                          f"the reference")
    interior = np.setdiff1d(np.arange(n), boundary)
    K = sp.csr_matrix(K)
    K_ii = K[interior][:, interior]
    K_ib = K[interior][:, boundary]
    M_ii = sp.csr_matrix(M)[interior][:, interior]
    lu = factorize(K_ii, ordering, where=where)
    Psi = -lu.solve(np.asarray(K_ib.toarray()))  # (n_i, n_b)
    if problem is not None:
        problem.share(BlockSolve(K, boundary, lu, Psi))
    if n_modes == 0:  # Guyan: static constraint modes only
        Phi = np.zeros((interior.size, 0))
    else:
        _, Phi = lowest_modes(K_ii, M_ii, n_modes, f_max, sigma=0.0, lu=lu,
                              where=f"{where} (fixed-interface)")
    m_n, n_b = Phi.shape[1], boundary.size
    B = np.zeros((n, m_n + n_b))
    B[interior, :m_n] = Phi
    B[interior, m_n:] = Psi
    B[boundary, m_n:] = np.eye(n_b)
    B[:, m_n:] /= np.sqrt(np.einsum("ij,ij->j", B[:, m_n:], M @ B[:, m_n:]))
    K_red = _sym(B.T @ (K @ B))
    M_red = _sym(B.T @ (M @ B))
    try:
        lam, Q = la.eigh(K_red, M_red)
    except la.LinAlgError as exc:
        raise ModalError(f"{where}: the Craig-Bampton basis is rank deficient ({exc})") from exc
    share = np.sum(Q[m_n:] ** 2, axis=0) / np.sum(Q ** 2, axis=0)
    kinds = np.full(lam.size, "normal", dtype=object)
    kinds[np.argsort(-share, kind="stable")[:n_b]] = "constraint"
    return lam, B @ Q, tuple(kinds)


def _sym(A: np.ndarray) -> np.ndarray:
    return 0.5 * (A + A.T)
