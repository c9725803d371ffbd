"""Lowest eigenpairs of K x = omega^2 M x by shift-invert Lanczos.

``scipy.sparse.linalg.eigsh`` in shift-invert mode with our own operator
(K - sigma M)^-1 from SuperLU, or from CHOLMOD (scikit-sparse, on OpenBLAS) for links of
:data:`CHOLMOD_ABOVE` DOFs and more when it is installed. SuperLU's fill-reducing
ordering: ``MMD_AT_PLUS_A`` (minimum degree on A^T + A) with SuperLU's symmetric mode and
a zero diagonal-pivot threshold (valid: K - sigma M is positive definite). Measured
on the 55 464-DOF clamped P2 bar, 20 modes (``tests/modes/test_bench_eigen.py``,
output/bench/modes_eigen.json): factor 1.15 s + Lanczos 2.1 s = 3.3 s, fill
16.8 M; COLAMD (scipy's default) 4.2 s, fill 18.7 M; MMD_AT_PLUS_A without
symmetric mode 7.8 s (partial pivoting wrecks the ordering); MMD_ATA 6.0 s,
fill 25 M. The shift defaults to 0, which is below the first eigenvalue of a
clamped model (K positive definite); a free-free model needs a negative shift.

Small problems (or asking for nearly all modes) go to dense LAPACK ``eigh``,
also in shift-invert form so that the low modes keep full relative accuracy.
"""

from __future__ import annotations

import functools
import logging
import os
import time

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from pipeline.core.errors import ConfigError, ModalError
from pipeline.core.progress import report

logger = logging.getLogger(__name__)

ORDERINGS = ("MMD_AT_PLUS_A", "COLAMD", "MMD_ATA", "NATURAL")
DEFAULT_ORDERING = "MMD_AT_PLUS_A"
DENSE_BELOW = 200  # DOFs; dense eigh is as fast below this (and needs no shift)
#: ARPACK's relative tolerance on the Ritz values of (K - sigma M)^-1 M. Machine precision
#: (0) took 55 solves for 21 modes of the 493 k-DOF clamped bar, 1e-10 takes 44, with
#: eigenvalues equal to 3e-15 and eigenvectors to 1e-12 (|cos| = 1): an eigenvalue's error
#: goes as the residual squared
LANCZOS_TOL = 1e-10


#: DOFs from which a symmetric factorisation uses CHOLMOD when scikit-sparse is installed:
#: a Cholesky factor holds about 40 % of SuperLU's L + U (SuperLU's 32-bit indices also
#: give out near 1 M P2 DOF: MemoryError at 1.0 M on a 24 GB machine)
CHOLMOD_ABOVE = 100_000


class CholmodFactor:
    """A CHOLMOD (scikit-sparse) Cholesky factor with SuperLU's ``solve``."""

    def __init__(self, factor, n: int):
        self._factor, self.shape = factor, (n, n)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """x with A x = b, b (n,) or (n, k)."""
        return self._factor(np.asarray(b, dtype=float))


def _cholmod():
    try:
        from sksparse import cholmod
    except ImportError:
        return None
    return cholmod


def reference_blas(mapped: list[str]) -> str | None:
    """The reference (netlib) BLAS among the resolved paths of a process's mapped
    libraries, or None.

    CHOLMOD's supernodal factor spends its time in BLAS: on the reference BLAS (Debian's
    ``libblas3``, in a ``blas/`` directory) it runs about three times slower than on
    OpenBLAS (``libopenblas0``, in ``openblas-*/``), measured on a 189 k-DOF boom.
    """
    for path in mapped:
        parts = path.split("/")
        if parts[-1].startswith("libblas.so") and len(parts) > 1 and parts[-2] == "blas":
            return path
    return None


@functools.cache
def _warn_reference_blas() -> None:
    try:
        with open("/proc/self/maps") as fh:  # Linux; elsewhere nothing to say
            mapped = {line.split()[-1] for line in fh if "/" in line}
    except OSError:
        return
    path = reference_blas(sorted(os.path.realpath(p) for p in mapped))
    if path:
        logger.warning("CHOLMOD runs on the reference BLAS (%s): large links reduce about "
                       "twice as slowly as with OpenBLAS (Debian/Ubuntu: apt install "
                       "libopenblas0-pthread)", path)


def factorize(A: sp.spmatrix, ordering: str = DEFAULT_ORDERING, symmetric: bool = True,
              where: str = "model", backend: str = "auto"):
    """Sparse factorisation of a symmetric positive-definite matrix: SuperLU (scipy), or
    CHOLMOD (scikit-sparse, optional) for large ones.

    Parameters
    ----------
    A : (n, n) sparse, symmetric.
    ordering : one of :data:`ORDERINGS` (SuperLU ``permc_spec``; CHOLMOD orders itself).
    symmetric : use SuperLU's symmetric mode (diagonal pivots), valid for SPD A.
    where : label for error messages.
    backend : "superlu", "cholmod", or "auto": CHOLMOD for symmetric A with at least
        :data:`CHOLMOD_ABOVE` rows when scikit-sparse is installed, else SuperLU.

    Returns
    -------
    An object with ``solve(b)``: ``scipy.sparse.linalg.SuperLU`` or :class:`CholmodFactor`.

    Raises
    ------
    ConfigError for an unknown ordering or backend (or CHOLMOD asked and not installed);
    ModalError if A is singular.
    """
    if ordering not in ORDERINGS:
        raise ConfigError(f"{where}: ordering: expected one of {ORDERINGS}, got {ordering!r}")
    if backend not in ("auto", "superlu", "cholmod"):
        raise ConfigError(f"{where}: backend: expected auto, superlu or cholmod, got "
                          f"{backend!r}")
    cholmod = _cholmod() if backend != "superlu" and symmetric else None
    if backend == "cholmod" and cholmod is None:
        raise ConfigError(f"{where}: backend cholmod needs scikit-sparse (and SuiteSparse)")
    if cholmod is not None and (backend == "cholmod" or A.shape[0] >= CHOLMOD_ABOVE):
        _warn_reference_blas()
        try:
            return CholmodFactor(cholmod.cholesky(sp.csc_matrix(A)), A.shape[0])
        except cholmod.CholmodNotPositiveDefiniteError as exc:
            raise _not_definite(where, "not positive definite", exc) from exc
    kwargs = {"options": {"SymmetricMode": True}, "diag_pivot_thresh": 0.0} if symmetric else {}
    try:
        return spla.splu(sp.csc_matrix(A), permc_spec=ordering, **kwargs)
    except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
        raise _not_definite(where, "singular", exc) from exc


def _not_definite(where: str, what: str, exc: Exception) -> ModalError:
    return ModalError(f"{where}: the constrained stiffness is {what} ({exc}); the clamp does "
                      "not remove all rigid motions or the model has a mechanism")


def lowest_modes(K: sp.spmatrix, M: sp.spmatrix, n_modes: int | None = None,
                 f_max: float | None = None, *, sigma: float = 0.0,
                 ordering: str = DEFAULT_ORDERING, lu: spla.SuperLU | None = None,
                 where: str = "model") -> tuple[np.ndarray, np.ndarray]:
    """Lowest eigenpairs, selected by count and/or frequency cut-off.

    Parameters
    ----------
    K, M : (n, n) sparse symmetric stiffness (N/m) and mass (kg); M positive definite.
    n_modes : int, optional. At most this many modes.
    f_max : float, optional. Only modes with frequency <= f_max (Hz).
    sigma : shift (rad^2/s^2) below the first eigenvalue.
    ordering : SuperLU ordering when ``lu`` is not given.
    lu : optional factorisation of K - sigma M to reuse.
    where : label for messages (link and what is solved).

    Returns
    -------
    lam : (m,) eigenvalues omega^2, ascending, rad^2/s^2.
    X : (n, m) eigenvectors, mass-normalised (X^T M X = I).

    Raises
    ------
    ModalError
        More modes asked than DOFs, or the cut-off selects none.
    """
    n = K.shape[0]
    if n_modes is None and f_max is None:
        raise ConfigError(f"{where}: give n_modes or f_max")
    check_mode_count(n_modes, where)
    if n_modes is not None and n_modes > n:
        raise ModalError(f"{where}: asked for {n_modes} modes but the clamped model has "
                         f"only {n} DOFs")
    w2_max = np.inf if f_max is None else (2.0 * np.pi * float(f_max)) ** 2
    k = int(n_modes) if n_modes is not None else min(12, n)
    if lu is None and n >= DENSE_BELOW and k < n - 1:
        lu = factorize(_shifted(K, M, sigma), ordering, where=where)  # reused while k grows
    while True:
        lam, X = _solve(K, M, k, sigma, ordering, lu, where)
        if f_max is None or lam[-1] > w2_max or k >= n:
            break
        k = min(2 * k, n)
    keep = lam <= w2_max
    if not keep.any():
        raise ModalError(f"{where}: f_max = {f_max} Hz selects no mode; the first one is at "
                         f"{np.sqrt(max(lam[0], 0.0)) / (2 * np.pi):.6g} Hz")
    lam, X = lam[keep], X[:, keep]
    if n_modes is not None:
        lam, X = lam[:n_modes], X[:, :n_modes]
    return lam, mass_normalise(X, M)


def check_mode_count(n_modes, where: str = "model") -> None:
    """ConfigError unless ``n_modes`` is None or an integer >= 1."""
    if n_modes is not None and (int(n_modes) != n_modes or n_modes < 1):
        raise ConfigError(f"{where}: n_modes: expected an integer >= 1, got {n_modes!r}")


def mass_normalise(X: np.ndarray, M: sp.spmatrix) -> np.ndarray:
    """Scale columns of X (n, m) to unit modal mass x^T M x = 1."""
    mm = np.einsum("ij,ij->j", X, M @ X)
    return X / np.sqrt(mm)


def _solve(K, M, k, sigma, ordering, lu, where):
    n = K.shape[0]
    if n < DENSE_BELOW or k >= n - 1:
        # dense shift-invert: M x = mu (K - sigma M) x, mu = 1 / (lambda - sigma). The low
        # modes are the largest mu, so they are accurate to eps relative to themselves
        # (eigh(K, M) would give eps * lambda_max absolute error on them)
        A = _dense(K) - sigma * _dense(M)
        try:
            mu, X = la.eigh(_dense(M), A, subset_by_index=[n - k, n - 1])
        except la.LinAlgError as exc:  # A not positive definite
            raise ModalError(f"{where}: K - sigma M is not positive definite (sigma = {sigma}): "
                             f"the model is not fully constrained or sigma is above the first "
                             f"eigenvalue") from exc
        return sigma + 1.0 / mu[::-1], X[:, ::-1]
    t0 = time.perf_counter()
    if lu is None:
        report(f"factorising K - sigma M ({n} DOFs)")
        lu = factorize(_shifted(K, M, sigma), ordering, where=where)
    t1 = time.perf_counter()
    solves = 0

    def apply(x):
        # one Lanczos step is one solve with the factor: the count is the progress
        nonlocal solves
        solves += 1
        if solves % 10 == 0:
            report(f"Lanczos, {k} modes: {solves} solves, {time.perf_counter() - t1:.1f} s")
        return lu.solve(x)

    op = spla.LinearOperator((n, n), matvec=apply, dtype=float)
    # fixed start vector: the same input gives the same vectors (degenerate pairs too)
    v0 = np.random.default_rng(0).standard_normal(n)
    lam, X = spla.eigsh(K, k=k, M=M, sigma=sigma, which="LM", OPinv=op, v0=v0,
                        tol=LANCZOS_TOL)
    order = np.argsort(lam)
    logger.info("%s: %d eigenpairs of %d DOFs: factor %.2f s, Lanczos %d solves %.2f s, "
                "omega^2 in [%.4g, %.4g]", where, k, n, t1 - t0, solves,
                time.perf_counter() - t1, lam[order[0]], lam[order[-1]])
    return lam[order], X[:, order]


def _shifted(K, M, sigma: float):
    return K if sigma == 0.0 else K - sigma * M


def _dense(A) -> np.ndarray:
    return A.toarray() if sp.issparse(A) else np.asarray(A)
